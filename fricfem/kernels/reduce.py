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


@numba.njit(cache=True, _nrt=False)
def rayleigh_sums(x, y, mass, out):
    """One pass of the power iteration: ``out[0] = Σ x_i y_i`` (x·Kx),
    ``out[1] = Σ (x_i m_i) x_i`` (x·Mx), then ``y_i /= m_i`` in place and
    ``out[2] = Σ y_i²`` (|M⁻¹Kx|²), each summed i = 0, 1, 2, ... in turn."""
    xy = 0.0
    xmx = 0.0
    yy = 0.0
    for i in range(x.shape[0]):
        xi = x[i]
        xy += xi * y[i]
        xmx += (xi * mass[i]) * xi
        yi = y[i] / mass[i]
        y[i] = yi
        yy += yi * yi
    out[0] = xy
    out[1] = xmx
    out[2] = yy
