"""Writes the reproduction summary table of docs/reproduction/results.json into README.md.

    python scripts/update_readme_tables.py [--results docs/reproduction/results.json]

The table sits between <!-- reproduction-table --> and <!-- /reproduction-table -->.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from skidsteer.datafiles import write_atomically
from skidsteer.report import _table, summary_rows

REPO = Path(__file__).resolve().parents[1]
START, END = "<!-- reproduction-table -->", "<!-- /reproduction-table -->"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--results", default=str(REPO / "docs/reproduction/results.json"))
    parser.add_argument("--readme", default=str(REPO / "README.md"))
    args = parser.parse_args()
    results = json.loads(Path(args.results).read_text())
    table = _table(["quantity", "measured (thesis)", "thesis model", "ours", "target (ours)"],
                   [list(r) for r in summary_rows(results)])
    write_between_markers(Path(args.readme), START, END, table)


def write_between_markers(readme: Path, start: str, end: str, body: str) -> None:
    """Replaces what stands between the start and end markers of readme with body (a
    start marker without its end marker gets one)."""
    text = readme.read_text()
    pattern = re.compile(re.escape(start) + r"(.*?" + re.escape(end) + r")?", re.S)
    if not pattern.search(text):
        raise SystemExit(f"{readme}: no {start} marker")
    new = pattern.sub(lambda _: f"{start}\n{body}{end}", text, count=1)
    write_atomically(readme, lambda tmp: tmp.write_text(new))


if __name__ == "__main__":
    main()
