"""The calm-swivel table: the soft start against the thesis's feed-forward, per floor and
omega, at the same mean yaw rate (skidsteer.tasks.calm_swivel).

    python scripts/calm_swivel_table.py [--out docs/calm_swivel] [--readme FILE]

Writes OUT/results.json and OUT/table.md, and the table into FILE (default
docs/calm_swivel/README.md) between <!-- calm-swivel-table --> and
<!-- /calm-swivel-table -->.  24 runs of 20 s: about a minute on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from skidsteer.data.files import write_atomically
from skidsteer.tasks import calm_swivel
from update_readme_tables import write_between_markers  # scripts/, beside this file

REPO = Path(__file__).resolve().parents[1]
START, END = "<!-- calm-swivel-table -->", "<!-- /calm-swivel-table -->"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(REPO / "docs/calm_swivel"))
    parser.add_argument("--readme", default=str(REPO / "docs/calm_swivel/README.md"))
    args = parser.parse_args()
    started = time.time()
    rows = calm_swivel.compare_controllers()
    table = calm_swivel.markdown_table(rows)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = json.dumps({"soft_start_s": calm_swivel.SOFT_START_S, "run_s": calm_swivel.RUN_S,
                          "rows": rows, "wall_time_s": round(time.time() - started, 1)},
                         indent=1)
    write_atomically(out / "results.json", lambda tmp: tmp.write_text(results))
    write_atomically(out / "table.md", lambda tmp: tmp.write_text(table))
    write_between_markers(Path(args.readme), START, END, table)
    print(table)
    print(f"{time.time() - started:.0f} s")


if __name__ == "__main__":
    main()
