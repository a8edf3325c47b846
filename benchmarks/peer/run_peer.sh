#!/usr/bin/env bash
# Run one SEM2DPACK case serially and time it.
#   usage: run_peer.sh <Par file> <run directory>
# Environment: SEM2DSOLVE = path of the sem2dsolve executable (built outside
#              this repository from the upstream source).
# The solver reads Par.inp from its working directory and writes its
# output there (Flt05_sem2d.hdr/.dat, Flt05_init_sem2d.tab, info).
set -euo pipefail
par=$(realpath "$1")
run=$2
exe=${SEM2DSOLVE:?set SEM2DSOLVE to the sem2dsolve executable}
# Keep glibc from serving the solver's large (> 32 MB) per-step Fortran
# temporaries with mmap/munmap: without this the 0.05 mm runs spend ~30 %
# of their CPU time in minor page faults (system time).  Results are
# bit-for-bit unaffected; only the CPU time changes.
export MALLOC_MMAP_MAX_=${MALLOC_MMAP_MAX_:-0}
export MALLOC_TRIM_THRESHOLD_=${MALLOC_TRIM_THRESHOLD_:-4294967296}
mkdir -p "$run"
cd "$run"
cp "$par" Par.inp
/usr/bin/time -v "$exe" > info.txt 2> time.txt
grep -E "User time|System time|Elapsed" time.txt
