#!/usr/bin/env bash
# fricfem on the PyPI binary wheel of dolfinx (`dolfinx-solver-real`, 0.11):
# a venv of its own, .venv-wheel, with no Debian FE stack in it.
#
#   bash scripts/setup-wheel.sh          # makes/updates .venv-wheel (Python >= 3.12)
#   .venv-wheel/bin/mpiexec -n 2 .venv-wheel/bin/python -m fricfem run case1
#   .venv-wheel/bin/mpiexec -n 2 .venv-wheel/bin/python -m pytest tests -k "golden or demo"
#
# The wheel brings its own MPI (MPICH, the `mpich` wheel): run it with the
# venv's `mpiexec`, not the system's OpenMPI `mpirun` (which refuses it:
# "unsupported PMI version").  It needs Python >= 3.12, so not Debian 12's
# 3.11.  A C compiler and the Python headers are needed at run time: FFCx
# compiles the forms (Debian: gcc, python3-dev; scripts/setup.sh installs them).
#
# PYTHON=/path/to/python3.12+ chooses the interpreter (default python3).
# Idempotent: skipped when this script is unchanged since the last success
# (stamp: .venv-wheel/.fricfem-setup.stamp).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
PY=${PYTHON:-python3}
VENV="$ROOT/.venv-wheel"
STAMP="$VENV/.fricfem-setup.stamp"

# What the wheel path installs: dolfinx 0.11 and what fricfem and its tests
# import, pinned (the wheel path has no distribution to take pins from).
PACKAGES=(
  dolfinx-solver-real==0.11.0.post0
  numba==0.62.1 h5py==3.15.1 matplotlib==3.10.7 scipy==1.16.3 pytest==8.4.2
  pyvista==0.46.5 vtk==9.5.2 meshio==5.3.5
  numpy==2.3.5 mpi4py==4.1.2 mpich==5.0.2 setuptools==84.2.1 wheel==0.48.0
)

say() { printf 'setup-wheel: %s\n' "$*"; }
die() { printf 'setup-wheel: ERROR: %s\n' "$*" >&2; exit 1; }

command -v "$PY" >/dev/null || die "$PY not found (PYTHON=... names a Python >= 3.12)"
"$PY" -c 'import sys; sys.exit(sys.version_info < (3, 12))' ||
  die "$("$PY" -V 2>&1): the dolfinx-solver-real wheel needs Python >= 3.12 (Debian 12 has 3.11: use scripts/setup.sh there)"

want="$( { cat scripts/setup-wheel.sh pyproject.toml; "$PY" -V; } | sha256sum | cut -d' ' -f1)"
if [[ -f $STAMP && "$(cat "$STAMP")" == "$want" ]]; then
  say "up to date ($VENV)"
  exit 0
fi
rm -f "$STAMP"
[[ -x $VENV/bin/python ]] || { say "creating $VENV"; "$PY" -m venv "$VENV"; }

LOG="$VENV/.fricfem-setup-pip.log"
: >"$LOG"
run_logged() {
  if ! "$@" >>"$LOG" 2>&1; then
    tail -n 40 "$LOG" >&2
    die "failed: $* (full log: $LOG)"
  fi
}
PIP=("$VENV/bin/python" -m pip --disable-pip-version-check)
say "installing ${PACKAGES[*]} into $VENV"
run_logged "${PIP[@]}" install --progress-bar off "${PACKAGES[@]}"
say "installing fricfem (editable) into $VENV"
run_logged "${PIP[@]}" install --progress-bar off --no-build-isolation --no-deps -e .

say "checking imports and the wheel's mpiexec"
[[ -x $VENV/bin/mpiexec ]] || die "$VENV/bin/mpiexec not found (the mpich wheel provides it)"
run_logged "$VENV/bin/python" -I -c '
from mpi4py import MPI  # before dolfinx: the wheel loads libmpi through mpi4py
import dolfinx, h5py, numba, pyvista
print(f"dolfinx {dolfinx.__version__}, MPI {MPI.Get_library_version().splitlines()[0]}")'
tail -n 1 "$LOG" | sed 's/^/setup-wheel: /'
echo "$want" >"$STAMP"
say "done ($VENV)"
