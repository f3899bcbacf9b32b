"""Writes the generated tables of the READMEs.

    python scripts/update_readme_tables.py [--results docs/reproduction/results.json]

- README.md, between <!-- reproduction-table --> and <!-- /reproduction-table -->:
  the reproduction summary of docs/reproduction/results.json;
- docs/diagnose.md, between <!-- fresh-draws --> and <!-- /fresh-draws -->: diagnose's
  rates on the generalisation benchmark's fresh draws and the ceiling's
  (docs/diagnose-*.jsonl, judged by the verdict rules as they are now;
  --fresh-draws-only writes this one alone);
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
from skidsteer.diagnosis import benchmark_rows
from skidsteer.reports.benchmarks import rates_table
from skidsteer.reports.markdown import table as _table
from skidsteer.reports.reproduction import summary_rows
from skidsteer.robot import tire

REPO = Path(__file__).resolve().parents[1]

PLUGIN_README = REPO / "plugin" / "tire" / "README.md"
DIAGNOSE_DOC = REPO / "docs" / "diagnose.md"  # holds the fresh-draws table
# the fresh-draws table's first row: from the first draw made after the held-out errors
# became medians over 5 starts
FRESH_FROM = 1080
MARKERS = {
    "reproduction": ("<!-- reproduction-table -->", "<!-- /reproduction-table -->"),
    "fresh-draws": ("<!-- fresh-draws -->", "<!-- /fresh-draws -->"),
    "attributes": ("<!-- attributes-table -->", "<!-- /attributes-table -->"),
    "floors": ("<!-- floors-table -->", "<!-- /floors-table -->"),
}


def plugin_tables() -> dict[str, str]:
    """The plugin README's generated tables, by marker name."""
    return {"attributes": tire.attributes_markdown(), "floors": tire.floors_markdown()}


def fresh_draws_table(results: Path = REPO / "docs" / "diagnose-generalisation.jsonl",
                      rows_of_ceiling: Path = REPO / "docs" / "diagnose-ceiling.jsonl",
                      draws_from: int = FRESH_FROM) -> str:
    """docs/diagnose.md's tables of diagnose on fresh draws: the draws from draws_from on
    and the whole table, each as the two benchmarks' summaries count them, then the three
    rates per cause of the draws from draws_from on (reports.benchmarks.rates_table)."""
    newest = benchmark_rows.newest_rows(results)
    truths = list(benchmark_rows.newest_rows(rows_of_ceiling).values())
    verdicts = [benchmark_rows.judged(r, newest[r["case"]]) for r in truths]

    def rate(k: int, n: int) -> str:  # the table writes "85 %"
        return benchmark_rows.fraction(k, n).replace("%)", " %)")

    def line(label: str, rows: list[dict], which: list[int]) -> list[str]:
        rated = {k: benchmark_rows.right_of(v) for k, v in benchmark_rows.groups(rows).items()}
        truth = benchmark_rows.counts([truths[i] for i in which], [verdicts[i] for i in which])
        wrong = sum(benchmark_rows.wrong_name(r) for r in rows)
        return [label, str(len(rows)),
                f"{rate(*rated['effects'])}; {rate(*rated['judged'])} where the held-out "
                "command shows it", str(wrong),
                "{} of {}; {} of {}".format(*rated["nulls"], *rated["outside"]),
                f"{rate(*truth['named'])}; {rate(*truth['judged'])}", rate(*truth['diagnose'])]

    rows = list(newest.values())
    later = benchmark_rows.drawn_from(rows, draws_from)
    seeds = [r["seed"] for r in later]
    summary = _table(
        ["draws", "datasets", "clear causes named right", "wrong names",
         "nulls no-discrepancy; fans unexplained",
         "the truth itself would be named (as in the third column)",
         "diagnose, where the truth would be named"],
        [line(f"{min(seeds)}-{max(seeds)} (drawn after the held-out errors became medians "
              "over 5 starts)", later,
              benchmark_rows.drawn_from_indices(truths, newest, draws_from)),
         line("all (every code version, a draw's newest row)", rows,
              list(range(len(truths))))])
    return (summary + f"\nPer cause, the draws {min(seeds)}-{max(seeds)}: (a) named right, "
            "(b) the truth itself would be named (the ceiling), (c) named after following the "
            "report (the proposed command recorded and held out; a row whose report "
            "proposed one it did not follow is not counted), with 95 % intervals "
            "(Clopper-Pearson):\n\n"
            + rates_table(later, benchmark_rows.newest_rows(rows_of_ceiling)) + "\n")


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
    parser.add_argument("--fresh-draws-only", action="store_true",
                        help="only docs/diagnose.md's table of diagnose on fresh draws")
    args = parser.parse_args()
    if not args.plugin_only:
        write_between_markers(DIAGNOSE_DOC, *MARKERS["fresh-draws"], fresh_draws_table())
    if args.fresh_draws_only:
        return
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
