"""The hidden-effect diagnoses that tests/test_diagnose.py checks: a "measured"
dataset from a truth model (our model plus one effect, seeded) through the sensor
chain into LabVIEW xlsx files, diagnosed against its rivals (the causes the
generalisation benchmark most often confuses it with; candidates_for), the null
with every candidate.

pytest's two workers (scripts/test.sh, --dist loadgroup) share the diagnoses, the
slow part of the suite, one effect at a time; every diagnosis of a test session
reads and writes one simulation cache (shared_cache_dir), also across the workers:
the candidates' grids are the same models whatever the data, and a stored
simulation gives the numbers a new one would (the kill-and-resume test checks that
a resumed diagnosis equals an uninterrupted one; entries are written atomically,
so two workers may store one at once).
"""

from __future__ import annotations

import collections
import json
import os
from pathlib import Path

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.synth import make_dataset
from skidsteer.reports.diagnosis import diagnose

SEED = 3
DURATION_S = 8.0
# A once-per-revolution effect shows only in records that hold a revolution of the
# wheels in the steady window (from 4 s): at 30 deg/s the wheels turn once in 7.9 s
# (7.2 s commanded, 9 % servo droop), at 15 deg/s twice the rate needs 8.9 s (the
# once-per-revolution line there needs 17.7 s, beyond even a 20 s record: 19 % droop).
# 14 s holds both with a second to spare and scores the same wheel-order features as
# the thesis's 20 s (Sec. 3.2).  The other effects show in 8 s.
RECORD_S = {"wheel_eccentricity": 14.0}
# Each hidden cause is diagnosed against its RIVALS, the causes it is most often
# confused with, which its naming has to beat; an effect outside every candidate
# against the OUTSIDE_RIVALS causes most often ranked first on its draws, the ones it
# could be wrongly named (it must stay unexplained with no other candidate to block
# them); the null against every candidate (it fits none).  A diagnosis with every
# candidate for each took CI over its 30 min (stop 40's code: 31.8 min alone here, about
# 45 min on CI at stop 39's ratio, 1.41; with one rival each and the outside effect's
# two, 16.4 min in pytest here); the rates over every candidate on fresh draws are the
# generalisation benchmark's (scripts/bench/bench_diagnose_generalisation.py,
# docs/diagnose-generalisation.md).
RIVALS = 1
OUTSIDE_RIVALS = 2
BENCHMARK = Path(__file__).resolve().parents[1] / "docs" / "diagnose-generalisation.jsonl"


def rivals(effect: str, benchmark: Path = BENCHMARK, n: int = RIVALS) -> list[str]:
    """The n causes the generalisation benchmark ranks most often among the first n
    beside `effect` (its committed rows, the newest per draw, that kept their ranking;
    ties by name): the ones a diagnosis of `effect` has to tell it from."""
    newest = {}
    for number, line in enumerate(benchmark.read_text().splitlines(), 1):
        if line.strip():
            try:
                row = json.loads(line)
            except json.JSONDecodeError as err:
                raise ValueError(f"{benchmark}:{number}: not a JSON row ({err})") from err
            newest[row["case"]] = row
    counts = collections.Counter()
    for row in newest.values():
        if row["effect"] == effect and row.get("ranking"):
            others = [r["cause"] for r in row["ranking"] if r["cause"] != effect]
            counts.update(others[:n])
    chosen = sorted(counts, key=lambda cause: (-counts[cause], cause))[:n]
    if len(chosen) < n:
        raise ValueError(f"{benchmark}: fewer than {n} rivals of {effect} in its rankings "
                         f"({chosen}); rerun the benchmark on {effect} draws")
    return chosen


def candidates_for(effect: str | None) -> list[str] | None:
    """What the hidden-effect test diagnoses `effect` with (None: every candidate, for
    the null)."""
    if effect is None:
        return None
    if effect not in causes.CAUSES:  # an effect outside every candidate
        return rivals(effect, n=OUTSIDE_RIVALS)
    return [effect, *rivals(effect)]


def shared_cache_dir(tmp_path_factory):
    """One simulation cache for the session: under the workers' common base directory
    when pytest-xdist runs the tests, else under the session's own."""
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent
    return base / "diagnose-simulations"


def hidden_diagnoses(tmp_path_factory):
    """effect -> (truth, diagnosis, root), each computed once per module (per worker:
    an effect's tests run on one)."""
    cache = {}
    shared = shared_cache_dir(tmp_path_factory)

    def run(effect, out=False):
        if effect not in cache:
            root = tmp_path_factory.mktemp(f"hidden-{effect}")
            truth = make_dataset(root / "data", effect, seed=SEED,
                                 duration_s=RECORD_S.get(effect, DURATION_S))
            result = diagnose(root / "data", root / "out" if out else None,
                              progress=False, figures=out, cache_dir=shared,
                              candidates=candidates_for(effect))
            cache[effect] = (truth, result, root)
        return cache[effect]

    return run


def check_named(truth, result, effect):
    """The hidden cause named, its main parameter within its recovery factor, at least
    half of the held-out discrepancy removed."""
    assert result["verdict"] == "explained", result["reason"]
    assert result["cause"] == effect
    main = truth["main_parameter"]
    fitted, hidden_value = result["parameters"][main], truth["parameters"][main]
    factor = causes.get(effect).recovery_factor
    assert hidden_value / factor <= fitted <= hidden_value * factor, (fitted, hidden_value)
    assert result["gain"]["relative_reduction"] >= 0.5


def check_not_wrong(result, effect):
    """Where it cannot tell, it says unexplained rather than guess."""
    assert result["cause"] in (effect, None), result["reason"]
    if result["cause"] is None:
        assert result["verdict"] == "unexplained"
