"""The monitor's per-step look at the interface points, in one pass (numba).

After every step a run needs, from this rank's interface points: the largest
and smallest x1 that slides (the leading tip, the first sliding), the largest
slip rate (spikes), whether every traction and slip rate is finite (the
watchdog), and the stations' values (a row every step).  Done as separate
NumPy expressions these were ~15 array operations and a dozen Python calls a
step, each slowed by the step having just swept the caches (~70 µs a step on
the reference mesh, a quarter of a MatMult); here they are one call.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, _nrt=False)
def look(x1, slip_rate, Ts, Tn, out):
    """``out[0]`` the largest x1 with a slip rate > 0 (−1: none), ``out[1]`` minus
    the smallest (−inf: none), ``out[2]`` the largest slip rate (0 for no points;
    NaN if one is NaN), ``out[3]`` 1.0 if a traction or slip rate is not finite,
    ``out[4]`` x1 of the first point with the largest slip rate (as ``np.argmax``;
    −inf for no points)."""
    xmax, mxmin, vmax, bad = -1.0, -np.inf, 0.0, 0.0
    xv = x1[0] if x1.shape[0] > 0 else -np.inf
    for i in range(x1.shape[0]):
        v = slip_rate[i]
        if not (np.isfinite(v) and np.isfinite(Ts[i]) and np.isfinite(Tn[i])):
            bad = 1.0
        if v > 0.0:
            if x1[i] > xmax:
                xmax = x1[i]
            if -x1[i] > mxmin:
                mxmin = -x1[i]
        if v != v:  # a NaN stays the largest (as in NumPy's max)
            vmax = v
        elif v > vmax:
            vmax = v
            xv = x1[i]
    if vmax != vmax:  # a NaN slip rate: no tip this step (the watchdog stops the run)
        xmax, mxmin = -1.0, -np.inf
    out[0], out[1], out[2], out[3], out[4] = xmax, mxmin, vmax, bad, xv


@numba.njit(cache=True, _nrt=False)
def take_rows(columns, index, rows, k, j0):
    """``rows[k, j0 + j, s] = columns[j][index[s]]``: the stations' values now (one row a step)."""
    for j in range(len(columns)):
        col = columns[j]
        for s in range(index.shape[0]):
            rows[k, j0 + j, s] = col[index[s]]
