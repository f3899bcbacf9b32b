"""The next command to record: where two fitted causes the data cannot tell apart predict
different measurements, or where the cause the training runs point to predicts a
discrepancy the held-out runs do not show.

When a diagnosis names no cause because two candidates each remove most of the
held-out discrepancy (they "explain the data about equally well", or the training
and held-out halves prefer different ones), the recorded commands do not separate
them, and no threshold will (SEPARATE).  When it names none because the held-out
command shows no discrepancy of its own (the effect shows on the training commands
alone), nothing recorded can confirm the training runs' lead; a command where the
lead's fit and the base model predict different measurements can (CONFIRM: the same
scoring, with the base model as the second model).  A new recording can: ``separating_commands``
simulates both fits, each at its fitted parameters and realisation, on swivels the
dataset does not have, and scores how far apart their features land, in the units
every error of the diagnosis is read in (the trials' spread), widened by each
model's own start-to-start scatter there.  The command that separates them most is
what to record next; a separation below ``Z_CONSISTENT`` means neither model could
be told from the other's prediction by the limit the diagnosis reads a discrepancy
with, so no swivel in the range helps (and the report says so).

This is a prediction of the two fitted models, not of the robot: the robot may be
neither, and a random geometry's fit carries one realisation of it (its scatter
across realisations is not in the start-to-start scatter).  Whether recording the
proposed command resolves a diagnosis is measured on the generalisation benchmark's
undecided draws (docs/diagnose.md, "The next command to record").
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from skidsteer.data.dataset import Group
from skidsteer.diagnosis.comparison import Comparison, simulate_groups
from skidsteer.diagnosis.verdict import Z_CONSISTENT
from skidsteer.features.extract import comparison_feature_names

# the swivel rates a proposal is chosen from, deg/s: the range of the generalisation
# benchmark's commands and of the regime map (docs/diagnose.md), where the model's swivels
# have been measured against its own data; above it the model does not reproduce the
# thesis's wheel hop (Sec. 3.2: hop above 64 deg/s), so its predictions there are not
# trusted.  Steps of 10 deg/s (assumed: the benchmark's commands are 5 deg/s apart, and
# neighbouring commands' features differ by about a trial spread there)
CANDIDATE_RATES_DEG_S = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0)
# a candidate this close to a recorded command of its setup counts as recorded (half the
# candidates' step): the data already hold it
RECORDED_WITHIN_DEG_S = 5.0
# starts per model and command (comparison.start_state 0..): the median is the
# prediction, their spread the model's own scatter there (assumed: 3, the fewest that
# give a median and a spread; the diagnosis's errors take 5, and a proposal costs
# 2 models x 3 starts x 6 commands = 36 simulations, about a twentieth of a diagnosis)
PROPOSAL_STARTS = 3
# what a diagnosis's proposals are for (Diagnosis.next_command_purpose)
SEPARATE = "separate"  # two undecided fits (undecided_pair)
CONFIRM = "confirm"  # the training runs' lead against the base model (verdict.unconfirmed_lead)
BASE_MODEL = "base model"  # how a CONFIRM proposal's "predicted" names the base model


class BaseModel(NamedTuple):
    """The base model as separating_commands' second model (a fit's cause and factory)."""
    factory: object  # comparison.model_factory() of the diagnosis's step
    cause: str = BASE_MODEL


def candidate_commands(groups: list[Group],
                       rates_deg_s=CANDIDATE_RATES_DEG_S) -> list[Group]:
    """Swivels (v = 0) at `rates_deg_s` on each setup of the recorded groups, without the
    rates a setup already has (within RECORDED_WITHIN_DEG_S of a recorded command's rate)."""
    setups = sorted({g.setup for g in groups}, key=lambda s: (str(s.floor), str(s.build),
                                                               s.mount))
    out = []
    for setup in setups:
        recorded = [abs(g.omega_deg_s) for g in groups if g.setup == setup]
        out += [Group(0.0, float(w), setup) for w in rates_deg_s
                if all(abs(w - r) >= RECORDED_WITHIN_DEG_S for r in recorded)]
    return out


def separation(logs_a: np.ndarray, logs_b: np.ndarray, scale: np.ndarray,
               spread_a: np.ndarray, spread_b: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Per command, how far two models' predictions are apart: the RMS over features of
    (median_a - median_b) / sqrt(scale^2 + spread_a^2 + spread_b^2), the medians over
    starts.

    logs_a, logs_b: (starts, commands, features), features as the measurement would show
    them (Comparison.simulated_log); scale: (features,), what a discrepancy is measured in;
    spread_a, spread_b: (commands, features), each model's start-to-start spread
    (Comparison.start_spread of the same simulations).  Returns (separation per command,
    (commands, features) z of the medians' difference); a feature neither model scores
    (NaN) does not count.
    """
    logs_a, logs_b = np.asarray(logs_a, float), np.asarray(logs_b, float)
    spreads = [np.asarray(s, float) for s in (spread_a, spread_b)]
    if (logs_a.shape[1:] != logs_b.shape[1:] or logs_a.shape[-1] != np.shape(scale)[-1]
            or any(s.shape != logs_a.shape[1:] for s in spreads)):
        raise ValueError(f"separation: shapes {logs_a.shape}, {logs_b.shape}, scale "
                         f"{np.shape(scale)} and spreads {[s.shape for s in spreads]} do "
                         f"not match (starts, commands, features)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an unscored feature: NaN
        width = np.sqrt(np.asarray(scale, float) ** 2 + spreads[0] ** 2 + spreads[1] ** 2)
        z = (np.nanmedian(logs_a, axis=0) - np.nanmedian(logs_b, axis=0)) / width
        return np.sqrt(np.nanmean(z ** 2, axis=1)), z


def separating_commands(first, second, comparison: Comparison, groups: list[Group],
                        duration_s: float, chain, backend, cache=None, progress=None,
                        rates_deg_s=CANDIDATE_RATES_DEG_S,
                        starts: int = PROPOSAL_STARTS) -> list[dict]:
    """The candidate commands (candidate_commands of the recorded `groups`) ranked by how
    far apart the two fits (search.Fit, with their model factories) predict them
    (separation), best first: each with its label, command, separation, and the feature
    that differs most with both fits' values there ("predicted": the median over starts, as
    measured: log10 power, or m/s^2 for the centripetal mean).  Empty when
    no candidate is left (the data hold every rate)."""
    commands = candidate_commands(groups, rates_deg_s)
    if not commands:
        return []
    jobs = [(fit.factory, commands) for fit in (first, second) for _ in range(starts)]
    sims = simulate_groups(jobs, duration_s, chain, backend=backend, progress=progress,
                           cache=cache, signals=False,
                           starts=[s for _ in (first, second) for s in range(starts)])
    logs = np.stack([comparison.simulated_log(s.features) for s in sims])
    scale = comparison.scale if comparison.scale.ndim == 1 else np.median(comparison.scale,
                                                                           axis=0)
    apart, z = separation(logs[:starts], logs[starts:], scale,
                          comparison.start_spread(sims[:starts]),
                          comparison.start_spread(sims[starts:]))
    names = comparison_feature_names()
    out = []
    for k, g in enumerate(commands):
        f = int(np.nanargmax(np.abs(np.nan_to_num(z[k])))) if np.isfinite(apart[k]) else 0
        out.append({"command": g.label, "v_mps": g.v_mps, "omega_deg_s": g.omega_deg_s,
                    "separation": float(apart[k]), "feature": names[f],
                    "feature_z": float(z[k, f]),
                    "predicted": {first.cause: float(np.nanmedian(logs[:starts, k, f])),
                                  second.cause: float(np.nanmedian(logs[starts:, k, f]))}})
    out.sort(key=lambda d: -np.nan_to_num(d["separation"], nan=-1.0))
    return out


def undecided_pair(fits: list, named, base_held: float, limit: float, min_gain: float):
    """The two fits a new command should tell apart, or None: when no cause is named, the
    held-out runs show a discrepancy of their own (base_held above `limit`, the diagnosis's
    Z_CONSISTENT) and the two best fits each remove at least `min_gain` (MIN_GAIN) of it:
    two candidates explain most of what the data show, and the data do not choose."""
    if named is not None or len(fits) < 2 or base_held <= limit:
        return None
    first, second = fits[0], fits[1]
    if first.removed < min_gain or second.removed < min_gain:
        return None
    return first, second


def worth_recording(proposal: dict, limit: float = Z_CONSISTENT) -> bool:
    """Whether a proposed command's separation reaches `limit` (the diagnosis's
    Z_CONSISTENT): the held-out runs of that command, once recorded, could show it."""
    return proposal["separation"] >= limit


def _note(proposals: list[dict], causes: tuple[str, str], limit: float, *, goal: str,
          predicts: str, fits: str, shows: str, apart: str) -> str:
    """What proposal_note and confirmation_note share: the first proposal, to record and
    hold out, when it reaches `limit`, else that no swivel in the range does.  goal and
    shows are the clauses that name the models; predicts, with {separation}, says how far
    apart they land; fits is what --hold-out tests; apart follows the RMS z of a miss."""
    if not proposals:
        return ""
    top = proposals[0]
    if worth_recording(top, limit):
        a, b = (top["predicted"][c] for c in causes)
        return (f"; {goal}, record a swivel at {top['omega_deg_s']:g} deg/s "
                f"({top['command']}): {predicts.format(separation=top['separation'])} "
                f"({top['feature']} the most: {a:.2f} against {b:.2f}); diagnose it with "
                f"--hold-out '{top['command']}' to test the {fits} on it")
    rates = [p["omega_deg_s"] for p in proposals]
    return (f"; no swivel of {min(rates):g}-{max(rates):g} deg/s the data lack {shows} in "
            f"simulation (at most {top['separation']:.1f} RMS z{apart}, at "
            f"{top['omega_deg_s']:g} deg/s, against the {limit} a discrepancy needs)")


def proposal_note(proposals: list[dict], first, second, limit: float) -> str:
    """The clause a verdict's reason gains from separating_commands' proposals ('' when
    there is no candidate): the command to record, and to hold out once recorded (the fits
    trained on the commands recorded now then predict it, which is what separates them:
    held out by split()'s rule instead, the tied commands decide again; docs/diagnose.md),
    or that none in the range would do."""
    return _note(proposals, (first.cause, second.cause), limit,
                 goal=f"to tell {first.cause} from {second.cause}",
                 predicts="their fits predict it {separation:.1f} RMS z apart", fits="fits",
                 shows=f"tells {first.cause} from {second.cause}", apart=" apart")


def confirmation_note(proposals: list[dict], lead, limit: float) -> str:
    """The clause a verdict's reason gains from separating_commands' proposals of the
    training runs' lead against the base model ('' when there is no candidate): the
    command where the lead's fit predicts a discrepancy of at least `limit` (what the
    held-out runs must show before they can confirm a cause), to record and hold out, or
    that no swivel in the range shows one."""
    return _note(proposals, (lead.cause, BASE_MODEL), limit, goal=f"to confirm {lead.cause}",
                 predicts="its fit predicts it {separation:.1f} RMS z from the base model",
                 fits="fit", shows=f"shows {lead.cause}'s fit apart from the base model",
                 apart="")
