"""Results that hold under any BLAS on any processor: the golden check of one
whole run (coarse Case III: interface and field datasets, the summary with
λmax's ``dt_crit_s``, the energies) in separate 2-rank jobs under reference
BLAS/LAPACK and under OpenBLAS with two processor kernels, each job saying
which libraries it loaded and which OpenBLAS kernel ran.

Debian picks the BLAS by its alternatives; ``LD_LIBRARY_PATH`` overrides them
per process:

    netlib      LD_LIBRARY_PATH=/usr/lib/x86_64-linux-gnu/blas:/usr/lib/x86_64-linux-gnu/lapack
    OpenBLAS    LD_LIBRARY_PATH=/usr/lib/x86_64-linux-gnu/openblas-pthread OPENBLAS_CORETYPE=Haswell (or Nehalem)

Before fricfem summed λmax's dot products itself (fricfem.kernels.reduce) and
inverted the field stress's 2×2 Jacobians itself (gauges.inverse_2x2), the
coarse Case III gave dt_crit_s = 5.69799918667237e-08 under netlib and
OpenBLAS/Nehalem but 5.6979991866723716e-08 under OpenBLAS/Haswell, energies
differing in their last digits, and the σ1 − σ2 snapshots differing under
OpenBLAS.  A configuration whose libraries are not installed is skipped,
naming them (``apt-get install libopenblas0-pthread libblas3 liblapack3``).

Under ``mpirun -n 2`` (1 rank works too): rank 0 starts the jobs.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import faults
from rankcheck import on_rank0

ROOT = Path(__file__).resolve().parents[1]
LIB = Path("/usr/lib/x86_64-linux-gnu")
#: label -> (environment, the libraries it needs, the directory every loaded BLAS/LAPACK must be in, OpenBLAS kernel)
CONFIGS = {
    "netlib": ({"LD_LIBRARY_PATH": f"{LIB / 'blas'}:{LIB / 'lapack'}"},
               [LIB / "blas" / "libblas.so.3", LIB / "lapack" / "liblapack.so.3"], (LIB / "blas", LIB / "lapack"),
               None),
    "openblas-Haswell": ({"LD_LIBRARY_PATH": str(LIB / "openblas-pthread"), "OPENBLAS_CORETYPE": "Haswell"},
                         [LIB / "openblas-pthread" / "libblas.so.3", LIB / "openblas-pthread" / "liblapack.so.3"],
                         (LIB / "openblas-pthread",), "Haswell"),
    "openblas-Nehalem": ({"LD_LIBRARY_PATH": str(LIB / "openblas-pthread"), "OPENBLAS_CORETYPE": "Nehalem"},
                         [LIB / "openblas-pthread" / "libblas.so.3", LIB / "openblas-pthread" / "liblapack.so.3"],
                         (LIB / "openblas-pthread",), "Nehalem"),
}
#: what a BLAS's own dot product gives (a witness that the configurations really round differently)
WITNESS = ("import numpy as np; r = np.random.default_rng(0); a, b = r.standard_normal((2, 100001)); "
           "print(repr(float(np.dot(a, b))))")


def _env(label: str) -> dict:
    env = faults.clean_env()
    for k in ("LD_LIBRARY_PATH", "OPENBLAS_CORETYPE", "LD_PRELOAD"):
        env.pop(k, None)
    env.update(CONFIGS[label][0], FRICFEM_CACHE="off")  # no λmax from a cache filled under another BLAS
    return env


def _missing(label: str) -> list:
    return [str(p) for p in CONFIGS[label][1] if not p.exists()]


@pytest.mark.slow
@pytest.mark.parametrize("label", list(CONFIGS))
def test_golden_case_is_identical_under_this_blas(label, comm):
    """``tests/golden.py check case3 --exact`` under ``label``'s BLAS: the job loaded
    that BLAS (and that OpenBLAS kernel) and every digest, the summary (dt_crit_s)
    and the energies match the golden exactly."""
    missing = _missing(label)
    if missing:
        pytest.skip(f"{label}: not installed here: {', '.join(missing)}")

    def work():
        res = subprocess.run(["mpirun", "-n", "2", sys.executable, str(ROOT / "tests" / "golden.py"), "check",
                              "case3", "--exact"], cwd=ROOT, capture_output=True, text=True, env=_env(label),
                             timeout=3600)
        return res.returncode, res.stdout, res.stderr[-3000:]

    status, out, err = on_rank0(comm, work)
    line = next((ln for ln in out.splitlines() if ln.startswith("blas: ")), None)
    assert line is not None, out + err
    blas = json.loads(line[len("blas: "):].split("; compare:")[0])
    dirs, core = CONFIGS[label][2], CONFIGS[label][3]
    assert blas["libraries"] and all(any(str(lib).startswith(f"{d}{os.sep}") for d in dirs)
                                     for lib in blas["libraries"]), blas
    assert blas["openblas_core"] == core, blas
    assert status == 0 and "case3: identical" in out, out + err


def test_the_blas_configurations_round_differently(comm):
    """The witness: the BLAS's own dot product of one pair of random vectors is not
    the same bits in every configuration (else the golden runs above would
    prove nothing), while fricfem's (fricfem.kernels.reduce.dot) is."""
    labels = [label for label in CONFIGS if not _missing(label)]
    if len(labels) < 2:
        pytest.skip(f"fewer than two BLAS configurations installed: {labels}")
    code = WITNESS + ("; from fricfem.kernels.reduce import dot; print(repr(dot(a, b)))")

    def work():
        out = {}
        for label in labels:
            res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                                 env=_env(label), timeout=600)
            assert res.returncode == 0, res.stderr
            out[label] = res.stdout.split()
        return out

    got = on_rank0(comm, work)
    assert len({v[0] for v in got.values()}) > 1, got  # the BLASes differ
    assert len({v[1] for v in got.values()}) == 1, got  # fricfem's sum does not
