"""Bad input to the `skidsteer` command, as a new user types it: a message naming the
option and the value, exit status 2, no traceback; a command the robot cannot follow
warns; a dataset with no usable run says why each file was skipped."""

from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from skidsteer.cli import options as opt
from skidsteer.cli import build_parser, main
from skidsteer.robot import Setup, load_model, resolve

CORPUS = Path(__file__).resolve().parent / "malformed"
EXPECTED = json.loads((CORPUS / "expected.json").read_text())


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    [sub] = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def _is_numeric(action: argparse.Action) -> bool:
    """Read off the option itself: a number type, numeric choices or a numeric default."""
    default = action.default[0] if isinstance(action.default, list) and action.default \
        else action.default
    return (action.type in (int, float) or isinstance(action.type, opt.Bounded)
            or isinstance(action.choices, range)
            or (isinstance(default, (int, float)) and not isinstance(default, bool)))


def _required_argv(parser: argparse.ArgumentParser) -> list[str]:
    """Placeholders for the command's required arguments (nothing runs: parsing fails)."""
    argv = []
    for action in parser._actions:
        if not action.option_strings and action.nargs is None:
            argv.append("placeholder")
        elif action.required and action.option_strings:
            argv += [action.option_strings[0], "placeholder"]
    return argv


NUMERIC = [(name, action.option_strings[-1], action)
           for name, parser in _subparsers().items() for action in parser._actions
           if action.option_strings and _is_numeric(action)]


def test_the_enumeration_finds_the_numeric_options():
    # the parser is read, not a list kept here: these must be among what it finds
    found = {(name, option) for name, option, _ in NUMERIC}
    assert {("swivel", "--omega"), ("swivel", "--settle"), ("sweep", "--omega"),
            ("sweep", "--trials"), ("pull", "--slip-velocity"), ("straight", "--speed"),
            ("diagnose", "--search-starts"), ("compare", "--threads"),
            ("render", "--fps"), ("free-response", "--timestep")} <= found
    assert len(found) >= 31, sorted(found)  # as of this test: 31 in 9 commands


@pytest.mark.parametrize("command, option, action", NUMERIC,
                         ids=[f"{c} {o}" for c, o, _ in NUMERIC])
def test_every_numeric_option_has_a_physical_range(command, option, action):
    assert isinstance(action.type, opt.Bounded), \
        f"skidsteer {command} {option}: give it a cli.options.Bounded type"
    assert action.type.reason, f"skidsteer {command} {option}: its range needs a reason"
    if action.default is not None:  # the default itself is in range
        assert action.type(str(action.default)) == action.default


def _out_of_range(kind: opt.Bounded) -> list[str]:
    """Values past each end of the range (an open low end itself; for a range of
    |value|, a magnitude below it)."""
    num = (lambda x: str(int(x))) if kind.integer else (lambda x: f"{x:g}")  # noqa: E731
    below = kind.low / 2 if kind.magnitude else kind.low - (kind.high - kind.low) - 1
    return [num(kind.high * 2 + 1), num(below)] + ([num(kind.low)] if kind.low_open else [])


BAD_VALUES = [(command, option, bad) for command, option, action in NUMERIC
              if isinstance(action.type, opt.Bounded)
              for bad in ["nan", "inf", "-inf", *_out_of_range(action.type)]]


@pytest.mark.parametrize("command, option, bad", BAD_VALUES,
                         ids=[f"{c} {o}={b}" for c, o, b in BAD_VALUES])
def test_a_bad_number_is_refused_by_name_at_parse_time(command, option, bad, capsys):
    parser = _subparsers()[command]
    # option=value: "-inf" would read as an option of its own
    with pytest.raises(SystemExit) as exit_info:
        main([command, *_required_argv(parser), f"{option}={bad}"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}: invalid value {bad!r}" in err, err
    assert parser._option_string_actions[option].type.allowed in err  # range and reason
    assert "Traceback" not in err


def test_the_reported_nan_omega_is_an_error_not_a_traceback():
    # as a new user ran it: `skidsteer swivel --omega nan` (an OverflowError before)
    done = subprocess.run([sys.executable, "-m", "skidsteer.cli", "swivel", "--omega", "nan"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    assert "argument --omega: invalid value 'nan'" in done.stderr
    assert "[-360, 360] deg/s" in done.stderr


# ------------------------------------------------------------------ the robot's reach

def _reach(robot: str, build: str) -> tuple[float, float]:
    """(rim speed m/s, swivel rate deg/s) its servos' ctrlrange allows, computed here
    from the model (eq. 2.11 inverted: omega = r w / c)."""
    m = load_model(resolve(Setup(robot=robot, build=build)))
    wheel = float(m.actuator_ctrlrange[:, 1].min())  # both models: symmetric, drive only
    # wheel radius and half track, m: the MJCFs' (husky_a200.xml wheel geom size and
    # body y; pioneer3at/parts/drive.xml's radius, Table 5.1's c)
    radius, half_track = (0.1651, 0.2854) if robot == "husky_a200" else (0.1075, 0.18)
    return wheel * radius, math.degrees(wheel * radius / half_track)


def _check(argv: list[str], capsys) -> str:
    """check_after_parse's warnings for a command line (nothing runs)."""
    parser = build_parser()
    opt.check_after_parse(parser, parser.parse_args(argv))
    return capsys.readouterr().err


def test_the_reach_is_the_servos_ctrlrange_at_the_wheel_geometry():
    for robot, build in (("pioneer3at", "extended"), ("husky_a200", None)):
        reach = opt.WheelReach.of(robot, build)
        rim, swivel = _reach(robot, build)
        assert reach.rim_mps == pytest.approx(rim, rel=1e-9)
        assert reach.swivel_deg_s == pytest.approx(swivel, rel=1e-9)


def test_a_swivel_beyond_the_wheels_runs_and_warns(tmp_path, capsys):
    _, swivel = _reach("husky_a200", None)  # 241 deg/s
    out = tmp_path / "run.csv"
    assert main(["swivel", "--model", "husky_a200", "--build", "base", "--floor", "asphalt",
                 "--omega", "-300", "--duration", "1", "--settle", "0.2", "--out", str(out),
                 "--json"]) == 0
    err = capsys.readouterr().err
    assert "warning: --omega -300 deg/s: the robot cannot follow" in err
    assert f"reach {swivel:.0f} deg/s" in err and f"commanded at -{swivel:.0f} deg/s" in err
    assert out.is_file()


@pytest.mark.parametrize("argv, warns", [
    (["swivel", "--model", "husky_a200", "--build", "base", "--omega", "240"], False),
    (["swivel", "--model", "husky_a200", "--build", "base", "--omega", "242"], True),
    (["swivel", "--omega", "360"], False),  # the Pioneer reaches 382 deg/s
    (["sweep", "--out", "x"], False),  # the thesis's omegas, up to 64 deg/s
    (["sweep", "--out", "x", "--build", "platform", "--build", "extended"], False),
    (["sweep", "--out", "x", "--model", "husky_a200", "--build", "base", "--omega", "30",
      "--omega", "250"], True),
    (["pull", "--wheels", "spinning", "--slip-velocity", "1.19"], False),
    (["pull", "--wheels", "spinning", "--slip-velocity", "1.21"], True),
    (["pull", "--wheels", "locked", "--slip-velocity", "3"], False),  # unused when locked
])
def test_a_command_beyond_the_wheels_warns_only_there(argv, warns, capsys):
    err = _check(argv, capsys)
    assert ("the wheels cannot follow" in err or "the robot cannot follow" in err) == warns, err
    if warns:
        assert f"{argv[-2]} {argv[-1]} " in err  # the option and the value named


def test_sweep_warns_of_each_omega_beyond_the_wheels(capsys):
    err = _check(["sweep", "--out", "x", "--model", "husky_a200", "--build", "base",
                  "--omega", "30", "--omega", "250", "--omega=-300"], capsys)
    assert "--omega 250 deg/s" in err and "--omega -300 deg/s" in err
    assert "--omega 30 " not in err


def test_straight_beyond_the_wheels_is_refused_before_it_simulates(capsys):
    rim, _ = _reach("pioneer3at", "extended")  # 1.2 m/s
    with pytest.raises(SystemExit) as exit_info:
        main(["straight", "--speed", "1.25"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "argument --speed: 1.25 m/s is beyond pioneer3at's wheel servos" in err
    assert f"{rim:.3g} m/s at most" in err


@pytest.mark.parametrize("timestep, warns", [("1e-3", False), ("1.5e-3", True)])
def test_a_time_step_past_the_stable_one_warns(timestep, warns, capsys):
    err = _check(["free-response", "--timestep", timestep], capsys)
    assert ("numerical limit cycle" in err) == warns, err


# ------------------------------------------------------------------ skipped runs

def _assert_each_skip_has_its_reason(err: str, expected: dict) -> None:
    lines = {line.split(": ", 1)[0].removeprefix("  skipped "): line
             for line in err.splitlines() if line.startswith("  skipped ")}
    for file, fragments in expected.items():
        assert file in lines, (file, err)
        for fragment in fragments:
            assert fragment in lines[file], (file, lines[file])


def test_compare_with_no_usable_run_gives_each_files_reason(tmp_path, capsys):
    # the corpus's good runs are 2.1 s: readable, too short to compare
    assert main(["compare", str(CORPUS / "dataset"), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skidsteer: {CORPUS / 'dataset'}: no usable runs; each file, "
                          "with the reason:\n")
    _assert_each_skip_has_its_reason(err, {
        **EXPECTED["skipped"],
        **{good: [good, "is too short: the diagnosis needs at least"]
           for good in EXPECTED["good"]}})


def test_diagnose_on_a_malformed_runs_csv_says_why_each_file_is_skipped(tmp_path, capsys):
    data = tmp_path / "dataset"
    shutil.copytree(CORPUS / "dataset", data)
    runs = data / "runs.csv"
    runs.write_text(runs.read_text().replace("omega_deg_s", "omega", 1))  # a bad header
    assert main(["diagnose", str(data), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    described = [p.name for p in data.iterdir() if p.suffix in (".csv", ".xlsx")
                 and p.name != "runs.csv"]
    _assert_each_skip_has_its_reason(err, {
        "runs.csv": ["unusable", "missing column(s) ['omega_deg_s']"],
        **{name: ["no row of runs.csv describes this file (runs.csv is unusable"]
           for name in described}})
