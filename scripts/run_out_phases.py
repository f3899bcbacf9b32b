"""Is a wheel run-out's size told apart from its wheels' phases?  A probe of one draw of
the generalisation benchmark (a wheel_eccentricity draw).

Turning in place, every wheel turns at one rate, the left ones backwards, so to first
order the run-out forces the body through three phasor sums of the wheels' phases:
heave (all wheels), pitch (front less rear) and roll (left less right), each up to 4
wheel-units long.  If the data read only these, a run-out e with phases whose sums point
the truth's way but are k times as long fits like the truth at e / k: the size would be
known only through its product with the phases.  The probe evaluates the draw's
training error (diagnose's, one start) at the truth's phases and at phase sets parallel
to them (within 4 deg) but shorter, at the truth's run-out and at the run-out that keeps
the product.

    python scripts/run_out_phases.py --draw draw-1351 --out /tmp/run-out-phases
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).parent / "bench"))
import bench_diagnose_generalisation as generalisation  # noqa: E402

from skidsteer.diagnosis import causes  # noqa: E402
from skidsteer.diagnosis.causes.wheel_eccentricity import wheel_phases  # noqa: E402
from skidsteer.diagnosis.diagnose import base_and_split  # noqa: E402
from skidsteer.diagnosis.evaluate import Evaluations  # noqa: E402
from skidsteer.diagnosis.verdict import REALISATIONS  # noqa: E402
from skidsteer.reports.diagnosis import _observed  # noqa: E402
from skidsteer.robot import load_model, tire  # noqa: E402
from skidsteer.simulation.backends import LocalBackend  # noqa: E402
from skidsteer.simulation.sensor_chain import SensorChain  # noqa: E402

ROWS = Path(__file__).parents[1] / "docs" / "diagnose-generalisation.jsonl"
PARALLEL_DEG = 4.0  # how near the truth's direction a phase set counts as parallel
LENGTHS = (0.5, 0.75)  # the shorter phasor lengths probed, of the truth's


def wheel_signs() -> tuple[np.ndarray, np.ndarray]:
    """(front +1 / rear -1, left +1 / right -1) of each wheel, tire.find_wheels order."""
    m = load_model()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    wheels = tire.find_wheels(m, tire.instance_id(m))
    offset = np.array([d.xpos[m.jnt_bodyid[w.joint]] for w in wheels]) - d.subtree_com[1]
    return np.sign(offset[:, 0]), np.sign(offset[:, 1])


def phasor_sums(phases_rad: np.ndarray, front: np.ndarray, left: np.ndarray) -> np.ndarray:
    """(heave, pitch, roll) lengths of the wheels' run-out phasors in an in-place turn
    (the left wheels turn backwards: their phasors conjugate), in wheel-units."""
    z = np.exp(1j * phases_rad)
    z = np.where(left > 0, np.conj(z), z)
    return np.abs([z.sum(), (front * z).sum(), (left * z).sum()])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draw", default="draw-1351")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--rows", type=Path, default=ROWS)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    rows = [json.loads(line) for line in args.rows.read_text().splitlines() if line.strip()]
    row = [r for r in rows if r["case"] == args.draw][-1]
    if row["effect"] != "wheel_eccentricity":
        raise SystemExit(f"{args.draw} hides {row['effect']}, not a wheel run-out")
    front, left = wheel_signs()
    truth_seed = int(np.random.default_rng(row["seed"]).integers(2**31))  # truth_edit's draw
    truth = phasor_sums(wheel_phases(truth_seed, len(front)), front, left)
    e_truth = row["truth"]["eccentricity_m"]
    print(f"{args.draw}: run-out {e_truth * 1e3:.3f} mm, phasor sums (heave, pitch, roll) "
          f"{np.round(truth, 2)}")
    for r in range(REALISATIONS):
        print(f"  realisation {r}: {np.round(phasor_sums(wheel_phases(r, 4), front, left), 2)}")
    parallel: dict[float, tuple[int, float]] = {}
    for seed in range(1_000_000):
        q = phasor_sums(wheel_phases(seed, len(front)), front, left)
        if q @ truth < np.cos(np.radians(PARALLEL_DEG)) * np.linalg.norm(q) * np.linalg.norm(truth):
            continue
        k = float(np.linalg.norm(q) / np.linalg.norm(truth))
        for length in LENGTHS:
            if abs(k - length) < 0.05 and length not in parallel:
                parallel[length] = (seed, k)
        if len(parallel) == len(LENGTHS):
            break
    data = args.out / "datasets" / args.draw
    if not (data / "runs.csv").exists():
        generalisation.generate(generalisation.case_of(row), args.out, 3, 20.0, args.threads)
    observed = _observed(data, None)
    backend, chain = LocalBackend(args.threads), SensorChain()
    split = base_and_split(observed, timestep=None, chain=chain, backend=backend,
                           held_out=row["held_out_groups"])
    cause = causes.get("wheel_eccentricity")
    evaluate = Evaluations(cause, split.comparison, observed.groups, observed.duration_s,
                           split.train, None, chain, backend, None, None, 1)
    points = [("the truth's phases", e_truth, truth_seed)]
    for _, (seed, k) in sorted(parallel.items()):
        points += [(f"parallel, {k:.2f}x as long", e_truth, seed),
                   (f"parallel, {k:.2f}x as long", e_truth / k, seed)]
    print(f"base model: training error {row['base_train']:.2f}")
    for label, e, seed in points:
        error = evaluate([(cause.parameters(e), seed)])[0]
        print(f"{label:28s} run-out {e * 1e3:.3f} mm (seed {seed}): training error {error:.2f}")


if __name__ == "__main__":
    main()
