"""`skidsteer analyze`: the thesis's Appendix A analysis of run files and datasets.

Per run, features.swivel_features (amplitude, FFT peaks, Sec. 3.2's bands); per
command on one setup (data.group_runs), the mean and spread over its trials;
written to analysis.json with, optionally, a figure per run and the features
against omega (Appendix B/C).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from skidsteer.data.dataset import RunInfo, group_runs, read_dataset
from skidsteer.data.files import plain, write_json
from skidsteer.data.recording import DataError, read_run
from skidsteer.features.extract import AXES, swivel_features
from skidsteer.reports import figures as plots

SUMMARY_KEYS = ("amplitude_m_s2", "steady_amplitude_m_s2", "main_peak_hz", "low_band_peak_hz",
                "high_band_peak_hz", "low_band_power", "high_band_power")


def analyze_file(path, out_dir=None, figures: bool = True) -> dict:
    """swivel_features() of one run file (data.read_run).

    With out_dir, writes <stem>.json (the returned dict) and, if figures,
    <stem>.png (figures.plot_run), whose path is returned under "figure".
    """
    rec = read_run(path)
    result = {"file": str(path), **swivel_features(rec.time_s, rec.accel)}
    if out_dir is not None:
        out_dir = Path(out_dir)
        stem = Path(path).stem
        if figures:
            result["figure"] = str(plots.plot_run(rec.time_s, rec.accel, result,
                                                       out_dir / f"{stem}.png"))
        write_json(out_dir / f"{stem}.json", result)
    return result


def _stats(values: list[dict]) -> dict:
    """Mean and sample std (ddof = 1, MATLAB's std, as Table 5.2) per axis over trials."""
    out = {"mean": {}, "std": {}}
    for a in AXES:
        v = np.array([np.nan if d[a] is None else d[a] for d in values], dtype=float)
        v = v[np.isfinite(v)]
        out["mean"][a] = plain(float(v.mean())) if len(v) else None
        out["std"][a] = plain(float(v.std(ddof=1))) if len(v) > 1 else None
    return out


def run_fields(info: RunInfo) -> dict:
    """A run's command and setup as the rows of analysis.json have them."""
    s = info.setup
    return {"v_mps": info.v_mps, "omega_deg_s": info.omega_deg_s, "floor": s.floor,
            "build": s.build, "mount": s.mount, "trial": info.trial}


def summarize(runs: list[tuple[RunInfo, dict]]) -> list[dict]:
    """Per command on one setup (data.group_runs; v_mps is part of it, so runs at
    different speeds never average): trials, mean and std of SUMMARY_KEYS."""
    rows = []
    for group, members in group_runs(runs, lambda item: item[0]):
        row = {k: v for k, v in run_fields(members[0][0]).items() if k != "trial"}
        row["trials"] = len(members)
        row["files"] = [run["file"] for _, run in members]
        row.update({k: _stats([run[k] for _, run in members]) for k in SUMMARY_KEYS})
        rows.append(row)
    return rows


def _figure_name(rec_path: Path, root: Path | None) -> str:
    try:
        rel = Path(rec_path).relative_to(root) if root is not None else Path(Path(rec_path).name)
    except ValueError:
        rel = Path(Path(rec_path).name)
    return "__".join(rel.with_suffix("").parts) + ".png"


def analyze_paths(paths_or_dir, out_dir, figures: bool = True, robot=None) -> dict:
    """Features of every run under the given directories/files, a summary and figures.

    A directory is read with data.read_dataset (its RunInfo gives the command and the
    setup; unreadable files come back under "skipped"); a file with read_run (no
    RunInfo: it is not summarised).  Writes out_dir/analysis.json (the returned dict)
    and, if figures, out_dir/runs/*.png per run and out_dir/peak_vs_omega.png,
    out_dir/amplitude_vs_omega.png from the summary.
    """
    items = [paths_or_dir] if isinstance(paths_or_dir, (str, Path)) else list(paths_or_dir)
    out_dir = Path(out_dir)
    loaded, skipped = [], []  # (info or None, recording, root or None)
    for item in map(Path, items):
        if item.is_dir():
            dataset = read_dataset(item, robot=robot)
            loaded += [(info, rec, item) for info, rec in dataset.runs]
            skipped += list(dataset.skipped)
        else:
            try:
                loaded.append((None, read_run(item), None))
            except DataError as err:
                skipped.append({"file": str(item), "reason": str(err)})

    runs, described, figure_paths = [], [], []
    for info, rec, root in loaded:
        run = {"file": str(info.file if info is not None else rec.path)}
        if info is not None:
            run.update(run_fields(info))
        run.update(swivel_features(rec.time_s, rec.accel))
        if figures:
            png = out_dir / "runs" / _figure_name(rec.path, root)
            run["figure"] = str(plots.plot_run(rec.time_s, rec.accel, run, png))
            figure_paths.append(run["figure"])
        runs.append(run)
        if info is not None:
            described.append((info, run))

    summary = summarize(described)
    if figures and summary:
        for quantity in ("peak", "amplitude"):
            png = out_dir / f"{quantity}_vs_omega.png"
            figure_paths.append(str(plots.plot_features_vs_omega(summary, png,
                                                                      quantity=quantity)))
    result = {"runs": runs, "summary": summary, "skipped": skipped, "figures": figure_paths}
    write_json(out_dir / "analysis.json", result)
    return plain(result)
