#!/usr/bin/env bash
# Installs skidsteer into a virtualenv (.venv by default), building the C plugin.
# Usage: scripts/install.sh [--test]
#   --test  also the test dependencies, the ray extra (the Ray backend's tests
#           run against a local Ray instance), and the system packages the
#           rendering tests need (Xvfb; EGL/Mesa), installed with apt-get when possible.
# Environment: PYTHON (default python3), SKIDSTEER_VENV (default .venv).
# The versions installed are constraints.txt's (on Python 3.11).
set -euo pipefail
cd "$(dirname "$0")/.."

with_tests=0
[[ "${1:-}" == "--test" ]] && with_tests=1
PYTHON=${PYTHON:-python3}
VENV=${SKIDSTEER_VENV:-.venv}

as_root() {
  if [[ $(id -u) -eq 0 ]]; then "$@"
  elif command -v sudo >/dev/null 2>&1; then sudo "$@"
  else return 1
  fi
}

apt_install() {  # apt_install PACKAGE... : installs what is missing, if we may
  local missing=()
  for pkg in "$@"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
  [[ ${#missing[@]} -eq 0 ]] && return 0
  if command -v apt-get >/dev/null 2>&1 &&
     as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
     as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null; then
    echo "install: apt-get installed ${missing[*]}"
  else
    echo "install: could not install ${missing[*]} (needs apt-get and root or sudo)" >&2
    return 1
  fi
}

# a C compiler for the plugin (CMake itself comes from PyPI if missing)
if ! command -v cc >/dev/null 2>&1 && ! command -v gcc >/dev/null 2>&1; then
  apt_install build-essential
fi
if ! "$PYTHON" -c "import venv, ensurepip" >/dev/null 2>&1; then
  apt_install python3-venv
fi
if [[ $with_tests -eq 1 ]]; then
  # Xvfb for the viewer test, EGL/Mesa for offscreen rendering
  apt_install xvfb xauth libegl1 libgl1-mesa-dri || true
fi

# A virtual environment whose python runs as one (its prefix is not its base's): a
# half-made one (a fresh clone's first install once ran pip in the base interpreter,
# then lost .venv/bin/python, and failed three lines later with "No such file") is made
# again once, then refused with what was found.
is_venv() {
  [[ -x "$VENV/bin/python" ]] &&
    "$VENV/bin/python" -c 'import sys; sys.exit(sys.prefix == sys.base_prefix)' 2>/dev/null
}
if ! is_venv; then
  [[ -e "$VENV" ]] &&
    echo "install: $VENV is not a working virtual environment; making it again" >&2
  "$PYTHON" -m venv --clear "$VENV"
fi
if ! is_venv; then
  echo "install: '$PYTHON -m venv $VENV' did not make a working virtual environment" \
       "($VENV/bin/python: $(ls -l "$VENV/bin/python" 2>&1)); remove $VENV and run again," \
       "or set PYTHON to another interpreter" >&2
  exit 1
fi
"$VENV/bin/python" -m pip install --quiet --upgrade pip
# The library versions the README's numbers were measured with (constraints.txt, made
# on Python 3.11): for pip and for the plugin's isolated build.
if [[ "$("$VENV/bin/python" -c 'import sys; print(sys.version_info[:2] == (3, 11))')" == "True" ]]; then
  export PIP_CONSTRAINT="$PWD/constraints.txt"
else
  echo "install: constraints.txt pins Python 3.11's libraries; this is $("$VENV/bin/python" -V):" \
       "installing the newest compatible ones (numbers may differ in the last digits)" >&2
fi
if [[ $with_tests -eq 1 ]]; then
  "$VENV/bin/python" -m pip install --quiet ".[test,ray]"
else
  "$VENV/bin/python" -m pip install --quiet .
fi
echo "install: skidsteer installed in $VENV"
