"""`skidsteer compare` and `skidsteer diagnose`: read a dataset, compare or diagnose it,
write the outputs.

``compare(dataset_dir, out_dir)`` and ``diagnose(dataset_dir, out_dir)`` are the
two commands: they read the dataset onto the robot (data.read_dataset), reduce
it to features (diagnosis.Observed), run diagnosis.diagnose_observed (or only
its base model), and write comparison.json / diagnosis.json, report.md, figures
and the extended model.  Until they have finished, the output directory holds
the unfinished-output marker and no result file (data.files.begin_outputs).
"""

from __future__ import annotations

import json
import sys
import threading
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from skidsteer.data.dataset import read_dataset
from skidsteer.data.files import begin_outputs, finish_outputs, write_json, write_text
from skidsteer.diagnosis import causes as cause_registry
from skidsteer.diagnosis.command_table import group_table, significant
from skidsteer.diagnosis.comparison import (SIGNIFICANT_Z, Comparison, Observed, Simulated,
                                            group_wheel_rates, model_factory, require_spread)
from skidsteer.diagnosis.diagnose import (base_error_over_starts, base_verdict,
                                          diagnose_observed, simulations_planned)
from skidsteer.diagnosis.evaluate import SEARCH_STARTS, STARTS
from skidsteer.diagnosis.intervals import unprobed_note
from skidsteer.diagnosis.next_command import CONFIRM, PROPOSAL_STARTS, worth_recording
from skidsteer.diagnosis.split import held_out_groups, holds_out_commands
from skidsteer.diagnosis.verdict import Z_CONSISTENT
from skidsteer.features import signals
from skidsteer.features.extract import (AXES, STEADY_FROM_S, comparison_feature_names,
                                        steady_window)
from skidsteer.reports import figures as plots
from skidsteer.reports.markdown import fmt, table
from skidsteer.robot import load_spec
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.cache import CACHE_DIR, SimulationCache, numeric_platform
from skidsteer.simulation.sensor_chain import SensorChain


class _Progress:
    """A tqdm bar that several threads (fits on a cluster) can advance.  Its total is a
    plan (diagnose.simulations_planned: searches often stop early); a run past it raises
    it, and the finished bar's total is what ran."""

    def __init__(self, total: int, enabled: bool, what: str):
        self.bar = tqdm(total=total, unit="run", desc=what, file=sys.stderr,
                        disable=not enabled)
        self.lock = threading.Lock()

    def __call__(self, n: int) -> None:
        with self.lock:
            if self.bar.total is not None and self.bar.n + n > self.bar.total:
                self.bar.total = self.bar.n + n
            self.bar.update(n)

    def close(self) -> None:
        with self.lock:
            self.bar.total = self.bar.n
            self.bar.refresh()
        self.bar.close()


def _observed(dataset_dir, model: str | None) -> Observed:
    dataset = read_dataset(dataset_dir, robot=model)
    observed = Observed.from_dataset(dataset, group_wheel_rates(model_factory()))
    require_spread(observed, str(dataset_dir))  # before any simulation
    return observed


def _model_label(model: str | None) -> str:
    return model or "built-in (per run's build)"


# ------------------------------------------------------------------ the commands

def diagnose(dataset_dir, out_dir=None, *, model: str | None = None,
             candidates: list[str] | None = None, nthread: int = 2, progress: bool = True,
             timestep: float | None = None, chain: SensorChain = SensorChain(),
             figures: bool = True, backend=None, cache_dir=None,
             search_starts: int = SEARCH_STARTS, model_spread: bool = False,
             next_command: bool = True, held_out: list[str] | None = None) -> dict:
    """Diagnoses a measured dataset; writes diagnosis.json, report.md, figures and the
    extended model to out_dir when given.  Returns the diagnosis.

    model: the robot the runs were recorded on (a robot's name, its folder, or an MJCF
    file; default: the built-in robot, each run's build).  backend: where the
    simulations run (simulation.backends; default nthread local threads).

    cache_dir: where every finished simulation is kept (simulation.cache; default
    out_dir/.skidsteer-cache, none without out_dir), so that a killed diagnosis,
    rerun, resumes where it stopped and reaches the same numbers, and diagnoses of
    several datasets of one robot share their simulations.

    search_starts: the simulated starts a fit's training error is the median over
    (diagnosis.evaluate.SEARCH_STARTS; the search costs as many times the simulations).

    model_spread: read every error against the trials' spread and the base model's own
    start-to-start spread together (diagnosis.comparison.Comparison.with_model_spread).

    next_command: propose the swivel that tells two undecided candidates apart, or that
    would confirm the training runs' lead when the held-out runs show no discrepancy
    (diagnosis.next_command; simulated only on such verdicts).

    held_out: the commands whose runs test the fits, by label or command alone
    (diagnosis.split.held_out_groups; default: the diagnosis chooses, diagnosis.split.split).
    """
    started = time.time()
    backend = backend or LocalBackend(nthread)
    if cache_dir is None and out_dir is not None:
        cache_dir = Path(out_dir) / CACHE_DIR
    stored = SimulationCache(cache_dir) if cache_dir is not None else None
    observed = _observed(dataset_dir, model)
    if held_out is not None:  # before anything is simulated or written
        try:
            held_out_groups(observed, held_out)
        except ValueError as err:
            raise ValueError(f"{dataset_dir}: {err}") from None
    if out_dir is not None:
        begin_outputs(Path(out_dir), "diagnosis.json", "diagnose",
                      f"; finished simulations are kept in {cache_dir}, and the same command "
                      "rerun resumes from them")
    names = candidates or sorted(cause_registry.CAUSES)
    bar = _Progress(simulations_planned(names, observed, search_starts, held_out), progress,
                    "diagnose")
    try:
        # a report plots the base model: its time series are needed, so with out_dir
        # it is always simulated (a twentieth of a diagnosis)
        found = diagnose_observed(observed, names, timestep=timestep, chain=chain,
                                  backend=backend, progress=bar, cache=stored,
                                  signals=out_dir is not None, search_starts=search_starts,
                                  model_spread=model_spread, next_command=next_command,
                                  held_out=held_out)
    finally:
        bar.close()
    summary = found.summary()
    summary["dataset"] = {"root": str(Path(dataset_dir)), **summary["dataset"]}
    summary["model"] = _model_label(model)
    summary["simulations"] = ({"simulated": stored.stores, "reused": stored.hits,
                               "cache": str(stored.root)} if stored else None)
    summary["platform"] = numeric_platform()
    summary["search_starts"] = search_starts
    summary["model_spread"] = model_spread
    summary["wall_time_s"] = round(time.time() - started, 1)
    if out_dir is not None:
        write_diagnosis(Path(out_dir), summary, found, timestep, figures)
    return summary


def compare(dataset_dir, out_dir=None, *, model: str | None = None, nthread: int = 2,
            progress: bool = True, timestep: float | None = None,
            chain: SensorChain = SensorChain(), figures: bool = True, backend=None) -> dict:
    """Simulates every command of a dataset with the base model and scores each feature
    against the trials' spread; writes comparison.json, report.md and figures.

    The error and the verdict are diagnose's (the median over STARTS simulated starts);
    the table and figures show the simulation from rest."""
    started = time.time()
    backend = backend or LocalBackend(nthread)
    observed = _observed(dataset_dir, model)
    if out_dir is not None:
        begin_outputs(Path(out_dir), "comparison.json", "compare")
    bar = _Progress(len(observed.groups) * STARTS, progress, "compare")
    try:
        observed, comparison, base, error = base_error_over_starts(
            observed, timestep=timestep, chain=chain, backend=backend, progress=bar)
    finally:
        bar.close()
    summary = {
        "baseline_error_all_runs": error,
        "verdict": base_verdict(error),
        "discrepancies": comparison.discrepancies(base.features),
        "skipped_runs": observed.skipped,
        "dataset": {"root": str(Path(dataset_dir)), "runs": len(observed.run_files),
                    "groups": [g.label for g in observed.groups],
                    "duration_s": observed.duration_s},
        "model": _model_label(model),
        "platform": numeric_platform(),
        "wall_time_s": round(time.time() - started, 1),
    }
    if out_dir is not None:
        write_comparison(Path(out_dir), summary, observed, comparison, base, figures)
    return summary


# ------------------------------------------------------------------ figures

def plot_spectra(observed: Observed, models: dict[str, Simulated], path: Path,
                 max_groups: int = 4) -> Path:
    plt = plots.pyplot()
    groups = observed.groups[:max_groups]
    fig, axes = plt.subplots(len(groups), 3, figsize=(12, 2.6 * len(groups)), squeeze=False,
                             sharex=True)
    for gi, g in enumerate(groups):
        members = np.flatnonzero(observed.run_group == gi)
        for k, a in enumerate(AXES):
            ax = axes[gi, k]
            for n, i in enumerate(members):
                t, acc = observed.records[i]
                f, p = signals.welch_spectrum(steady_window(t, acc)[:, k], signals.sample_rate(t))
                ax.semilogy(f, p, color="0.5", lw=0.8, label="measured trials" if n == 0 else None)
            for (name, sim), color in zip(models.items(), ("C0", "C3", "C2")):
                t, acc = sim.time_s[gi], sim.accel[gi]
                f, p = signals.welch_spectrum(steady_window(t, acc)[:, k], signals.sample_rate(t))
                ax.semilogy(f, p, color=color, lw=1.0, label=name)
            ax.set_xlim(0, 55)
            ax.set_title(f"{g.label}: a_{a}", fontsize=9)
            if k == 0:
                ax.set_ylabel("PSD (m/s^2)^2/Hz")
            if gi == len(groups) - 1:
                ax.set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"steady window (from {STEADY_FROM_S:g} s): measured vs simulated")
    return plots.save(fig, path)


def plot_features_vs_omega(rows: list[dict], models: list[str], path: Path) -> Path:
    plt = plots.pyplot()
    omega = np.array([r["omega_deg_s"] for r in rows])
    fig, axes = plt.subplots(1, 4, figsize=(15, 3.4))
    for k, a in enumerate(AXES):
        key = f"rms_a{a}_m_s2"
        mean = np.array([r["features"][key]["measured"] for r in rows])
        sd = np.array([r["features"][key]["trial_spread"] for r in rows])
        axes[k].errorbar(omega, mean, sd, fmt="ko", capsize=3, label="measured")
        for name, color in zip(models, ("C0", "C3", "C2")):
            axes[k].plot(omega, [r["features"][key][name] for r in rows], "s-", color=color,
                         label=name)
        axes[k].set_yscale("log")
        axes[k].set_title(f"steady RMS a_{a}, 1-50 Hz (m/s^2)", fontsize=9)
        axes[k].set_xlabel("omega* (deg/s)")
    axes[3].plot(omega, [r["measured_yaw_rate_from_centripetal_deg_s"] for r in rows], "ko",
                 label="measured (from centripetal a_x)")
    for name, color in zip(models, ("C0", "C3", "C2")):
        axes[3].plot(omega, [r[f"{name}_yaw_rate_deg_s"] for r in rows], "s-", color=color,
                     label=name)
    axes[3].plot(omega, omega, ":", color="0.6", label="commanded")
    axes[3].set_title("yaw rate (deg/s)", fontsize=9)
    axes[3].set_xlabel("omega* (deg/s)")
    axes[0].legend(fontsize=7)
    axes[3].legend(fontsize=7)
    return plots.save(fig, path)


# ------------------------------------------------------------------ writers

def _base_by_group(dataset: dict) -> list[str]:
    """The base model's error per command, which the held-out command is chosen by."""
    errors = dataset.get("base_error_by_group")
    if not errors:
        return []
    held = set(dataset["held_out_groups"])
    return ["The base model's error per command (RMS z; a held-out command should show a "
            f"discrepancy of its own, above {Z_CONSISTENT:g}): "
            + ", ".join(f"{label} {error:.2f}" + (" (held out)" if label in held else "")
                        for label, error in errors.items()) + ".", ""]


def _next_command_section(proposals: list[dict], purpose: str | None) -> list[str]:
    """report.md's "The next command to record" (diagnosis.next_command): the candidate
    swivels, how far apart the two models predict them, and what to do with the first."""
    first, second = proposals[0]["predicted"]
    if purpose == CONFIRM:
        why = (f"The held-out runs show no discrepancy of their own, so they cannot confirm "
               f"{first}, which the training runs point to.  Its fit and the {second}, "
               "simulated on the swivels the dataset lacks (median of "
               f"{PROPOSAL_STARTS} starts each), are this far apart (RMS z against the "
               "trials' spread widened by each model's start-to-start scatter; "
               f"{Z_CONSISTENT} or more is a discrepancy held-out runs would show):")
        then = ("the fit is then trained on the commands recorded now and tested on one "
                "where it predicts a discrepancy.")
    else:
        why = (f"{first} and {second} each remove most of the held-out discrepancy and the "
               "recorded commands do not choose between them.  Their fits, simulated on the "
               f"swivels the dataset lacks (median of {PROPOSAL_STARTS} starts each), are "
               "this far apart (RMS z against the trials' spread widened by each model's "
               f"start-to-start scatter; {Z_CONSISTENT} or more tells them apart):")
        then = ("the fits are then trained on the commands recorded now and tested on the "
                "one where they predict different measurements.")
    lines = ["## The next command to record", "", why, "",
             table(["command", "separation", "feature most apart", first, second],
                   [[p["command"], _fmt(p["separation"]), p["feature"],
                     _fmt(p["predicted"][first]), _fmt(p["predicted"][second])]
                    for p in proposals]), ""]
    top = proposals[0]
    if worth_recording(top):
        lines += [f"Record `{top['command']}` (as many trials as the other commands), add its "
                  f"runs to the dataset and diagnose it again with `--hold-out "
                  f"'{top['command']}'`: {then}", ""]
    return lines


def _fmt(x, digits: int = 3) -> str:
    return fmt(x, f".{digits}g")


def group_markdown(rows: list[dict], models: list[str]) -> str:
    out = []
    keys = list(rows[0]["features"])
    for r in rows:
        out.append(f"**{r['group']}** ({r['trials']} trials); yaw rate: measured "
                   f"{_fmt(r['measured_yaw_rate_from_centripetal_deg_s'])} deg/s (from the "
                   "centripetal a_x), " + ", ".join(
                       f"{m} {_fmt(r[f'{m}_yaw_rate_deg_s'])}" for m in models)
                   + "; spectral distance (RMS z of band powers): " + ", ".join(
                       f"{m} {_fmt(r[f'{m}_spectral_distance'])}" for m in models))
        out.append("")
        cells_by_key = []
        for key in keys:
            e = r["features"][key]
            cells = [key, f"{_fmt(e['measured'])} ± {_fmt(e['trial_spread'], 2)}"]
            for m in models:
                z = e.get(f"{m}_z")
                flag = " **!**" if significant(z) else ""
                cells.append(f"{_fmt(e[m])} (z {_fmt(z, 2)}){flag}")
            cells_by_key.append(cells)
        out.append(table(["feature (steady window)", "measured ± trial spread", *models],
                         cells_by_key))
        out.append("")
    return "\n".join(out)


def write_comparison(out: Path, summary: dict, observed: Observed, comparison: Comparison,
                     base: Simulated, figures: bool = True) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows = group_table(observed, comparison, {"base": base})
    summary["groups"] = rows
    lines = [
        "# skidsteer compare", "",
        f"Dataset `{summary['dataset']['root']}`: {summary['dataset']['runs']} runs in "
        f"{len(observed.groups)} commands; model: {summary['model']}.", "",
        f"Base model error (RMS z-score of {len(comparison_feature_names())} features against "
        f"the trials' spread; ~1 is as close as one trial to the next): "
        f"**{summary['baseline_error_all_runs']:.2f}**.", "",
        "## Largest discrepancies (trial-mean z > 3)", "",
        _discrepancy_table(summary["discrepancies"]), "",
        f"## Per command (! marks |z| > {SIGNIFICANT_Z:g})", "",
        group_markdown(rows, ["base"]), ""]
    if figures:
        plot_spectra(observed, {"base": base}, out / "figures" / "spectra.png")
        plot_features_vs_omega(rows, ["base"], out / "figures" / "features_vs_omega.png")
        lines += ["![spectra](figures/spectra.png)", "",
                  "![features vs omega](figures/features_vs_omega.png)", ""]
    lines += _skipped(summary["skipped_runs"])
    write_text(out / "report.md", "\n".join(lines))
    finish_outputs(out, "comparison.json", lambda path: write_json(path, summary))


def _discrepancy_table(items: list[dict]) -> str:
    if not items:
        return "None."
    return table(["command", "feature", "measured", "simulated", "trial spread", "z"],
                 [[d["group"], d["feature"], _fmt(d["measured"]), _fmt(d["simulated"]),
                   _fmt(d["trial_spread"], 2), _fmt(d["z"], 2)] for d in items[:12]])


def _skipped(skipped: list[dict]) -> list[str]:
    if not skipped:
        return []
    return ["## Skipped runs", ""] + [f"- `{s.get('file')}`: {s.get('reason')}"
                                      for s in skipped] + [""]


def write_extended_model(path: Path, cause: str, parameters: dict, setup,
                         timestep: float | None, realisation: int | None = None) -> Path:
    """The extended model as one MJCF file (includes flattened) that `skidsteer view`
    opens: the very model the fit simulated (load_spec of the setup with the cause)."""
    c = cause_registry.get(cause)
    spec = load_spec(setup, timestep=timestep, edit=c.edit(parameters, realisation or 0))
    spec.compile()
    xml = spec.to_xml()
    header = (f"<!-- skidsteer diagnose: {setup.robot} ({setup.label}) extended by cause "
              f"{cause} ({c.summary}), parameters {json.dumps(parameters)}"
              + (f", realisation {realisation}" if realisation is not None else "") + ".  Open "
              f"with `skidsteer view {path.name}`. -->\n")
    return write_text(path, header + xml)


def write_diagnosis(out: Path, diagnosis: dict, found, timestep: float | None,
                    figures: bool = True) -> None:
    """report.md, figures, the extended model of a named cause, and diagnosis.json last."""
    out.mkdir(parents=True, exist_ok=True)
    observed, comparison, named = found.observed, found.comparison, found.named
    shown = {"base": found.base}
    reference = found.reference
    if reference is not None:
        shown[reference.cause] = reference.simulated
    rows = group_table(observed, comparison, shown)
    if named is not None:
        path = write_extended_model(out / "extended_model.xml", named.cause, named.parameters,
                                    observed.groups[0].setup, timestep, named.realisation)
        diagnosis["extended_model"] = path.name
    g = diagnosis["gain"]
    lines = [
        "# skidsteer diagnose", "",
        f"Dataset `{diagnosis['dataset']['root']}`: {diagnosis['dataset']['runs']} runs, "
        f"{len(observed.groups)} command{'s' if len(observed.groups) != 1 else ''} (held out: "
        + (f"{', '.join(diagnosis['dataset']['held_out_groups'])}"
           + (", as given" if diagnosis["dataset"].get("held_out_given") else "")
           if holds_out_commands(observed, diagnosis["dataset"].get("held_out_given"))
           else "the last trial of each: with fewer than 3 commands no command can be held "
                "out, and no cause is named")
        + f"); model: {diagnosis['model']}.",
        "", *_base_by_group(diagnosis["dataset"]),
        f"## Verdict: **{diagnosis['verdict']}**"
        + (f", cause **{diagnosis['cause']}**" if diagnosis["cause"] else ""), "",
        diagnosis["reason"] + ".", ""]
    if named is not None:
        fitted = [f"{k} = **{_fmt(named.parameters[k], 4)}** (interval {_fmt(lo)} to "
                  f"{_fmt(hi)}{unprobed_note(named.unprobed.get(k))})"
                  for k, (lo, hi) in named.intervals.items()]
        held = [f"{k} = {_fmt(v)}" for k, v in named.parameters.items()
                if k not in named.intervals]
        lines += ["Fitted: " + "; ".join(fitted)
                  + (f"; held at their priors: {', '.join(held)}" if held else "") + ".", "",
                  f"Extended model: [{diagnosis['extended_model']}]({diagnosis['extended_model']})"
                  f" (`skidsteer view {out / diagnosis['extended_model']}`).", ""]
    likely, pair = diagnosis["most_likely"], diagnosis["best_pair"]
    if likely is not None and named is None:
        lines += [f"Most likely, though not named: {likely['cause']} (removes "
                  f"{likely['removed']:.0%} of the held-out discrepancy, error "
                  f"{_fmt(likely['held_out_error'])}).", ""]
    if pair is not None:
        lines += [f"The best pair, {' + '.join(pair['causes'])}, each at its own fit: held-out "
                  f"error {_fmt(pair['held_out_error'])}, score {_fmt(pair['score'])} "
                  f"({'better' if pair['better_than_best'] else 'no better'} than the best "
                  "cause alone).", ""]
    if diagnosis["next_commands"]:
        lines += _next_command_section(diagnosis["next_commands"],
                                       diagnosis.get("next_command_purpose"))
    lines += [
        "## Gain on held-out runs", "",
        table(["metric", "base model", f"extended ({g['extended_cause'] or '-'})",
                "trial noise", "discrepancy removed", "RMS error reduced"],
               [[g["metric"], _fmt(g["baseline_error"]), _fmt(g["extended_error"]),
                 _fmt(g["noise_error"]), f"{g['relative_reduction']:.0%}",
                 f"{g['rms_reduction']:.0%}"]]), "",
        f"Base error over all runs: {diagnosis['baseline_error_all_runs']:.2f}; on the "
        f"{diagnosis['training_runs']} training runs (from rest, as the candidates' training "
        f"errors): {diagnosis['baseline_error_training']:.2f}.", "",
        "## Candidates, best first", "",
        table(["cause", "held-out error", "training error", "score (E^2 + penalty)",
                "removed", "fitted parameters (interval)"],
               [[f["cause"], _fmt(f["held_out_error"]), _fmt(f["train_error"]), _fmt(f["score"]),
                 f"{f['removed']:.0%}",
                 "; ".join(f"{k} = {_fmt(f['parameters'][k])} ({_fmt(a)}-{_fmt(b)}"
                           f"{unprobed_note(f.get('unprobed', {}).get(k))})"
                           for k, (a, b) in f["interval"].items())]
                for f in diagnosis["ranking"]]) if diagnosis["ranking"] else "(none fitted)", "",
        "## What the base model gets wrong (trial-mean z > 3)", "",
        _discrepancy_table(diagnosis["discrepancies"]), ""]
    if diagnosis.get("remaining_discrepancies") is not None:
        lines += [f"Left after {named.cause}:", "",
                  _discrepancy_table(diagnosis["remaining_discrepancies"]), ""]
    elif likely is not None:
        lines += [f"Left after the most likely cause, {likely['cause']}:", "",
                  _discrepancy_table(likely["left"]), ""]
    lines += [f"## Per command (! marks |z| > {SIGNIFICANT_Z:g})", "",
              group_markdown(rows, list(shown)), ""]
    if figures:
        plot_spectra(observed, shown, out / "figures" / "spectra.png")
        plot_features_vs_omega(rows, list(shown), out / "figures" / "features_vs_omega.png")
        lines += ["![spectra](figures/spectra.png)", "",
                  "![features vs omega](figures/features_vs_omega.png)", ""]
    lines += _skipped(diagnosis["skipped_runs"])
    if diagnosis["not_applicable"]:
        lines += ["## Causes that do not apply to this model", ""] + [
            f"- {n['cause']}: {n['reason']}" for n in diagnosis["not_applicable"]] + [""]
    sims = diagnosis["simulations"]
    lines += [f"Wall time: {diagnosis['wall_time_s']} s ({sims['simulated']} simulations run, "
              f"{sims['reused']} reused from `{sims['cache']}`); numeric platform "
              f"{diagnosis['platform']} (docs/architecture.md#reproducible-numbers).", ""]
    write_text(out / "report.md", "\n".join(lines))
    finish_outputs(out, "diagnosis.json", lambda path: write_json(path, diagnosis))
