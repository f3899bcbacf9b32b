"""Writes what ``skidsteer diagnose`` found on real recordings: diagnosis.json, report.md,
the figures and the identified robot.  Nothing here decides: diagnosis.recordings
does, this renders its result."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from skidsteer.data.files import begin_outputs, finish_outputs, write_json, write_text
from skidsteer.diagnosis import extended_robot, identify, motion
from skidsteer.diagnosis.recordings import diagnose_terrains
from skidsteer.reports import figures as plots
from skidsteer.reports.markdown import fmt, table
from skidsteer.robot import load_robot

RESULT = "diagnosis.json"


def diagnose_recordings(paths, out, model: str = "husky_a200", progress: bool = True,
                        nthread: int = 2, leave_one_out: bool = True,
                        candidates=None, lines: bool = True) -> dict:
    """Diagnoses the recordings at paths (terrain folders, or folders of them) and writes
    out/diagnosis.json, report.md, figures/ and the identified robot
    (extended_model.xml with robot.toml)."""
    out = Path(out)
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    begin_outputs(out, RESULT, "diagnose")
    result = diagnose_terrains(paths, model, progress, nthread, candidates, leave_one_out,
                               with_lines=lines)
    robot = load_robot(model)
    named = result.pop("_named", None)
    result["extended_model"] = str(extended_robot.write(
        out, robot, model, named,
        {name: {"floor": t["floor"], "setup_floor": t["setup_floor"],
                "rigid": not t["ground"]["deformable"], "identified": t.get("identified")}
         for name, t in result["terrains"].items()},
        result.get("rigid_rolling_current_a"), [str(p) for p in paths]))
    figures = out / "figures"
    result["figures"] = [str(p.relative_to(out)) for p in write_figures(result, figures)]
    write_text(out / "report.md", render(result))
    finish_outputs(out, RESULT, lambda path: write_json(path, result, indent=1))
    return result


# ------------------------------------------------------------------ figures

def write_figures(result: dict, folder: Path) -> list[Path]:
    """chi per segment (measured, base, extended) per terrain, and each terrain's straight
    segment spectrum (recorded, base, extended) when the lines were diagnosed."""
    plt = plots.pyplot()
    folder.mkdir(parents=True, exist_ok=True)
    made = []
    terrains = result["terrains"]
    fig, axes = plt.subplots(1, len(terrains), figsize=(4.2 * len(terrains), 3.6), squeeze=False)
    for ax, (name, t) in zip(axes[0], terrains.items()):
        rows = [r for r in t["rows"] if r["kind"] in identify.TURN_KINDS
                and r["chi_measured"] is not None and r["yaw_rate_predicted_deg_s"] is not None
                and abs(r["yaw_rate_predicted_deg_s"]) >= identify.MIN_TURN_DEG_S]
        x = np.arange(len(rows))
        for key, style in (("measured", "ko"), ("base", "rx"), ("extended", "b+")):
            y = [r.get(f"chi_{key}") for r in rows]
            y = [np.nan if v is None else v for v in y]
            ax.plot(x, y, style, ms=4, label=key)
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(plt.FormatStrFormatter("%.1f"))
        ax.yaxis.set_minor_formatter(plt.FormatStrFormatter("%.1f"))
        ax.set_title(f"{name} ({'deformable' if t['ground']['deformable'] else 'rigid'})")
        ax.set_xlabel("turning segment (run order)")
        ax.set_ylabel("chi = predicted / measured yaw rate")
        ax.legend(fontsize=7)
    made.append(plots.save(fig, folder / "chi_per_segment.png"))
    for name, spectrum in (result.get("lines") or {}).get("spectra", {}).items():
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.4), sharey=True)
        for a, ax in enumerate(axes):
            for key, style in (("recorded", "k-"), ("base", "r-"), ("extended", "b-")):
                if spectrum.get(key) is not None:
                    ax.semilogy(spectrum[key]["frequency_hz"],
                                np.asarray(spectrum[key]["psd"])[:, a], style, lw=0.8,
                                label=key)
            ax.set_title(f"{name}, a_{'xyz'[a]}")
            ax.set_xlabel("frequency (Hz)")
        axes[0].set_ylabel("PSD ((m/s^2)^2/Hz)")
        axes[0].legend(fontsize=7)
        made.append(plots.save(fig, folder / f"spectrum_{name.lower()}.png"))
    return made


# ------------------------------------------------------------------ report.md

def render(result: dict) -> str:
    m = result["motion"]
    md = [f"# Diagnosis of recordings on {result['model']}\n\n",
          f"Terrains: {', '.join(result['terrains'])}.  Alternate runs of each terrain train "
          "(the first, third, ...); the others are held out.  Wall time "
          f"{result['wall_time_s']} s, {result['simulations']} surrogate simulations.\n\n",
          f"**Motion: {m['verdict']}**" + (f" (cause: {m['cause']})" if m["cause"] else "")
          + f". {m['reason']}\n\n"]
    md.append(chi_section(result))
    if m["named"]:
        md.append(parameter_section(m["named"]))
    md.append(fits_section(m))
    md.append(ground_section(result))
    if result.get("leave_one_terrain_out"):
        md.append(loto_section(result["leave_one_terrain_out"]))
    if result.get("lines"):
        md.append(lines_section(result["lines"]))
    md.append(f"\nThe identified robot: `{result['extended_model']}` (with robot.toml beside "
              "it: `--model` takes either).\n")
    if result["skipped"]:
        md.append("\n## Skipped\n\n" + table(["file", "reason"], [[s["file"], s["reason"]]
                                                                  for s in result["skipped"]]))
    notes = [n for ns in result["notes"].values() for n in ns]
    if notes:
        md.append("\n## What the readers found\n\n" + "".join(f"- {n}\n" for n in notes))
    return "".join(md)


def chi_section(result: dict) -> str:
    rows = []
    for name, t in result["terrains"].items():
        for kind in identify.TURN_KINDS:
            for half in ("held_out", "fit"):
                e = t["chi"].get(f"{kind}/{half}")
                if not e:
                    continue
                rows.append([name, kind.replace("_", " "), half.replace("_", "-"), e["n"],
                             f"{e['measured']:.2f} +- {e.get('stderr') or 0:.2f}",
                             fmt(e.get("base"), ".2f"), fmt(e.get("extended"), ".2f"),
                             relative_off(e.get("extended"), e["measured"])])
    k_rows = []
    for name, t in result["terrains"].items():
        for half, entry in t.get("centripetal_ratio", {}).items():
            m = entry["measured"]
            if m["k"] is None:
                continue
            k_rows.append([name, half.replace("_", "-"), m["n"], f"{m['k']:.2f} +- {m['stderr']:.2f}",
                           fmt(entry["base"]["k"], ".2f"), fmt(entry["extended"]["k"], ".2f")])
    return ("## How the robot turns (replays of every run)\n\n"
            + table(["terrain", "kind", "runs", "segments", "chi measured", "base model",
                     "extended", "extended vs measured"], rows)
            + "\nThe centripetal ratio k (a_y over v Omega, each run's IMU bias its own: the "
            "robot's true speed over the logged one, blind to friction), the recording "
            "against replays of the same runs:\n\n"
            + table(["terrain", "runs", "segments", "k measured", "base model", "extended"],
                    k_rows) + "\n")


def relative_off(model, measured) -> str:
    """The model against the measured value as a signed percentage, "-" without both."""
    return "-" if model is None or not measured else f"{(model / measured - 1):+.1%}"


def parameter_section(named: dict) -> str:
    priors = {p.name: p.prior for c in motion.MOTION_CAUSES.values() for p in c.parameters}
    rows = [[k, "robot", f"{v:.4g}", _interval(named["intervals"].get(k)),
             f"{priors[k].low:g}-{priors[k].high:g}", priors[k].source]
            for k, v in named["robot"].items()]
    for terrain, values in named["terrain"].items():
        rows += [[k, terrain, f"{v:.4g}", _interval(named["intervals"].get(f"{k}@{terrain}")),
                  f"{priors[k].low:g}-{priors[k].high:g}", priors[k].source]
                 for k, v in values.items()]
    laws = "; ".join(f"{k} = {v}" for k, v in named["settings"].items())
    return ("\n## Identified\n\n" + (f"Settings: {laws}.\n\n" if laws else "")
            + table(["parameter", "of", "value", "interval", "prior", "source"], rows) + "\n")


def _interval(v) -> str:
    return "-" if not v else f"{v[0]:.3g} to {v[1]:.3g}"


def fits_section(m: dict) -> str:
    rows = [[f["cause"], f"{f['train_error']:.2f}", f"{f['held_out_error']:.2f}",
             f"{f['score']:.2f}", f["implausible"] or ""] for f in m["fits"]]
    base = m["base"]
    head = (f"Base model: training error {base['train_error']:.2f}, held-out "
            f"{base['held_out_error']:.2f} (RMS z against the segments' scatter).\n\n"
            if base else "")
    return ("\n## Every fit (robot causes first, then the terrains')\n\n" + head
            + table(["causes", "training error", "held-out error", "score", "not named because"],
                    rows) + "\n")


def ground_section(result: dict) -> str:
    rows = []
    for name, t in result["terrains"].items():
        g = t["ground"]
        rows.append([name, "deformable" if g["deformable"] else "rigid",
                     fmt(g["rolling_current_a"], ".2f"), fmt(g["rolling_current_ratio"], ".2f"),
                     f"{g['stuck_segments']} of {g['turning_segments']}",
                     "; ".join(g["evidence"]) or "-"])
    return ("\n## Rigid or deformable ground\n\n"
            + table(["terrain", "ground", "straight-driving current (A)", "x rigid",
                     "stuck turning segments", "evidence"], rows) + "\n")


def loto_section(loto: list[dict]) -> str:
    rows = []
    for e in loto:
        for feature, measured in e["measured"]["held_out"].items():
            if not feature.startswith("chi"):
                continue
            no_fit = e["no_fit"]["held_out"].get(feature)
            fitted = e["fitted_held_out"].get(feature)
            rows.append([e["terrain"], ", ".join(e["robot_from"]), feature, f"{measured:.2f}",
                         fmt(no_fit, ".2f"), relative_off(no_fit, measured), fmt(fitted, ".2f"),
                         relative_off(fitted, measured)])
    return ("\n## Leave one terrain out (held-out runs; surrogate)\n\n"
            "The robot fitted on the other terrains; the left-out terrain with its own "
            "parameters at the robot's default (no fit), then fitted on its training runs.\n\n"
            + table(["terrain", "robot from", "feature", "measured", "no fit", "off",
                     "terrain fitted", "off"], rows) + "\n")


def lines_section(lines: dict) -> str:
    md = [f"\n## Vibration of the straight segments\n\n**{lines['verdict']}**"
          + (f" (cause: {lines['cause']})" if lines.get("cause") else "")
          + f". {lines['reason']}\n\n"]
    fits = lines.get("fits", [])
    if fits:
        md.append(table(["cause", "fitted", "training error", "held-out error"],
                        [[f["cause"], ", ".join(f"{k} {_list(v)}" for k, v in
                                                f["parameters"].items()),
                          f"{f['train_error']:.2f}", f"{f['held_out_error']:.2f}"]
                         for f in fits]) + "\n")
    for name, t in lines.get("terrains", {}).items():
        held = t["held_out"]
        causes = [c for c in held if c not in ("measured", "base")]
        rows = [[feature, fmt(held["measured"].get(feature), ".1f"),
                 fmt(held["base"].get(feature), ".1f"),
                 *[fmt(held[c].get(feature), ".1f") for c in causes]]
                for feature in held["measured"]]
        md.append(f"\n{name}, held-out straight segments (median dB: lines (m/s^2)^2, RMS "
                  f"m/s^2; speeds {', '.join(f'{v:.2f}' for v in t['speeds_mps'])} m/s):\n\n"
                  + table(["feature", "recorded", "base model", *causes], rows) + "\n")
    return "".join(md)


def _list(value) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(f"{v:.3g}" for v in value) + "]"
    return f"{value:.4g}" if isinstance(value, float) else str(value)
