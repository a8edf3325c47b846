"""The leading sliding tip and the speed of a front (the paper's 5-point
progressive least-squares fit)."""

from __future__ import annotations

import math

import numpy as np

from .regions import check_history


def leading_tip(x1, slip_rate_row, threshold: float = 0.0) -> float:
    """x1 [m] of the point furthest from the impact edge (x1 = 0) with
    Δu̇_slip > ``threshold`` [m/s]; ``nan`` if no point slides.

    This is the paper's leading sliding tip: no filtering, a single sliding
    point counts.
    """
    x1 = np.asarray(x1, dtype=np.float64)
    on = np.flatnonzero(np.asarray(slip_rate_row) > threshold)
    return float(x1[on[-1]]) if on.size else math.nan


def tip_history(time, x1, slip_rate, threshold: float = 0.0):
    """(t float64[m], x_tip float64[m]) of the leading sliding tip [s, m], over
    the m sample times at which some point slides."""
    time, x1, slip_rate = check_history(time, x1, slip_rate)
    on = slip_rate > threshold
    has = on.any(axis=1)
    # index of the last sliding point of every row
    last = x1.size - 1 - np.argmax(on[:, ::-1], axis=1)
    return time[has], x1[last[has]]


def tip_speed(t, x, npts: int = 5):
    """Speed of a front from its positions by the paper's progressive least-squares fit.

    A window of ``npts`` consecutive samples slides along the series; in each
    window the slope of the least-squares line x ≈ a + V t is

        V = Σ (t_i − t̄)(x_i − x̄) / Σ (t_i − t̄)²

    and is assigned to the window's centre time t̄ (the middle sample for odd
    ``npts`` and equally spaced samples).  The fit smooths the staircase of a
    tip that jumps from Gauss point to Gauss point; the paper notes that
    oscillations of V_tip may partly come from this differentiation.

    t float64[m] [s], x float64[m] [m] → (t_centre float64[m−npts+1] [s],
    V float64[m−npts+1] [m/s]); empty arrays if m < npts.
    """
    if int(npts) < 2:
        raise ValueError(f"npts = {npts!r}: the fit needs at least 2 points")
    npts = int(npts)
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.shape != x.shape or t.ndim != 1:
        raise ValueError(f"t and x must be 1-D of equal length; got {t.shape} and {x.shape}")
    if t.size < npts:
        return np.zeros(0), np.zeros(0)
    tw = np.lib.stride_tricks.sliding_window_view(t, npts)
    xw = np.lib.stride_tricks.sliding_window_view(x, npts)
    tc = tw.mean(axis=1)
    dt = tw - tc[:, None]
    v = (dt * (xw - xw.mean(axis=1)[:, None])).sum(axis=1) / (dt * dt).sum(axis=1)
    return tc, v


def lsq_slope(t, x) -> float:
    """Least-squares slope of x against t (nan for fewer than 2 samples).

    The tracking of fronts calls it thousands of times a run on windows of a
    few samples, where numpy's set-up costs ~20 times the arithmetic: up to
    :data:`_SHORT` samples it is done in Python with numpy's own order of
    operations (numpy's pairwise sum adds fewer than 8 values one after
    another, ((v0 + v1) + v2) + …), so the result is the same to the bit
    (``tests/test_diagnostics.py``).
    """
    n = len(t)
    if 2 <= n <= _SHORT and n == len(x):
        t = [float(v) for v in t]
        x = [float(v) for v in x]
        tm = _sum(t) / n
        xm = _sum(x) / n
        dt = [v - tm for v in t]
        return _sum([a * (b - xm) for a, b in zip(dt, x)]) / _sum([a * a for a in dt])
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.size < 2:
        return math.nan
    dt = t - t.mean()
    return float((dt * (x - x.mean())).sum() / (dt * dt).sum())


#: the longest window :func:`lsq_slope` sums in Python (numpy adds fewer than
#: 8 values one after another; from 8 on, in eight interleaved partial sums)
_SHORT = 7


def _sum(v: list) -> float:
    """Σ v in numpy's order for 2 to :data:`_SHORT` values: ((v0 + v1) + v2) + …"""
    r = v[0]
    for a in v[1:]:
        r += a
    return r


def tip_record(time, x1, slip_rate, every: int = 1, npts: int = 5) -> dict:
    """The leading tip of a slip-rate history as ``summary.json`` records it:
    ``time_s``, ``x1_m`` (every sample with sliding) and the speed
    ``v_tip_m_s`` of the ``npts``-point fit at its window centres
    ``v_tip_time_s``, fitted on every ``every``-th sample (so that a window
    spans a few point spacings rather than one staircase step)."""
    t, x = tip_history(time, x1, slip_rate)
    tv, v = tip_speed(t[::every], x[::every], npts)
    return {"time_s": t, "x1_m": x, "v_tip_time_s": tv, "v_tip_m_s": v}
