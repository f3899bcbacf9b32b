#!/usr/bin/env bash
# Installs skidsteer and runs the main job on its built-in defaults: diagnose
# the bundled sample dataset (data/sample, made by scripts/make_sample_dataset.py:
# three swivel commands x three trials of a robot with one hidden effect),
# printing the verdict and the held-out gain; the report goes to out/diagnosis/.
# Arguments are passed to `skidsteer diagnose` (e.g. a dataset of your own:
# `bash scripts/main-job.sh path/to/dataset --out out/mine`).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh
if [[ $# -eq 0 ]]; then
  set -- data/sample --out out/diagnosis
fi
exec "${SKIDSTEER_VENV:-.venv}/bin/skidsteer" diagnose "$@"
