"""Sums in an order of fricfem's own (numba): one sequential loop, no fastmath.

A BLAS's ``ddot``/``dnrm2`` (NumPy's ``np.dot``, PETSc's ``VecDot``/``VecNorm``)
sums in an order of its processor kernel: reference BLAS one after the other,
OpenBLAS in 4 or 8 interleaved partial sums whose number depends on the
processor (Haswell, Nehalem, ...), ``dnrm2`` with scaling.  Their last digits
therefore depend on which BLAS a machine has and on its processor.  These
loops add element 0, 1, 2, ... one at a time (numba compiles them without
fastmath, so LLVM may neither reassociate nor vectorise the sum nor fuse a
product into an FMA), so the result is the same bits on every x86-64
processor and with every BLAS.  Across MPI ranks the partial sums are
combined in rank order (:func:`fricfem.model.assembly.ordered_sum`).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, _nrt=False)
def dot(a, b):
    """Σ a_i b_i, i = 0, 1, 2, ... in turn."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@numba.njit(cache=True, _nrt=False)
def dot3(a, b, c):
    """Σ (a_i b_i) c_i, i = 0, 1, 2, ... in turn (a mass-weighted dot product)."""
    s = 0.0
    for i in range(a.shape[0]):
        s += (a[i] * b[i]) * c[i]
    return s


@numba.njit(cache=True)
def tridiagonal_max(alpha, beta):
    """The largest eigenvalue of the symmetric tridiagonal matrix with diagonal
    ``alpha`` (float64[n]) and off-diagonal ``beta`` (float64[n − 1]), by
    bisection on Sturm counts inside the Gershgorin bound, to the last bits of
    the interval (plain float arithmetic in a fixed order: the same bits everywhere)."""
    n = alpha.shape[0]
    lo = np.inf
    hi = -np.inf
    for i in range(n):
        r = 0.0
        if i > 0:
            r += abs(beta[i - 1])
        if i < n - 1:
            r += abs(beta[i])
        lo = min(lo, alpha[i] - r)
        hi = max(hi, alpha[i] + r)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        count = 0  # eigenvalues below mid: the negative pivots of LDLᵀ of T − mid
        d = 1.0
        for i in range(n):
            d = alpha[i] - mid - (beta[i - 1] * beta[i - 1] / d if i > 0 else 0.0)
            if d == 0.0:
                d = -1e-300 * (abs(mid) + 1.0)
            if d < 0.0:
                count += 1
        if count == n:
            hi = mid
        else:
            lo = mid
    return hi
