"""Which measured runs train the fits and which test them (the held-out runs)."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from skidsteer.diagnosis.comparison import Observed
from skidsteer.diagnosis.verdict import Z_CONSISTENT


def split(observed: Observed, group_errors: np.ndarray | None = None,
          held_out: Sequence[str] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(training runs, held-out runs): every third group, starting with the second, is
    held out; with fewer than 3 groups, the last trial of each group is.

    group_errors: the base model's error on each group (evaluate.base_group_errors).
    When every group the rule holds out is within Z_CONSISTENT (the held-out runs would
    show no discrepancy of their own and could confirm no cause) and more groups than it
    holds out are above it, the groups above it with the smallest errors are held out
    instead, as many: the held-out runs then show the discrepancy, and the groups
    showing it most still train.

    held_out: the commands to hold out instead (held_out_groups: labels, or a command
    alone where one setup has it), as the user chose them; neither rule applies."""
    runs = np.arange(len(observed.run_group))
    if held_out is not None:
        held = np.isin(observed.run_group, held_out_groups(observed, held_out))
    elif holds_out_commands(observed):
        held_groups = np.arange(1, len(observed.groups), 3)
        if group_errors is not None:
            errors = np.asarray(group_errors)
            showing = np.flatnonzero(errors > Z_CONSISTENT)
            if np.all(errors[held_groups] <= Z_CONSISTENT) and len(showing) > len(held_groups):
                weakest = np.argsort(errors[showing], kind="stable")
                held_groups = showing[weakest[:len(held_groups)]]
        held = np.isin(observed.run_group, held_groups)
    else:
        held = np.zeros(len(runs), bool)
        for gi in range(len(observed.groups)):
            members = runs[observed.run_group == gi]
            if len(members) > 1:
                held[members[-1]] = True
    if not held.any() or held.all():
        raise ValueError("the dataset needs at least two runs of one command, or three "
                         "commands, to hold some out")
    return runs[~held], runs[held]


def held_out_groups(observed: Observed, commands: Sequence[str]) -> np.ndarray:
    """The indices of the groups `commands` name, each by its label ("v0-w60 tile
    extended", as diagnosis.json's dataset.groups list them) or by its command alone
    ("v0-w60") where only one setup has it.  A command the dataset lacks, one that names
    several groups, or holding out every command is an error naming it."""
    labels = [g.label for g in observed.groups]
    chosen = []
    for command in commands:
        matches = [i for i, g in enumerate(observed.groups)
                   if command.strip() in (g.label, g.command)]
        if not matches:
            raise ValueError(f"hold-out {command!r}: the dataset has no such command "
                             f"(its commands: {', '.join(labels)})")
        if len(matches) > 1:
            raise ValueError(f"hold-out {command!r} names {len(matches)} commands ("
                             f"{', '.join(labels[i] for i in matches)}): give the full label")
        chosen.append(matches[0])
    if len(set(chosen)) == len(labels):
        raise ValueError(f"hold-out {', '.join(commands)}: that is every command of the "
                         "dataset, and none would be left to fit on")
    return np.array(sorted(set(chosen)), int)


def holds_out_commands(observed: Observed, held_out: Sequence[str] | None = None) -> bool:
    """Whether split holds out whole commands (the user's held_out, or three or more
    commands), or else the last trial of each, which repeats a trained command and can
    confirm no cause (verdict)."""
    return held_out is not None or len(observed.groups) >= 3
