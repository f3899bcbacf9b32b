#!/usr/bin/env bash
# Installs skidsteer with its test dependencies and runs the test suite.
# Under CI (CI=true) the rendering and Ray-backend tests are required rather than
# skippable, and the plugin's tests run again under ASan/UBSan
# (scripts/test_sanitized.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh --test
if [[ "${CI:-}" == "true" ]]; then
  export SKIDSTEER_REQUIRE_DISPLAY_TESTS=1
  export SKIDSTEER_REQUIRE_RAY_TESTS=1
fi
"${SKIDSTEER_VENV:-.venv}/bin/python" -m pytest "$@"
# The plugin's tests once more against an AddressSanitizer/UBSan build of it
# (issue 7): always under CI, elsewhere with SKIDSTEER_SANITIZE_TESTS=1.
if [[ "${CI:-}" == "true" || "${SKIDSTEER_SANITIZE_TESTS:-}" == "1" ]]; then
  bash scripts/test_sanitized.sh
fi
