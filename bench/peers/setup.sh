#!/usr/bin/env bash
# Creates bench/.venv (if absent) with pyroomacoustics 0.10.1 and its pinned
# dependencies from PyPI, then prints the venv's python path on stdout.
# Idempotent: a second run only checks the installed versions (~1 s).
# Progress goes to stderr so that `PY=$(bash bench/peers/setup.sh)` works.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="${FRUSTA_PEERS_VENV:-$here/../.venv}"
python="${PYTHON:-python3}"

# Pins. pyroomacoustics 0.10.1 publishes a manylinux wheel for CPython 3.11
# x86-64 (cp311-manylinux_2_27/2_28), so nothing is compiled and no system
# library is needed. Its declared runtime requirements are numpy, scipy and
# Cython (numpy 2.4 and scipy 1.17 need Python >= 3.11).
PRA_VERSION=0.10.1
PINS=(
  "pyroomacoustics==$PRA_VERSION"
  "numpy==2.4.6"
  "scipy==1.17.1"
  "Cython==3.3.1"
)

log() { echo "setup.sh: $*" >&2; }

check() {
  "$venv/bin/python" - "$PRA_VERSION" <<'PY' 2>/dev/null
import sys
import pyroomacoustics as pra
sys.exit(0 if pra.__version__ == sys.argv[1] else 1)
PY
}

if [ ! -x "$venv/bin/python" ]; then
  mkdir -p "$venv"
  venv="$(cd "$venv" && pwd)"
  log "creating virtual environment $venv"
  "$python" -m venv "$venv"
fi
venv="$(cd "$venv" && pwd)"

if check; then
  log "pyroomacoustics $PRA_VERSION already installed"
else
  log "installing ${PINS[*]}"
  # Wheels only. The pyroomacoustics 0.10.1 sdist cannot be built here: its
  # CMake build fetches Eigen 5.0.1, nanoflann 1.9.0 and pybind11 3.0.1 with
  # FetchContent from GitLab/GitHub (external/CMakeLists.txt), and only PyPI
  # is reachable. So fail fast with a clear message instead of a long,
  # doomed compile.
  if ! "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
      --only-binary=:all: "${PINS[@]}" >&2; then
    log "pip could not install wheels for ${PINS[*]} on this Python" \
      "($("$venv/bin/python" -V 2>&1), $(uname -m)). pyroomacoustics $PRA_VERSION" \
      "publishes wheels for CPython 3.9-3.14 on manylinux x86-64; its sdist" \
      "needs network access to GitHub/GitLab to build."
    exit 1
  fi
  if ! check; then
    log "pyroomacoustics $PRA_VERSION did not import after install"
    exit 1
  fi
  log "installed"
fi

echo "$venv/bin/python"
