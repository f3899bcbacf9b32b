"""What `compare` and `diagnose` write: JSON, a Markdown report, figures, the extended model."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from skidsteer import causes as cause_registry
from skidsteer import signals
from skidsteer.analysis import _plain, _write_json
from skidsteer.comparison import (AXES, N_POWER, STEADY_FROM_S, Comparison, Observed,
                                  Simulated, feature_names)
from skidsteer.datafiles import remove_temporaries, write_atomically
from skidsteer.report import _fmt as report_fmt
from skidsteer.report import _table


def _steady(time_s, accel):
    t = np.asarray(time_s) - time_s[0]
    return accel[t >= STEADY_FROM_S]


def readable_features(time_s, accel) -> dict:
    """Per axis, over the steady window: RMS 1-50 Hz and Sec. 3.2's low/high band peaks."""
    steady = _steady(time_s, accel)
    fs = signals.sample_rate(time_s)
    f, psd = signals.welch_spectrum(steady, fs)
    rms = np.sqrt(signals.band_power(f, psd, signals.BAND_HZ))
    low = signals.band_peak_hz(f, psd, signals.LOW_BAND_HZ)
    high = signals.band_peak_hz(f, psd, signals.HIGH_BAND_HZ)
    out = {}
    for i, a in enumerate(AXES):
        out[f"rms_a{a}_m_s2"] = float(rms[i])
        out[f"low_peak_a{a}_hz"] = float(low[i])
        out[f"high_peak_a{a}_hz"] = float(high[i])
    return out


# Smallest credible spread of each readable feature: a Welch bin for the peaks,
# the log-power resolution (comparison.LOG_POWER_RESOLUTION = 0.1 decade, i.e.
# 12 % in amplitude) for the RMS.
def _resolution(key: str, value: float) -> float:
    if key.endswith("_hz"):
        return signals.WELCH_RESOLUTION_HZ
    return 0.12 * abs(value)


def group_table(observed: Observed, comparison: Comparison, models: dict[str, Simulated]
                ) -> list[dict]:
    """Per group and readable feature: measured mean and trial spread, each model's
    value and its z against the spread; plus each model's spectral distance (RMS z
    of the band powers) and yaw rate."""
    rows = []
    runs = np.arange(len(observed.run_group))
    zs = {name: comparison.z_scores(sim.features, runs) for name, sim in models.items()}
    base = next(iter(models.values()))
    bias = np.median(base.features[observed.run_group, -1] - observed.features[:, -1])
    for gi, g in enumerate(observed.groups):
        members = np.flatnonzero(observed.run_group == gi)
        measured = [readable_features(*observed.records[i]) for i in members]
        simulated = {name: readable_features(sim.time_s[gi], sim.accel[gi])
                     for name, sim in models.items()}
        # the mean a_x less the sensor's offset (bias) and the static a_x of the robot at
        # rest (gravity along a tilted cube, read from the simulation's first sample)
        centripetal = observed.features[members, -1] + bias - base.accel[gi][0, 0]
        # yaw rate from the centripetal mean, scaled on the base simulation's (the
        # turning centre is not the CoM: in a swivel it sits ahead of the cube by
        # ~0.3 m, not 0.2 m, so a_x = omega^2 * 0.2 would overestimate omega)
        sim_centripetal = base.features[gi, -1] - base.accel[gi][0, 0]
        ratio = max(centripetal.mean(), 0.0) / sim_centripetal if sim_centripetal > 0 else np.nan
        row = {"group": g.label, "omega_deg_s": g.omega_deg_s, "trials": len(members),
               "measured_yaw_rate_from_centripetal_deg_s": float(
                   base.mean_yaw_rate_deg_s[gi] * np.sqrt(ratio)),
               "features": {}}
        for name, sim in models.items():
            row[f"{name}_yaw_rate_deg_s"] = sim.mean_yaw_rate_deg_s[gi]
            row[f"{name}_spectral_distance"] = float(np.sqrt(np.nanmean(
                zs[name][members, :N_POWER] ** 2)))
        for key in measured[0]:
            values = np.array([m[key] for m in measured])
            mean = float(np.nanmean(values))
            spread = float(np.nanstd(values, ddof=1)) if len(values) > 1 else 0.0
            spread = max(spread, _resolution(key, mean))
            entry = {"measured": mean, "trial_spread": spread}
            for name in models:
                v = simulated[name][key]
                entry[name] = v
                entry[f"{name}_z"] = (v - mean) / spread if spread > 0 else None
            row["features"][key] = entry
        rows.append(row)
    return rows


# ------------------------------------------------------------------ figures

def plot_spectra(observed: Observed, models: dict[str, Simulated], path: Path,
                 max_groups: int = 4) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from skidsteer.figures import save

    groups = observed.groups[:max_groups]
    fig, axes = plt.subplots(len(groups), 3, figsize=(12, 2.6 * len(groups)), squeeze=False,
                             sharex=True)
    for gi, g in enumerate(groups):
        members = np.flatnonzero(observed.run_group == gi)
        for k, a in enumerate(AXES):
            ax = axes[gi, k]
            for n, i in enumerate(members):
                t, acc = observed.records[i]
                f, p = signals.welch_spectrum(_steady(t, acc)[:, k], signals.sample_rate(t))
                ax.semilogy(f, p, color="0.5", lw=0.8, label="measured trials" if n == 0 else None)
            for (name, sim), color in zip(models.items(), ("C0", "C3", "C2")):
                t, acc = sim.time_s[gi], sim.accel[gi]
                f, p = signals.welch_spectrum(_steady(t, acc)[:, k], signals.sample_rate(t))
                ax.semilogy(f, p, color=color, lw=1.0, label=name)
            ax.set_xlim(0, 55)
            ax.set_title(f"{g.label}: a_{a}", fontsize=9)
            if k == 0:
                ax.set_ylabel("PSD (m/s^2)^2/Hz")
            if gi == len(groups) - 1:
                ax.set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"steady window (from {STEADY_FROM_S:g} s): measured vs simulated")
    return save(fig, path)


def plot_features_vs_omega(rows: list[dict], models: list[str], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from skidsteer.figures import save

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
    return save(fig, path)


# ------------------------------------------------------------------ writers

def write_json(path: Path, data: dict) -> Path:
    """Strict JSON (non-finite numbers as null, numpy scalars as numbers), atomically."""
    def ready(x):
        if isinstance(x, dict):
            return {k: ready(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [ready(v) for v in x]
        return _plain(x)
    return _write_json(path, ready(data))


def write_text(path: Path, text: str) -> Path:
    return write_atomically(path, lambda tmp: tmp.write_text(text))


def _fmt(x, digits: int = 3) -> str:
    return report_fmt(x, f".{digits}g")


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
        table = []
        for key in keys:
            e = r["features"][key]
            cells = [key, f"{_fmt(e['measured'])} ± {_fmt(e['trial_spread'], 2)}"]
            for m in models:
                z = e.get(f"{m}_z")
                flag = " **!**" if z is not None and abs(z) > 3 else ""
                cells.append(f"{_fmt(e[m])} (z {_fmt(z, 2)}){flag}")
            table.append(cells)
        out.append(_table(["feature (steady window)", "measured ± trial spread", *models], table))
        out.append("")
    return "\n".join(out)


def start_outputs(out: Path, result_name: str, command: str, note: str = "") -> None:
    """Marks out as unfinished until finish_outputs: removes a previous run's result file
    (written last, so its presence means a complete set of outputs), writes the
    .skidsteer-incomplete marker (its text ends with note) and clears stale
    temporaries."""
    from skidsteer.measured import INCOMPLETE_MARKER

    out.mkdir(parents=True, exist_ok=True)
    (out / result_name).unlink(missing_ok=True)
    write_atomically(out / INCOMPLETE_MARKER, lambda tmp: tmp.write_text(
        f"an unfinished skidsteer {command}: no {result_name} yet{note}\n"))
    remove_temporaries(out)


def finish_outputs(out: Path, result_name: str, result: dict) -> None:
    """Writes the result file, the last of the outputs, and removes the marker."""
    from skidsteer.measured import INCOMPLETE_MARKER

    write_json(out / result_name, result)
    (out / INCOMPLETE_MARKER).unlink(missing_ok=True)


def write_compare_outputs(out: Path, summary: dict, observed: Observed, comparison: Comparison,
                          base: Simulated, figures: bool = True) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rows = group_table(observed, comparison, {"base": base})
    summary["groups"] = rows
    lines = [
        "# skidsteer compare", "",
        f"Dataset `{summary['dataset']['root']}`: {summary['dataset']['runs']} runs in "
        f"{len(observed.groups)} commands; model: {summary['model']}.", "",
        f"Base model error (RMS z-score of {len(feature_names())} features against the trials' "
        f"spread; ~1 is as close as one trial to the next): "
        f"**{summary['baseline_error_all_runs']:.2f}**.", "",
        "## Largest discrepancies (trial-mean z > 3)", "",
        _discrepancy_table(summary["discrepancies"]), "",
        "## Per command (! marks |z| > 3)", "", group_markdown(rows, ["base"]), ""]
    if figures:
        plot_spectra(observed, {"base": base}, out / "figures" / "spectra.png")
        plot_features_vs_omega(rows, ["base"], out / "figures" / "features_vs_omega.png")
        lines += ["![spectra](figures/spectra.png)", "",
                  "![features vs omega](figures/features_vs_omega.png)", ""]
    lines += _skipped(summary["skipped_runs"])
    write_text(out / "report.md", "\n".join(lines))
    finish_outputs(out, "comparison.json", summary)


def _discrepancy_table(items: list[dict]) -> str:
    if not items:
        return "None."
    return _table(["command", "feature", "measured", "simulated", "trial spread", "z"],
                  [[d["group"], d["feature"], _fmt(d["measured"]), _fmt(d["simulated"]),
                    _fmt(d["trial_spread"], 2), _fmt(d["z"], 2)] for d in items[:12]])


def _skipped(skipped: list[dict]) -> list[str]:
    if not skipped:
        return []
    return ["## Skipped runs", ""] + [f"- `{s.get('file')}`: {s.get('reason')}"
                                      for s in skipped] + [""]


def write_extended_model(path: Path, cause: str, parameters: dict, setup, model: str | None,
                         timestep: float | None, realisation: int | None = None) -> Path:
    """The extended model as one MJCF file (includes flattened) that `skidsteer view` opens."""
    from skidsteer.experiments import _wheel_mount
    from skidsteer.models import load_spec

    c = cause_registry.get(cause)
    spec = load_spec(model or setup.config, setup.surface, timestep=timestep)
    if setup.mount == "wheel":
        _wheel_mount(spec)
    c.apply(spec, parameters, realisation or 0)
    spec.compile()
    xml = spec.to_xml()
    header = (f"<!-- skidsteer diagnose: the {setup.config} robot on {setup.surface} extended "
              f"by cause {cause} ({c.summary}), parameters {json.dumps(parameters)}"
              + (f", realisation {realisation}" if realisation is not None else "") + ".  Open "
              f"with `skidsteer view {path.name}`. -->\n")
    return write_text(path, header + xml)


def write_outputs(out: Path, diagnosis: dict, observed: Observed, comparison: Comparison,
                  base: Simulated, fits: list, named, model: str | None,
                  timestep: float | None, figures: bool = True) -> None:
    out.mkdir(parents=True, exist_ok=True)
    shown = {"base": base}
    reference = named or (fits[0] if fits else None)
    if reference is not None:
        shown[reference.cause] = reference.simulated
    rows = group_table(observed, comparison, shown)
    if named is not None:
        path = write_extended_model(out / "extended_model.xml", named.cause, named.parameters,
                                    observed.groups[0].setup, model, timestep,
                                    named.realisation)
        diagnosis["extended_model"] = path.name
    g = diagnosis["gain"]
    lines = [
        "# skidsteer diagnose", "",
        f"Dataset `{diagnosis['dataset']['root']}`: {diagnosis['dataset']['runs']} runs, "
        f"{len(observed.groups)} commands (held out: "
        f"{', '.join(diagnosis['dataset']['held_out_groups'])}); model: {diagnosis['model']}.",
        "",
        f"## Verdict: **{diagnosis['verdict']}**"
        + (f", cause **{diagnosis['cause']}**" if diagnosis["cause"] else ""), "",
        diagnosis["reason"] + ".", ""]
    if named is not None:
        lo, hi = named.interval
        lines += [f"Fitted {named.main} = **{_fmt(named.parameters[named.main], 4)}** "
                  f"(interval {_fmt(lo)} to {_fmt(hi)}); held at their priors: "
                  + ", ".join(f"{k} = {_fmt(v)}" for k, v in named.parameters.items()
                              if k != named.main) + ".", "",
                  f"Extended model: [{diagnosis['extended_model']}]({diagnosis['extended_model']})"
                  f" (`skidsteer view {out / diagnosis['extended_model']}`).", ""]
    lines += [
        "## Gain on held-out runs", "",
        _table(["metric", "base model", f"extended ({g['extended_cause'] or '-'})",
                "trial noise", "discrepancy removed", "RMS error reduced"],
               [[g["metric"], _fmt(g["baseline_error"]), _fmt(g["extended_error"]),
                 _fmt(g["noise_error"]), f"{g['relative_reduction']:.0%}",
                 f"{g['rms_reduction']:.0%}"]]), "",
        f"Base error over all runs: {diagnosis['baseline_error_all_runs']:.2f}.", "",
        "## Candidates, best first", "",
        _table(["cause", "held-out error", "training error", "score (E^2 + penalty)",
                "fitted main parameter", "interval"],
               [[f["cause"], _fmt(f["held_out_error"]), _fmt(f["train_error"]), _fmt(f["score"]),
                 " ".join(f"{k} = {_fmt(v)}" for k, v in f["parameters"].items()
                          if k in f["interval"]),
                 " ".join(f"{_fmt(a)}-{_fmt(b)}" for a, b in f["interval"].values())]
                for f in diagnosis["ranking"]]) if diagnosis["ranking"] else "(none fitted)", "",
        "## What the base model gets wrong (trial-mean z > 3)", "",
        _discrepancy_table(diagnosis["discrepancies"]), ""]
    if diagnosis.get("remaining_discrepancies") is not None:
        lines += [f"Left after {named.cause}:", "",
                  _discrepancy_table(diagnosis["remaining_discrepancies"]), ""]
    lines += ["## Per command (! marks |z| > 3)", "", group_markdown(rows, list(shown)), ""]
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
              f"{sims['reused']} reused from `{sims['cache']}`).", ""]
    write_text(out / "report.md", "\n".join(lines))
    finish_outputs(out, "diagnosis.json", diagnosis)
