"""The diagnosis benchmarks' shared tables: the three rates of fresh draws, as the
generalisation benchmark's report and docs/diagnose.md print them."""

from __future__ import annotations

from skidsteer.diagnosis.benchmark_rows import fraction, rate_interval, three_rates
from skidsteer.reports.markdown import table


def rate_with_interval(k: int, n: int) -> str:
    """'k of n (p%, a-b%)': the rate and its RATE_CONFIDENCE interval ('0 of 0')."""
    ci = rate_interval(k, n)
    return fraction(k, n) if ci is None else (
        fraction(k, n)[:-1] + f", {ci[0]:.0%}-{ci[1]:.0%})")


def rates_table(rows: list[dict], truths: dict[str, dict]) -> str:
    """three_rates() as a markdown table, a row per hidden cause and one for all."""
    return table(["cause", "clear draws", "(a) named right", "(b) the truth would be named",
                  "(c) after following the report", "commands followed", "wrong names"],
                 [[cause, str(r["named"][1]), rate_with_interval(*r["named"]),
                   rate_with_interval(*r["ceiling"]), rate_with_interval(*r["loop"]),
                   str(r["followed"]), str(r["wrong"])]
                  for cause, r in three_rates(rows, truths).items()]).rstrip()
