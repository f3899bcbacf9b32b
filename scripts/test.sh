#!/usr/bin/env bash
# Installs skidsteer with its test dependencies and runs the test suite.
# Under CI (CI=true) the rendering and Ray-backend tests are required rather than
# skippable.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh --test
if [[ "${CI:-}" == "true" ]]; then
  export SKIDSTEER_REQUIRE_DISPLAY_TESTS=1
  export SKIDSTEER_REQUIRE_RAY_TESTS=1
fi
exec "${SKIDSTEER_VENV:-.venv}/bin/python" -m pytest "$@"
