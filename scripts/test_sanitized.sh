#!/usr/bin/env bash
# The plugin's tests once more, against a build of the plugin with AddressSanitizer
# and UBSan (issue 7).  Needs the test install of scripts/test.sh (the venv).
#
#   bash scripts/test_sanitized.sh [pytest args]
#
# Only the plugin is instrumented: the sanitizer runtimes are preloaded into
# Python, and SKIDSTEER_PLUGIN_LIBRARY points skidsteer at the instrumented build.
# Leak detection is off (CPython and numpy keep allocations until exit that
# LeakSanitizer reports); any ASan or UBSan report aborts the test run.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="$(cd "${SKIDSTEER_VENV:-.venv}" && pwd)"  # absolute: cmake runs it from the build tree
PY="$VENV/bin/python"
BUILD="${SKIDSTEER_SANITIZE_BUILD:-build-sanitize}"

if command -v cmake >/dev/null 2>&1; then
  CMAKE=cmake
else
  "$PY" -m pip install --quiet cmake
  CMAKE="$VENV/bin/cmake"
fi
"$CMAKE" -S . -B "$BUILD" -DSKIDSTEER_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPython_EXECUTABLE="$PY" >/dev/null
"$CMAKE" --build "$BUILD" --parallel 2 >/dev/null
LIBRARY="$BUILD/plugin/tire/libskidsteer_tire.so"
echo "test_sanitized: plugin built with -fsanitize=address,undefined: $LIBRARY"

CC_BIN="$(command -v cc || command -v gcc)"
PRELOAD="$("$CC_BIN" -print-file-name=libasan.so):$("$CC_BIN" -print-file-name=libubsan.so)"
# The plugin tests: the C law against its Python reference, the plugin's
# contract (reset, copy, state, threads, 60 s of random commands per floor) and
# the property tests at their CI budget, except the energy property: it spends
# its 30 s in Python (the tire energy every step), not in the plugin.
TESTS=(tests/test_tire_reference.py tests/test_plugin_contract.py
       tests/test_plugin_properties.py tests/test_tire_law.py
       -k "not energy_never_grows")
SKIDSTEER_PLUGIN_LIBRARY="$PWD/$LIBRARY" \
LD_PRELOAD="$PRELOAD" \
ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:verify_asan_link_order=0" \
UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1" \
  exec "$PY" -m pytest -q -p no:cacheprovider "${TESTS[@]}" "$@"
