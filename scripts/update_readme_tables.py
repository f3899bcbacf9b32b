"""Writes the generated tables of the READMEs.

    python scripts/update_readme_tables.py [--results docs/reproduction/results.json]

- README.md, between <!-- reproduction-table --> and <!-- /reproduction-table -->:
  the reproduction summary of docs/reproduction/results.json;
- plugin/tire/README.md, between <!-- attributes-table --> and its end marker, and
  <!-- floors-table -->: the tire plugin's attributes and floors, from the plugin's
  own contract (skidsteer.robot.tire; tests/test_repository.py checks they match).
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from skidsteer.data.files import write_atomically
from skidsteer.reports.markdown import table as _table
from skidsteer.reports.reproduction import summary_rows
from skidsteer.robot import tire

REPO = Path(__file__).resolve().parents[1]
PLUGIN_README = REPO / "plugin" / "tire" / "README.md"
MARKERS = {
    "reproduction": ("<!-- reproduction-table -->", "<!-- /reproduction-table -->"),
    "attributes": ("<!-- attributes-table -->", "<!-- /attributes-table -->"),
    "floors": ("<!-- floors-table -->", "<!-- /floors-table -->"),
}


def plugin_tables() -> dict[str, str]:
    """The plugin README's generated tables, by marker name."""
    return {"attributes": tire.attributes_markdown(), "floors": tire.floors_markdown()}


def between_markers(text: str, name: str) -> str | None:
    """What stands between a marker pair of text (None without the pair)."""
    start, end = MARKERS[name]
    found = re.search(re.escape(start) + r"\n(.*?)" + re.escape(end), text, re.S)
    return found.group(1) if found else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", default=str(REPO / "docs/reproduction/results.json"))
    parser.add_argument("--readme", default=str(REPO / "README.md"))
    parser.add_argument("--plugin-only", action="store_true",
                        help="only the plugin README's tables (no results.json needed)")
    args = parser.parse_args()
    for name, body in plugin_tables().items():
        write_between_markers(PLUGIN_README, *MARKERS[name], body)
    if args.plugin_only:
        return
    results = json.loads(Path(args.results).read_text())
    table = _table(["quantity", "measured (thesis)", "thesis model", "ours", "target (ours)"],
                   [list(r) for r in summary_rows(results)])
    write_between_markers(Path(args.readme), *MARKERS["reproduction"], table)


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
