"""The verdict rules: from the base model's errors and the ranked fits to "no-discrepancy",
"explained", "partly-explained" or "unexplained", and the cause named.

An error is the RMS z-score of the features against the trials' spread: a simulation
as close to the measurements as one trial to another scores ~1 to ~1.4 (it is one more
trial).  ``verdict`` reads errors and fit-like objects only (FitLike), so it can judge
stored results without simulating.  The measurements behind each rule:
docs/diagnose.md and docs/diagnose-notebook.md.
"""

from __future__ import annotations

from typing import Protocol, Sequence

import numpy as np

from skidsteer.diagnosis import causes as cause_registry
from skidsteer.diagnosis.comparison import TRIALS_SCALE

Z_CONSISTENT = 2.0  # base error at or below: "no-discrepancy"
# a named cause whose held-out error is within this "explains" the data; above it, one
# that removes at least MIN_GAIN is "partly-explained" (a large discrepancy mostly removed)
Z_EXPLAINED = 3.0
MIN_GAIN = 0.5  # a named cause removes at least half of the held-out discrepancy (gain)
# the named fit beats the runner-up's score by this share of the base model's excess over
# it, or alone is consistent with the held-out runs (separated); assumed, set before any
# test ran: a runner-up closing 3/4 of the gap is a rival explanation, not a worse one
SEPARATION = 0.25
# AIC: score = E^2 + PARAMETER_PENALTY k / (training runs); choosing one of N
# realisations counts as ln N parameters (its description length in nats)
PARAMETER_PENALTY = 2.0
# the realisations a cause with a random geometry tries (search.fit_cause), the one fitting
# the training runs best kept; the score pays ln(REALISATIONS) parameters for the choice
# (assumed: 8 draws cover the phases of four wheels coarsely; each costs one simulation
# of every command)
REALISATIONS = 8


class FitLike(Protocol):
    """What the rules read of a fit (search.Fit has it, and so can a stored row)."""

    cause: str
    held_out_error: float
    train_error: float
    score: float

    @property
    def fitted(self) -> list[str]: ...


def profile_factor(n_train: int) -> float:
    """The profile bound on a training error squared, as a factor on the best fit's:
    E^2 <= E_min^2 (1 + 1/n), a Delta chi^2 = 1 bound with the residual variance scaled
    to the best fit and each training run counted as one observation (features of a run
    are correlated).  The intervals (intervals.interval) and told_from_base read it."""
    return 1 + 1 / max(n_train, 1)


def penalised_score(error: float, n_params: float, n_train: int) -> float:
    """An error squared plus PARAMETER_PENALTY per fitted parameter (AIC)."""
    return error ** 2 + PARAMETER_PENALTY * n_params / n_train


def n_parameters(cause: str, n_fitted: int) -> float:
    """The parameters a fit of `cause` pays for (penalised_score): its n_fitted fitted
    ones, and ln(REALISATIONS) for a chosen realisation (a cause with a random geometry;
    a name not in the registry, a test's stand-in, has none)."""
    registered = cause_registry.CAUSES.get(cause)
    random = registered is not None and registered.random_realisation
    return n_fitted + (np.log(REALISATIONS) if random else 0.0)


def gain(base_held: float, extended_held: float, noise: float) -> float:
    """The fraction of the base model's held-out discrepancy that an extension removes.

    The discrepancy is the mean square z-score in excess of what a simulation at
    the trials' mean scores against single trials (Comparison.noise_error): a
    perfect extension scores 1 (up to chance), the base model 0.  The plain ratio
    of RMS errors would not do: it cannot reach 50 % for a perfect extension when
    the base error is below twice the noise, however clear the effect.  Capped at
    1 (an extension that scores below the trials' noise does so by chance).
    """
    excess = base_held ** 2 - noise ** 2
    if excess <= 0:
        return 0.0
    return float(min(1.0, (base_held ** 2 - extended_held ** 2) / excess))


def separated(base_held: float, best: FitLike, others: Sequence[FitLike]) -> bool:
    """Whether the best fit is told apart from the others (SEPARATION): it beats the
    runner-up's score by a quarter of the base model's excess over it, or it is
    consistent with the held-out runs (within Z_CONSISTENT) and none of the others is."""
    base_score = base_held ** 2
    if others[0].score - best.score >= SEPARATION * (base_score - best.score):
        return True
    return (best.held_out_error <= Z_CONSISTENT
            and all(f.held_out_error > Z_CONSISTENT for f in others))


def told_from_base(base_train: float, best: FitLike, n_train: int) -> bool:
    """Whether the training runs tell the best fit from the base model: the base model's
    training error lies outside the fit's profile bound (profile_factor, on the fit's
    own training error: not the intervals' wider interval_bound).  Without it a cause
    fitted next to its null value could be named on the held-out runs' scatter alone."""
    return base_train ** 2 > best.train_error ** 2 * profile_factor(n_train)


def rivals(others: Sequence[FitLike], base_train: float, n_train: int) -> list:
    """The other fits that are rival explanations (SEPARATION): those the training runs
    tell from the base model, in the given order.  A fit they do not tell from it
    explains the held-out runs alone, with parameters the training runs leave free."""
    return [f for f in others if told_from_base(base_train, f, n_train)]


def training_score(fit: FitLike, n_train: int) -> float:
    """The fit's training error scored as its held-out error is (penalised_score)."""
    return penalised_score(fit.train_error, n_parameters(fit.cause, len(fit.fitted)), n_train)


def training_lead(fits: Sequence[FitLike], base_train: float, n_train: int):
    """The fit the training runs rank first (the lowest training_score) when they tell it
    from the base model (told_from_base), else None: what the training runs point to,
    whatever the held-out runs say."""
    if not fits:
        return None
    lead = min(fits, key=lambda f: training_score(f, n_train))
    return lead if told_from_base(base_train, lead, n_train) else None


def unconfirmed_lead(fits: Sequence[FitLike], named, base_error: float, base_held: float,
                     base_train: float, n_train: int):
    """The fit a new command could confirm, or None: no cause is named, the records show a
    discrepancy (base_error above Z_CONSISTENT) but the held-out runs show none of their
    own (base_held within it), so nothing held out can confirm the training runs' lead
    (training_lead)."""
    if named is not None or base_error <= Z_CONSISTENT or base_held > Z_CONSISTENT:
        return None
    return training_lead(fits, base_train, n_train)


def preferred_in_training(best: FitLike, others: Sequence[FitLike], n_train: int):
    """The other fit the training runs rank first (the lowest training_score, below the
    best's), or None when they rank the best first too.  When the two halves of the data
    rank different causes first, naming the held-out half's choice is a guess."""
    rival = min(others, key=lambda f: training_score(f, n_train), default=None)
    if rival is not None and training_score(rival, n_train) < training_score(best, n_train):
        return rival
    return None


def verdict(base_error: float, base_held: float, fits: Sequence[FitLike], noise: float, *,
            base_train: float, n_train: int, held_out_new_commands: bool = True,
            scale: str = TRIALS_SCALE) -> tuple[str, FitLike | None, str]:
    """(verdict, named fit or None, reason); fits: best (lowest score) first; noise:
    Comparison.noise_error(); base_train: the base model's training error from start 0
    (as a fit's train_error), n_train the training runs; held_out_new_commands: the
    held-out runs are of commands no training run has (split's way with three commands
    or more); scale: what the errors are read against, as the reason says it.

    no-discrepancy: the base model is within Z_CONSISTENT.  Otherwise, when the held-out
    runs show a discrepancy of their own (base_held above Z_CONSISTENT) and are of
    commands the fits were not trained on (held_out_new_commands), the best fit is
    the most likely cause when it removes at least MIN_GAIN of the held-out discrepancy,
    its score beats the base model's (the held-out error squared: no parameter), the
    training runs tell it from the base model (told_from_base), it is told apart from
    the others the training runs tell from the base model (rivals, separated) and the
    training runs do not prefer another (preferred_in_training: its training score is
    the lowest too); it is then named, "explained" when its held-out error is within
    Z_EXPLAINED and "partly-explained" when it is not (it removes most of a large
    discrepancy and leaves a part no candidate covers: the summary says which features
    and how far).  Anything else is "unexplained".
    """
    if base_error <= Z_CONSISTENT:
        return "no-discrepancy", None, (
            f"the base model's error {base_error:.2f} is within {Z_CONSISTENT} (RMS z against "
            f"{scale})")
    if not fits:
        return "unexplained", None, "no candidate cause applies to this model"
    best = fits[0]
    if base_held <= Z_CONSISTENT:
        # the held-out runs show no discrepancy of their own: nothing on them can confirm
        # a cause, whatever its gain there
        lead = training_lead(fits, base_train, n_train)
        points = ("the training runs tell no candidate from the base model" if lead is None
                  else f"the training runs point to {lead.cause} (training error "
                       f"{base_train:.2f} -> {lead.train_error:.2f})")
        return "unexplained", None, (
            f"the held-out runs show no discrepancy of their own (the base model's error "
            f"{base_held:.2f} there is within {Z_CONSISTENT}), so they cannot confirm a cause; "
            f"{points}")
    removed = gain(base_held, best.held_out_error, noise)
    if not held_out_new_commands:
        # a held-out trial of a trained command shares that command's simulation: a fit
        # moved towards its trained trials moves towards their repeat too, cause or none
        return "unexplained", None, (
            f"the held-out runs repeat the commands the fits were trained on (split needs "
            f"three commands to hold one out), so they cannot confirm a cause: the best "
            f"candidate, {best.cause}, brings their error from {base_held:.2f} to "
            f"{best.held_out_error:.2f} ({removed:.0%} of the discrepancy); record a third "
            "command to confirm it")
    if removed < MIN_GAIN:
        return "unexplained", None, (
            f"the best candidate, {best.cause}, removes only {removed:.0%} of the held-out "
            f"discrepancy (error {base_held:.2f} -> {best.held_out_error:.2f}; trial noise "
            f"{noise:.2f})")
    if best.score >= base_held ** 2:
        # the base model is a candidate too, with no parameter (AIC)
        return "unexplained", None, (
            f"the best candidate, {best.cause}, does not beat the base model on the held-out "
            f"runs once its fitted parameters are paid for (score {best.score:.2f} against "
            f"{base_held ** 2:.2f}; error {base_held:.2f} -> {best.held_out_error:.2f})")
    if not told_from_base(base_train, best, n_train):
        return "unexplained", None, (
            f"the training runs do not tell the best candidate, {best.cause}, from the base "
            f"model (training error {base_train:.2f} -> {best.train_error:.2f}, within the "
            f"fit's profile bound {best.train_error * np.sqrt(profile_factor(n_train)):.2f}); "
            f"the held-out gain ({base_held:.2f} -> {best.held_out_error:.2f}) alone does not "
            "establish it")
    contending = rivals(fits[1:], base_train, n_train)
    if contending and not separated(base_held, best, contending):
        rival = contending[0]
        return "unexplained", None, (
            f"{best.cause} and {rival.cause} explain the data about equally well by the "
            f"separation rule (held-out {best.held_out_error:.2f} vs "
            f"{rival.held_out_error:.2f}: scores {rival.score - best.score:.3g} apart where "
            f"a quarter of the base model's excess, "
            f"{SEPARATION * (base_held ** 2 - best.score):.3g}, tells two fits apart, and "
            f"neither alone within {Z_CONSISTENT})")
    rival = preferred_in_training(best, fits[1:], n_train)
    if rival is not None:
        return "unexplained", None, (
            f"the held-out runs prefer {best.cause} (error {best.held_out_error:.2f} against "
            f"{rival.held_out_error:.2f}) but the training runs prefer {rival.cause} (training "
            f"error {rival.train_error:.2f} against {best.train_error:.2f}, score "
            f"{training_score(rival, n_train):.2f} against {training_score(best, n_train):.2f}"
            f"): the two halves of the data disagree about the cause")
    runner_up = (f"the runner-up {fits[1].cause} reaches {fits[1].held_out_error:.2f}"
                 if len(fits) > 1 else "no other candidate applies")
    if len(fits) > 1 and not told_from_base(base_train, fits[1], n_train):
        runner_up += (f", but the training runs do not tell it from the base model (training "
                      f"error {base_train:.2f} -> {fits[1].train_error:.2f})")
    if best.held_out_error > Z_EXPLAINED:
        return "partly-explained", best, (
            f"{best.cause} is the most likely cause: it removes {removed:.0%} of the held-out "
            f"discrepancy (error {base_held:.2f} -> {best.held_out_error:.2f}; trial noise "
            f"{noise:.2f}) but leaves more than {Z_EXPLAINED}; {runner_up}")
    return "explained", best, (
        f"{best.cause} brings the held-out error from {base_held:.2f} to "
        f"{best.held_out_error:.2f} (trial noise {noise:.2f}: {removed:.0%} of the "
        f"discrepancy removed); {runner_up}")
