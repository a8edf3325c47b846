"""Slipping regions of a slip-rate profile, and the checks every history passes."""

from __future__ import annotations

from typing import NamedTuple

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
    w = cell_lengths(x1) if weights is None else weights
    on = s > threshold
    if not on.any():
        return []
    d = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    if min_points > 1 or floor > 0.0:
        peaks = np.maximum.reduceat(s, starts)
        keep = (ends - starts + 1 >= min_points) & (peaks >= floor)
        starts, ends = starts[keep], ends[keep]
        if starts.size == 0:
            return []
    if min_gap_points > 1 and starts.size > 1:
        wide = (starts[1:] - ends[:-1] - 1) >= min_gap_points
        starts = np.concatenate((starts[:1], starts[1:][wide]))
        ends = np.concatenate((ends[:-1][wide], ends[-1:]))
    cw = np.concatenate(([0.0], np.cumsum(w)))
    out = []
    for a, b in zip(starts.tolist(), ends.tolist()):
        j = a + int(np.argmax(s[a : b + 1]))
        out.append(Region(a, b, float(x1[a]), float(x1[b]), float(cw[b + 1] - cw[a]), float(s[j]), float(x1[j])))
    return out


def region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w):
    return [slip_regions(x1, row, threshold, min_points=min_points, floor=floor,
                         min_gap_points=min_gap_points, weights=w) for row in slip_rate]


def local_spacing(x1, i) -> float:
    """Largest spacing next to point ``i`` [m]."""
    lo = x1[i] - x1[i - 1] if i > 0 else 0.0
    hi = x1[i + 1] - x1[i] if i + 1 < x1.size else 0.0
    return max(lo, hi)
