"""Writes the reproduction summary table of docs/reproduction/results.json into README.md.

    python scripts/update_readme_tables.py [--results docs/reproduction/results.json]

The table sits between <!-- reproduction-table --> and <!-- /reproduction-table -->.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

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
    readme = Path(args.readme)
    text = readme.read_text()
    block = f"{START}\n{table}{END}"
    pattern = re.compile(re.escape(START) + r"(.*?" + re.escape(END) + r")?", re.S)
    if not pattern.search(text):
        raise SystemExit(f"{readme}: no {START} marker")
    readme.write_text(pattern.sub(lambda _: block, text, count=1))


if __name__ == "__main__":
    main()
