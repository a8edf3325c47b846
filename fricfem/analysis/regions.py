"""Slipping regions of a slip-rate profile, and the checks every history passes."""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from ..output.rundir import jsonable


def check_history(time, x1, slip_rate):
    time = np.asarray(time, dtype=np.float64)
    x1 = np.asarray(x1, dtype=np.float64)
    slip_rate = np.asarray(slip_rate, dtype=np.float64)
    if slip_rate.shape != (time.size, x1.size):
        raise ValueError(f"slip_rate has shape {slip_rate.shape}; expected (len(time), len(x1)) = "
                         f"({time.size}, {x1.size})")
    if x1.size > 1 and np.any(np.diff(x1) < 0):
        raise ValueError("x1 must be sorted in increasing order [m]")
    if time.size > 1 and np.any(np.diff(time) <= 0):
        raise ValueError("time must be strictly increasing [s]")
    return time, x1, slip_rate


def cell_lengths(x1) -> np.ndarray:
    """Length [m] of the interval each point owns: between the midpoints to its
    neighbours (half a spacing beyond the first and last point)."""
    x1 = np.asarray(x1, dtype=np.float64)
    if x1.size < 2:
        return np.zeros(x1.size)
    mid = 0.5 * (x1[1:] + x1[:-1])
    lo = np.concatenate(([x1[0] - (mid[0] - x1[0])], mid))
    hi = np.concatenate((mid, [x1[-1] + (x1[-1] - mid[-1])]))
    return hi - lo


class Region(NamedTuple):
    """One slipping region of a slip-rate profile.

    i0, i1     first and last point index (inclusive)
    x_start    x1 of the first point, nearest the impact edge [m]
    x_end      x1 of the last point, furthest from the impact edge [m]
    width      sum of the points' cell lengths [m]
    peak       largest Δu̇_slip in the region [m/s]
    x_peak     where it occurs [m]
    """

    i0: int
    i1: int
    x_start: float
    x_end: float
    width: float
    peak: float
    x_peak: float

    def to_dict(self) -> dict:
        return jsonable(self._asdict())


def slip_regions(x1, slip_rate_row, threshold: float = 0.0, *, min_points: int = 1,
                 floor: float = 0.0, min_gap_points: int = 1, weights=None) -> list:
    """Slipping regions of one profile, sorted along x1 (list of :class:`Region`).

    Runs of points with Δu̇_slip > ``threshold`` [m/s]; runs of fewer than
    ``min_points`` points or with a peak below ``floor`` [m/s] are dropped
    (numerical blips), then regions separated by fewer than ``min_gap_points``
    stuck points are joined.  ``weights`` are the points' cell lengths
    (:func:`cell_lengths`, computed if not given).  The defaults keep every run.
    """
    x1 = np.asarray(x1, dtype=np.float64)
    s = np.asarray(slip_rate_row, dtype=np.float64)
    return region_history(None, x1, s[None, :], threshold, min_points, floor, min_gap_points, weights)[0]


def region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w):
    """:func:`slip_regions` of every row of ``slip_rate`` [n_t, n_p] (``time`` unused):
    one compiled pass over the history (:func:`_runs`), then the regions."""
    x1 = np.asarray(x1, dtype=np.float64)
    rate = np.ascontiguousarray(slip_rate, dtype=np.float64)
    w = cell_lengths(x1) if w is None else np.asarray(w, dtype=np.float64)
    found, peaks = _runs(rate, float(threshold), int(min_points), float(floor), int(min_gap_points))
    x = x1.tolist()
    cw = np.concatenate(([0.0], np.cumsum(w))).tolist()
    out: list = [[] for _ in range(rate.shape[0])]
    for (r, a, b, j), peak in zip(found.tolist(), peaks.tolist()):
        out[r].append(Region(a, b, x[a], x[b], cw[b + 1] - cw[a], peak, x[j]))
    return out


@numba.njit(cache=True)
def _runs(rate, threshold, min_points, floor, min_gap_points):
    """The regions of every row: (row, first, last, index of the peak) [n, 4] and
    the peaks [n].  Runs of rate > threshold; with ``min_points > 1`` or
    ``floor > 0`` those shorter than ``min_points`` or peaking below ``floor``
    dropped; then runs fewer than ``min_gap_points`` points apart joined; the
    peak at the first largest value of the joined region (a NaN in a bridged
    gap counts as the largest, as in ``np.argmax``)."""
    n_t, n_p = rate.shape
    found = np.empty((n_t * ((n_p + 1) // 2), 4), dtype=np.int64)
    peaks = np.empty(found.shape[0])
    filt = min_points > 1 or floor > 0.0
    n = 0
    for r in range(n_t):
        row = rate[r]
        first = n  # this row's regions are found[first:n]
        i = 0
        while i < n_p:
            if not row[i] > threshold:
                i += 1
                continue
            a = i
            top = row[i]
            while i + 1 < n_p and row[i + 1] > threshold:
                i += 1
                if row[i] > top:
                    top = row[i]
            b = i
            i += 1
            if filt and (b - a + 1 < min_points or not top >= floor):
                continue
            if min_gap_points > 1 and n > first and a - found[n - 1, 2] - 1 < min_gap_points:
                found[n - 1, 2] = b  # joined to the region before
                continue
            found[n, 0] = r
            found[n, 1] = a
            found[n, 2] = b
            n += 1
        for k in range(first, n):
            a, b = found[k, 1], found[k, 2]
            j = a
            for q in range(a + 1, b + 1):
                if row[j] != row[j]:
                    break
                if row[q] > row[j] or row[q] != row[q]:
                    j = q
            found[k, 3] = j
            peaks[k] = row[j]
    return found[:n], peaks[:n]


def spacings(x1) -> list:
    """:func:`local_spacing` of every point (a list: looked up one at a time)."""
    x1 = np.asarray(x1, dtype=np.float64)
    if x1.size < 2:
        return [0.0] * x1.size
    d = np.diff(x1)
    return np.maximum(np.concatenate(([0.0], d)), np.concatenate((d, [0.0]))).tolist()


def local_spacing(x1, i) -> float:
    """Largest spacing next to point ``i`` [m]."""
    lo = x1[i] - x1[i - 1] if i > 0 else 0.0
    hi = x1[i + 1] - x1[i] if i + 1 < x1.size else 0.0
    return max(lo, hi)
