#!/usr/bin/env bash
# Installs skidsteer with its test dependencies and runs the test suite (what CI runs).
#
#   bash scripts/test.sh [--quick] [pytest arguments]
#
# --quick: only the tests not marked slow (pytest -m "not slow"; the marker's
# rule is in pyproject.toml), on the venv's install as it is (installed first only
# when the venv has none; an install older than the checkout is refused by
# tests/conftest.py), for the edit-and-test loop.
# Under CI (CI=true) the rendering and Ray-backend tests are required rather than
# skippable, and the plugin's tests run again under ASan/UBSan
# (scripts/test_sanitized.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
args=()
for arg in "$@"; do
  if [[ "$arg" == "--quick" ]]; then quick=1; else args+=("$arg"); fi
done
VENV=${SKIDSTEER_VENV:-.venv}
if [[ $quick -eq 0 ]] || ! "$VENV/bin/python" -c "import skidsteer" >/dev/null 2>&1; then
  scripts/install.sh --test
fi
if [[ "${CI:-}" == "true" ]]; then
  export SKIDSTEER_REQUIRE_DISPLAY_TESTS=1
  export SKIDSTEER_REQUIRE_RAY_TESTS=1
fi
# The plugin's tests once more against an AddressSanitizer/UBSan build of it
# (issue 7): always under CI, elsewhere with SKIDSTEER_SANITIZE_TESTS=1.  They run
# beside the main suite, whose many single-threaded tests leave a core idle; their
# output follows the main suite's.
sanitize=0
if [[ "${CI:-}" == "true" || "${SKIDSTEER_SANITIZE_TESTS:-}" == "1" ]]; then
  sanitize=1
  sanitize_log=$(mktemp)
  bash scripts/test_sanitized.sh >"$sanitize_log" 2>&1 &
  sanitize_pid=$!
fi
status=0
# Two pytest workers.  --dist loadgroup: a test is a unit of work of its own, but for
# the tests that share a module-scoped fixture (one unit per module, so that the
# fixture is computed once; tests/scheduling.py groups them) and the hidden-effect
# diagnoses of test_diagnose.py (one unit per effect: the slow part of the suite,
# spread over both workers; hidden_effects.py).  The units go out in file order
# (--no-loadscope-reorder), not largest first.  SKIDSTEER_TEST_WORKERS=0 runs them
# in one process.  pytest stays below 9.2 for the groups (pyproject.toml).
workers=${SKIDSTEER_TEST_WORKERS:-2}
pytest_args=()
if [[ "$workers" -gt 0 ]]; then
  pytest_args=(-n "$workers" --dist loadgroup --no-loadscope-reorder)
fi
if [[ $quick -eq 1 ]]; then
  pytest_args+=(-m "not slow")
fi
"$VENV/bin/python" -m pytest "${pytest_args[@]}" "${args[@]}" || status=$?
if [[ $sanitize -eq 1 ]]; then
  sanitize_status=0
  wait "$sanitize_pid" || sanitize_status=$?
  echo "---- scripts/test_sanitized.sh (ran beside the main suite) ----"
  cat "$sanitize_log"
  rm -f "$sanitize_log"
  if [[ $sanitize_status -ne 0 ]]; then
    echo "test: the sanitized plugin tests failed (exit $sanitize_status)" >&2
    [[ $status -ne 0 ]] || status=$sanitize_status
  fi
fi
exit "$status"
