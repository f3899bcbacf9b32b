"""Adds the base model's training error to generalisation-benchmark rows written before
they kept it (issue 21: the verdict rule told_from_base reads it).

For each row of --results without "base_train": the row's dataset (regenerated under
--out as the benchmark made it, when missing), the base model simulated on its commands
from start 0 (the simulation cache under --out serves what the benchmark ran with the
same code), and Comparison.error on the training runs, as diagnose computes it.  The
values go to --values as they are computed (a rerun resumes); once every row has one,
--results is rewritten with them ("base_train", "n_train", and "base_train_code", the
code that computed it).  Run it when no benchmark is appending to --results.

    python scripts/bench/backfill_base_train.py --out /tmp/gen \
        --results docs/diagnose-generalisation.jsonl --values /tmp/gen/base_train.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import skidsteer  # noqa: E402,F401
from bench_diagnose_ceiling import Measured  # noqa: E402
from bench_diagnose_generalisation import case_of  # noqa: E402
from skidsteer.data.files import write_text  # noqa: E402
from skidsteer.simulation.cache import code_fingerprint  # noqa: E402


def base_train(row: dict, out: Path, threads: int) -> dict:
    """The base model's training error (start 0) on the row's dataset."""
    m = Measured(case_of(row), out, 3, 20.0, threads)  # the benchmark's trials and length
    return {"case": row["case"], "seed": row["seed"],
            "base_train": m.comparison.error(m.base.features, m.train),
            "n_train": int(len(m.train)), "base_train_code": code_fingerprint()[:12]}


def _lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--results", type=Path, required=True)
    ap.add_argument("--values", type=Path, required=True, help="the computed values (JSON lines)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    rows = _lines(args.results)
    # a case rerun has several rows of one dataset: one value serves them all
    values = {(v["case"], v["seed"]): v for v in _lines(args.values)}
    todo = {(r["case"], r["seed"]): r for r in rows
            if "base_train" not in r and (r["case"], r["seed"]) not in values}
    for i, row in enumerate(todo.values()):
        value = base_train(row, args.out, args.threads)
        values[(row["case"], row["seed"])] = value
        with args.values.open("a") as f:
            f.write(json.dumps(value) + "\n")
        print(f"[{i + 1}/{len(todo)}] {row['case']}: base training error "
              f"{value['base_train']:.3f} ({value['n_train']} runs)", flush=True)
    merged = [r if "base_train" in r else
              {**r, **{k: v for k, v in values[(r["case"], r["seed"])].items()
                       if k not in ("case", "seed")}} for r in rows]
    write_text(args.results, "".join(json.dumps(r) + "\n" for r in merged))
    print(f"{args.results}: {sum('base_train' not in r for r in rows)} rows given the base "
          f"model's training error, {len(rows)} rows in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
