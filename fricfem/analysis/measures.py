"""Measurements on a run's interface history that the paper reports
(:class:`fricfem.output.rundir.Run`, from ``fricfem.open_run``): the first
sliding, the loading front along the interface, values at the sliding tip and
behind it, the geometry of a train of pulses."""

from __future__ import annotations

import math

import numpy as np

from .regions import slip_regions


def regions(r, k: int, floor: float = 0.05) -> list:
    """Slipping regions of row ``k`` of a run (at least 3 points, peak >= ``floor``
    [m/s]; :func:`~.regions.slip_regions`)."""
    return slip_regions(r.x1, r.slip_rate[k], min_points=3, floor=floor)


def first_slip(r) -> tuple:
    """(time [µs], x1 [mm]) of the first sliding (summary ``initiation``), or (None, None)."""
    ini = r.summary.get("initiation")
    return (None, None) if not ini else (ini["time_s"] * 1e6, ini["x1_m"] * 1e3)


def mode(r) -> str:
    """The classifier's label, as the run's summary gives it (``unknown`` for a run
    interrupted before its end); ``unknown`` too when the summary has none (a run
    stopped by the watchdog, still running, or without diagnostics): no label is
    not ``none``, which is the classifier's verdict of no sliding."""
    return (r.summary.get("mode") or {}).get("label") or "unknown"


def loading_front(r, t: float, sigma0: float) -> float:
    """Furthest x1 [mm] where T_n differs from Σ0 by > 0.01 % at ``t`` [s] (the
    longitudinal front along the interface); nan if nowhere."""
    k = r.at(t)
    tn = r.normal_traction[k]
    moved = np.abs(tn - sigma0) > 1e-4 * sigma0
    return float(r.x1[moved].max()) * 1e3 if moved.any() else math.nan


def tip_and_behind(r, t: float, quantity: np.ndarray) -> tuple:
    """Value of ``quantity`` [n_t, n_p] at the sliding tip (max over the last 2 mm
    of sliding) and its mean over the sliding region from 5 mm behind the tip
    back to 5 mm from the edge, at the row nearest ``t`` [s]."""
    k = r.at(t)
    s = r.slip_rate[k] > 0
    if not s.any():
        return math.nan, math.nan
    xt = r.x1[s].max()
    q = quantity[k]
    near = s & (r.x1 > xt - 2e-3)
    behind = s & (r.x1 < xt - 5e-3) & (r.x1 > 5e-3)
    return float(q[near].max()), (float(q[behind].mean()) if behind.any() else math.nan)


def pulse_train(r, t: float, x_max: float = 60e-3) -> dict:
    """Width, stick length and spacing [mm] of the pulses behind the leading one at
    ``t``: regions within x_end < ``x_max`` (the uniform fine mesh); width the
    median over them but the last (the leading pulse), spacing the median
    distance between successive region starts."""
    regs = regions(r, r.at(t))
    behind = [g for g in regs if g.x_end < x_max]
    widths = [g.width * 1e3 for g in behind[:-1]] if len(behind) > 2 else []
    starts = [g.x_start * 1e3 for g in behind]
    spacing = float(np.median(np.diff(starts))) if len(starts) > 2 else math.nan
    width = float(np.median(widths)) if widths else math.nan
    return {"n_regions": len(regs), "width_mm": width, "spacing_mm": spacing, "stick_mm": spacing - width}
