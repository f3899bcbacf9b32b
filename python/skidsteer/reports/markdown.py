"""Markdown pieces of the reports: tables and numbers."""

from __future__ import annotations

import numpy as np


def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def fmt(x, spec: str = ".3g") -> str:
    """A number for a table; "n/a" for None and non-finite."""
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "n/a"
    return format(x, spec)
