"""The committed benchmark tables are what their scripts make of the committed rows: a
rerun appended to docs/diagnose-generalisation.jsonl (or docs/diagnose-ceiling.jsonl)
and not tabulated again fails here, as would a report that no longer reads the rows."""

from __future__ import annotations

import json
import re

import mujoco
import numpy as np
import pytest

from conftest import REPO
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.benchmark_rows import FIXED, row_outcome, wrong_name

import bench_diagnose_ceiling  # scripts/bench/ and scripts/: pytest's pythonpath
import bench_diagnose_generalisation
import bench_every_command
import update_readme_tables

DOCS = REPO / "docs"


def _body(markdown: str) -> list[str]:
    """The table and its summary: from the first table row on, without the line that
    names the machine the report ran on (the rows record their own code)."""
    lines = markdown.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("|"))
    return [line for line in lines[first:] if not line.startswith("Machine:")]


def _generated_with(markdown: str) -> list[str]:
    """The --draws-from, --ceiling and --rates-from the committed table was generated
    with, as arguments."""
    command = markdown.split("\n\n")[1]
    out = []
    for option in ("--draws-from", "--ceiling"):
        found = re.search(option + r" (\S+?)[` ]", command)
        if found:
            value = found.group(1)
            out += [option, str(REPO / value) if option == "--ceiling" else value]
    found = re.search(r"--rates-from ((?:\d+ ?)+)", command)
    if found:
        out += ["--rates-from", *found.group(1).split()]
    return out


@pytest.mark.parametrize("name", ["generalisation", "ceiling"])
def test_the_committed_benchmark_table_is_its_rows(name, tmp_path, capsys):
    committed = (DOCS / f"diagnose-{name}.md").read_text()
    regenerated = tmp_path / "table.md"
    args = ["--out", str(tmp_path / "out"),
            "--results", str(DOCS / "diagnose-generalisation.jsonl"), "--report",
            "--markdown", str(regenerated), *_generated_with(committed)]
    if name == "ceiling":
        (tmp_path / "out").mkdir()
        args += ["--ceiling", str(DOCS / "diagnose-ceiling.jsonl")]
        bench_diagnose_ceiling.main(args)
    else:
        bench_diagnose_generalisation.main(args)
    capsys.readouterr()  # the report is printed too
    assert _body(regenerated.read_text()) == _body(committed), (
        f"docs/diagnose-{name}.md is not its rows' table; regenerate it with the command "
        "its first paragraph gives")


def test_the_fresh_draw_table_is_the_committed_rows():
    """docs/diagnose.md's rates on fresh draws are the two benchmarks' rows as the rules
    judge them now (a rule change that moves a row moves the table too)."""
    shown = update_readme_tables.between_markers(
        update_readme_tables.DIAGNOSE_DOC.read_text(), "fresh-draws")
    assert shown == update_readme_tables.fresh_draws_table(), (
        "docs/diagnose.md's fresh-draw table is not its rows'; regenerate it with "
        "python scripts/update_readme_tables.py --fresh-draws-only")


def test_recovery_counts_fitted_parameters_of_the_hidden_cause_only():
    def row(effect, truth, fit_cause, parameters, fitted, interval=None):
        return {"effect": effect, "truth": truth,
                "ranking": [{"cause": fit_cause, "parameters": parameters, "fitted": fitted,
                             **({"interval": interval, "train_errors_over_starts": [1.5] * 5}
                                if interval else {})}]}

    # five rows kept their intervals: three hold the hidden value (one on its edge, one
    # by spanning the prior, 0.003-1: open on both sides), two of the four bounded ones
    rows = [row("slip_lambda_max", {"lambda_max": 0.005}, "slip_lambda_max",
                {"lambda_max": 0.006}, ["lambda_max"], interval) for interval in
            ({"lambda_max": [0.0045, 0.0065]}, {"lambda_max": [0.005, 0.0065]},
             {"lambda_max": [0.0055, 0.0065]}, {"lambda_max": [0.0052, 0.0061]},
             {"lambda_max": [0.003, 1.0]}, None)]
    # an interval read against the narrower bound of draws 1201-1208 (no training errors
    # over the starts kept): its fit counts, its interval does not
    narrow = row("slip_lambda_max", {"lambda_max": 0.005}, "slip_lambda_max",
                 {"lambda_max": 0.006}, ["lambda_max"], {"lambda_max": [0.0045, 0.0065]})
    del narrow["ranking"][0]["train_errors_over_starts"]
    rows += [
        narrow,
        # below the hidden value; a tie (dropped from the sign test, kept in the median)
        row("slip_lambda_max", {"lambda_max": 0.005}, "slip_lambda_max",
            {"lambda_max": 0.004}, ["lambda_max"]),
        row("slip_lambda_max", {"lambda_max": 0.005}, "slip_lambda_max",
            {"lambda_max": 0.005}, ["lambda_max"]),
        # another cause's fit, and a parameter held at its prior: not counted
        row("slip_lambda_max", {"lambda_max": 0.005}, "friction_levels",
            {"mu_static": 0.5}, ["mu_static"]),
        row("sensor_mount", {"frequency_hz": 20.0, "damping_ratio": 0.1}, "sensor_mount",
            {"frequency_hz": 21.0, "damping_ratio": 0.05}, ["frequency_hz"]),
        # an interval open below (mu_s' prior starts at 0.4): none bounded on both sides
        row("friction_levels", {"mu_static": 0.5}, "friction_levels", {"mu_static": 0.45},
            ["mu_static"], {"mu_static": [0.4, 0.6]}),
        {"effect": None, "truth": {}, "ranking": []}]
    found = {(c["cause"], c["parameter"]): c for c in bench_diagnose_generalisation.recovery(rows)}
    assert set(found) == {("slip_lambda_max", "lambda_max"), ("sensor_mount", "frequency_hz"),
                          ("friction_levels", "mu_static")}
    slip = found["slip_lambda_max", "lambda_max"]
    assert (slip["fits"], slip["above"]) == (9, 7)
    assert slip["median"] == pytest.approx(1.2)
    # 7 above, 1 below: two-sided sign test 2 (1 + 8) / 2^8
    assert slip["p"] == pytest.approx(18 / 256)
    assert (slip["with_interval"], slip["inside"]) == (5, 3)
    assert (slip["bounded"], slip["bounded_inside"]) == (4, 2)
    assert found["sensor_mount", "frequency_hz"]["with_interval"] == 0
    shown = bench_diagnose_generalisation.recovery_table(rows)
    assert "| slip_lambda_max | lambda_max | 9 | 7 | 1.20 |" in shown
    assert "| 0.070 | 3 of 5 | 2 of 4 |" in shown and "| 1.000 | - | - |" in shown
    assert "| 1 of 1 | - |" in shown  # friction_levels: held by its open interval


def test_a_wrong_name_is_a_named_cause_not_a_null_said_unexplained():
    """The fresh-draws table's "wrong names" (docs/diagnose.md) counts causes named wrong;
    a null said "unexplained" (issue 21's draw 1211: the base model at 2.003 against the
    2.0 limit) is a wrong outcome that names nothing, counted in the nulls' column
    instead."""
    with (DOCS / "diagnose-generalisation.jsonl").open() as f:
        rows = {r["case"]: r for r in map(json.loads, f)}
    right = next(r for r in rows.values() if row_outcome(r) == "right"
                 and r["effect"] in causes.CAUSES and "ranking" in r and "base_train" in r)
    assert not wrong_name(right)
    # the same row with its hidden effect swapped for another cause: named, and wrong
    other = next(c for c in sorted(causes.CAUSES) if c != right["effect"])
    assert wrong_name({**right, "effect": other})
    # a null the verdict does not call no-discrepancy: wrong, but no name
    null = {**right, "effect": None, "baseline_error": 2.003, "held_out": [1.42, 1.48],
            "verdict": "unexplained", "cause": None, "ranking": []}
    assert row_outcome(null) == "wrong"
    assert not wrong_name(null)


@pytest.mark.parametrize("option, named", [(["--timestep", "5e-05"], "step"),
                                           (["--model-spread"], "model_spread"),
                                           (["--rough-floor-normal", "surface"],
                                            "rough_floor_normal")])
def test_a_results_file_holds_rows_of_one_step_and_one_scale(tmp_path, capsys, option,
                                                              named):
    # rows simulated at another step (--timestep), read against another scale
    # (--model-spread) or on a rough floor with another contact normal
    # (--rough-floor-normal) must not join the committed table's rows, which are all at
    # the model's own step, the trials' scale and the plugin's default normal: the
    # benchmark refuses before running,
    # naming the file and what differs
    results = tmp_path / "rows.jsonl"
    row = json.loads((DOCS / "diagnose-generalisation.jsonl").read_text().splitlines()[-1])
    results.write_text(json.dumps(row) + "\n")  # written before rows recorded either
    with pytest.raises(SystemExit) as stopped:
        bench_diagnose_generalisation.main(["--out", str(tmp_path), "--results", str(results),
                                            "--datasets", "0", *option])
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert str(results) in err and named in err


def test_rigid_belts_stiffen_the_belt_couplings_only():
    import mechanism_features  # scripts/, on pytest's pythonpath
    from skidsteer.robot import load_model

    shipped = load_model("extended", "concrete")
    rigid = load_model("extended", "concrete", edit=mechanism_features.rigid_belts)
    joints = shipped.eq_type == mujoco.mjtEq.mjEQ_JOINT
    assert joints.sum() == 2  # a belt per side (models/pioneer3at/parts/drive.xml)
    np.testing.assert_array_equal(rigid.eq_solref[joints],
                                  [mechanism_features.RIGID_SOLREF] * int(joints.sum()))
    np.testing.assert_array_equal(rigid.eq_solimp[joints],
                                  [mechanism_features.RIGID_SOLIMP] * int(joints.sum()))
    # nothing else of the model moves
    np.testing.assert_array_equal(rigid.body_mass, shipped.body_mass)
    assert rigid.opt.timestep == shipped.opt.timestep


def _missed_with_proposal(rows: dict, separation: float) -> dict:
    """A committed row that names its hidden cause, turned into a miss whose report
    proposes a swivel `separation` RMS z apart (the verdict made unexplained by a
    ranking the rules cannot name from)."""
    right = next(r for r in rows.values() if row_outcome(r) == "right"
                 and r["effect"] in causes.CAUSES and "ranking" in r and "base_train" in r)
    return {**right, "ranking": [], "verdict": "unexplained", "cause": None,
            "next_command_purpose": "separate",
            "next_commands": [{"command": "v0-w60", "omega_deg_s": 60.0,
                               "separation": separation}]}


def test_the_loop_counts_the_second_verdict_only_where_a_command_was_worth_recording():
    """(c): a row whose report proposes a command worth recording counts the diagnosis
    made with that command held out; one whose proposal is below the limit counts its
    first verdict (the report says no swivel would tell); one that should have followed
    and did not is not counted."""
    from skidsteer.diagnosis.benchmark_rows import loop_outcome, proposal_to_follow
    from skidsteer.diagnosis.verdict import Z_CONSISTENT

    with (DOCS / "diagnose-generalisation.jsonl").open() as f:
        rows = {r["case"]: r for r in map(json.loads, f)}
    named = next(r for r in rows.values() if row_outcome(r) == "right"
                 and r["effect"] in causes.CAUSES and "ranking" in r and "base_train" in r)
    below = _missed_with_proposal(rows, Z_CONSISTENT - 0.01)
    assert proposal_to_follow(below) is None and loop_outcome(below) == "missed"
    above = _missed_with_proposal(rows, Z_CONSISTENT)
    assert proposal_to_follow(above)["command"] == "v0-w60"
    assert loop_outcome(above) is None  # not followed: unknown, not a miss
    assert loop_outcome({**above, "loop": named}) == "right"
    assert loop_outcome({**above, "loop": above}) == "missed"
    old = {k: v for k, v in named.items() if k not in ("next_commands", "loop")}
    assert loop_outcome(old) is None  # written before proposals were kept


def test_three_rates_count_each_rate_on_its_own_rows():
    from skidsteer.diagnosis.benchmark_rows import rate_interval, three_rates

    with (DOCS / "diagnose-generalisation.jsonl").open() as f:
        rows = {r["case"]: r for r in map(json.loads, f)}
    right = next(r for r in rows.values() if row_outcome(r) == "right"
                 and r["effect"] in causes.CAUSES and "ranking" in r and "base_train" in r)
    right = {**right, "next_commands": []}  # as a row written with the loop keeps them
    missed = _missed_with_proposal(rows, 3.0)
    missed = {**missed, "case": "x", "effect": right["effect"]}
    other = next(c for c in sorted(causes.CAUSES) if c != right["effect"])
    wrong_after = {**missed, "case": "y", "loop": {**right, "effect": other}}
    rates = three_rates([right, missed, wrong_after], truths={})
    mine = rates[right["effect"]]
    assert mine["named"] == (1, 3)
    assert mine["ceiling"] == (0, 0)  # no ceiling rows given
    assert mine["loop"] == (1, 2)  # "x" did not follow its proposal; "y" did, and named wrong
    assert mine["followed"] == 1 and mine["wrong"] == 1
    assert rates["all"]["named"] == (1, 3)
    low, high = rate_interval(1, 3)
    assert 0.0 < low < 1 / 3 < high < 1.0
    assert rate_interval(0, 0) is None
    # Clopper-Pearson's 95 % interval of 17 of 20 (a textbook value: 0.621-0.968)
    assert rate_interval(17, 20) == pytest.approx((0.621, 0.968), abs=1e-3)


def test_following_a_proposal_diagnoses_the_draw_with_the_command_added_and_held_out(
        monkeypatch, tmp_path):
    calls = []

    def run_case(case, out, trials, duration_s, threads, search_starts, timestep,
                 model_spread, rough_floor_normal, held_out=None, loop=False):
        calls.append((case, held_out, loop))
        return {"case": case["case"], "held_out": [3.0, 1.5]}

    monkeypatch.setattr(bench_diagnose_generalisation, "run_case", run_case)
    case = {"case": "draw-9", "effect": "mast_compliance", "seed": 9, "floor": "tile",
            "omegas": (10.0, 20.0, 30.0), "params": None}
    row = {"next_command_purpose": "confirm",
           "next_commands": [{"command": "v0-w50 tile extended", "omega_deg_s": 50.0,
                              "separation": 2.5},
                             {"command": "v0-w40 tile extended", "omega_deg_s": 40.0,
                              "separation": 2.2}]}
    second = bench_diagnose_generalisation.follow_up(row, case, tmp_path, 3, 20.0, 1, 3,
                                                     None, False, None)
    (followed, held_out, loop), = calls
    assert followed["omegas"] == (10.0, 20.0, 30.0, 50.0) and followed["seed"] == 9
    assert followed["case"] == "draw-9-plus50" and held_out == ["v0-w50 tile extended"]
    assert not loop  # one loop: the second report is not followed again
    assert second["followed"]["command"] == "v0-w50 tile extended"
    assert second["purpose"] == "confirm"
    calls.clear()
    quiet = {**row, "next_commands": [{**row["next_commands"][0], "separation": 1.0}]}
    assert bench_diagnose_generalisation.follow_up(quiet, case, tmp_path, 3, 20.0, 1, 3,
                                                   None, False, None) is None
    assert not calls


def test_the_every_command_table_is_its_rows(tmp_path, capsys):
    """docs/diagnose-every-command.md is what the script makes of its committed rows, each
    judged both ways by the rules as they are now."""
    regenerated = tmp_path / "table.md"
    bench_every_command.main(["--out", str(tmp_path), "--results",
                              str(DOCS / "diagnose-generalisation.jsonl"), "--every",
                              str(DOCS / "diagnose-every-command.jsonl"), "--report",
                              "--markdown", str(regenerated)])
    capsys.readouterr()
    assert _body(regenerated.read_text()) == _body(
        (DOCS / "diagnose-every-command.md").read_text()), (
        "docs/diagnose-every-command.md is not its rows' table; regenerate it with the "
        "command its first paragraph gives")


def test_every_command_reads_the_single_split_from_the_fold_holding_out_the_rows_command():
    groups = ["v0-w20 tile extended", "v0-w40 tile extended", "v0-w60 tile extended"]

    def fold(held, base_held, cause_held):
        return {"dataset": {"groups": groups, "held_out_groups": [held]},
                "verdict": "?", "cause": None,
                "ranking": [{"cause": "loose_payload", "held_out_error": cause_held,
                             "train_error": 1.3, "score": cause_held ** 2 + 2 / 6,
                             "fitted": ["frequency_hz"], "parameters": {"frequency_hz": 9.0}}],
                "gain": {"baseline_error": base_held, "noise_error": 1.0},
                "baseline_error_all_runs": 3.0, "baseline_error_training": 3.2,
                "training_runs": 6, "wall_time_s": 100.0}

    # the middle command is quiet: held out alone, it confirms nothing; the others name
    row = {"case": "draw-9", "effect": "loose_payload", "seed": 9,
           "single_held_out": groups[1], "row_outcome": "missed", "row_code": "old",
           "row_diagnose_s": 500.0,
           "folds": [fold(groups[0], 4.0, 1.3), fold(groups[1], 1.7, 1.4),
                     fold(groups[2], 3.5, 1.2)]}
    seen = bench_every_command.judged(row)
    assert seen["single"]["outcome"] == "missed" and seen["single"]["base_held"] == 1.7
    assert seen["every"]["outcome"] == "right" and seen["every"]["cause"] == "loose_payload"
    assert seen["single"]["diagnose_s"] == 100.0 and seen["every"]["diagnose_s"] == 300.0
    assert "every command: 1 of 1 (100%)" in bench_every_command.report([row])


def test_rates_are_read_per_block_of_draws():
    # each block of fresh draws is one code's run: from its first seed to the next
    # block's less one, the last open-ended; fixed cases are in none
    rows = [{"case": f"draw-{s}", "seed": s} for s in (1299, 1300, 1359, 1360, 1400)]
    rows.append({"case": next(iter(FIXED)), "seed": 1330})
    blocks = bench_diagnose_generalisation.rate_blocks(rows, [1360, 1300])
    assert [[r["seed"] for r in block] for block in blocks] == [[1300, 1359], [1360, 1400]]
