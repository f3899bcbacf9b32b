"""Writes data/sample/: the small measured-style dataset the README's first command diagnoses.

Recipe (skidsteer.diagnosis.synth.SAMPLE_RECIPE): the extended robot swivelling on
concrete at 15, 30 and 60 deg/s, three trials of 10 s each, recorded through the default
sensor chain (skidsteer.simulation.sensor_chain.SensorChain: 80 Hz bandwidth, noise, 60 Hz
hum, zero-g offset errors) as CSV (LabVIEW xlsx is 10x larger), with one hidden
effect.  The effect and its parameters are written to data/sample.truth.json,
outside the dataset, so that `diagnose data/sample` cannot see them.

    python scripts/make_sample_dataset.py [--out data/sample]
"""

import argparse
import json
import shutil
from pathlib import Path

import skidsteer  # noqa: F401  (registers the plugin)
from skidsteer.data.files import write_atomically
from skidsteer.diagnosis.synth import SAMPLE_RECIPE, make_dataset
from skidsteer.robot import Setup


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    root = Path(__file__).resolve().parents[1]
    parser.add_argument("--out", type=Path, default=root / "data" / "sample")
    args = parser.parse_args()
    # built beside the old one and swapped in only when complete: an interrupted
    # run leaves the previous sample (and a .partial directory) behind
    partial = args.out.with_name(args.out.name + ".partial")
    shutil.rmtree(partial, ignore_errors=True)
    recipe = dict(SAMPLE_RECIPE)
    setup = Setup(build=recipe.pop("build"), floor=recipe.pop("floor"))
    truth = make_dataset(partial, setup=setup, **recipe)
    path = args.out.with_name(args.out.name + ".truth.json")
    text = json.dumps({**truth, "recipe": dict(SAMPLE_RECIPE)}, indent=2) + "\n"
    if args.out.exists():
        shutil.rmtree(args.out)
    partial.rename(args.out)
    write_atomically(path, lambda tmp: tmp.write_text(text))
    print(f"wrote {args.out} ({len(list(args.out.iterdir()))} files) and {path}")


if __name__ == "__main__":
    main()
