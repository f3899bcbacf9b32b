#!/usr/bin/env bash
# Installs skidsteer and runs the main job on its built-in defaults:
# a 20 s swivel in place at 30 deg/s on concrete (extended robot), printing its
# summary and writing the accelerometer log to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh
exec "${SKIDSTEER_VENV:-.venv}/bin/skidsteer" swivel "$@"
