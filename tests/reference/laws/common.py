"""What the scipy references share: the result record, piecewise-smooth
integration across stick/slip switches, peaks of the dense solution."""

from __future__ import annotations

import inspect
from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from fricfem.friction.base import Law


class Reference(NamedTuple):
    """A reference solution at the requested times (state: (n, n_state))."""

    t: np.ndarray
    Ts: np.ndarray  # shear traction [Pa] (block: the friction traction sgn(V) τ)
    Tn: np.ndarray
    slip_rate: np.ndarray  # [m/s]; block: the signed block velocity V
    slip: np.ndarray  # accumulated frictional slip [m]
    work: np.ndarray  # frictional work [J/m²]
    state: np.ndarray
    peak_rate: float  # largest |slip rate| of the continuous solution [m/s]
    t_peak: float  # its time [s]
    nfev: int  # right-hand-side evaluations
    segments: int  # smooth segments (switches + breaks + 1)
    segment_peaks: tuple = ()  # (t, largest |slip rate|) of each smooth segment

    @property
    def mu(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.abs(self.Ts) / self.Tn


def const(x) -> Callable:
    if callable(x):
        return x
    c = float(x)
    return lambda t: c


def has_branch(law: Law) -> bool:
    return law.rates is not None and "branch" in inspect.signature(law.rates).parameters


def sgn(x: float) -> float:
    return -1.0 if x < 0.0 else 1.0


def segments(rhs, event, switch, y0, mode, t_out, rtol, atol, breaks, method="Radau",
              max_segments=100000, max_step=np.inf):
    """Integrate piecewise: each segment with the mode's smooth right-hand side
    ``rhs(mode)`` until a terminal event of ``event(mode, t, y)`` (or a break
    time), then ``switch(mode, t, y, which) -> (mode, y)`` (``which``: the index
    of the event that fired).  Returns the solution at ``t_out``,
    the dense solutions [(t0, t1, sol, mode)] and the number of evaluations."""
    t_out = np.asarray(t_out, dtype=np.float64)
    t0, t_end = float(t_out[0]), float(t_out[-1])
    stops = sorted({float(b) for b in breaks if t0 < b < t_end} | {t_end})
    Y = np.full((len(t_out), len(y0)), np.nan)
    Y[0] = y0
    pieces = []
    nfev = 0
    t, y = t0, np.array(y0, dtype=np.float64)
    k = 0
    nzero = 0
    while t < t_end:
        k += 1
        if k > max_segments:
            raise RuntimeError(f"reference: more than {max_segments} segments by t = {t:.6g} s")
        stop = next(s for s in stops if s > t)
        ev = event(mode, t, y)
        sol = solve_ivp(rhs(mode), (t, stop), y, method=method, rtol=rtol, atol=atol,
                        events=ev, dense_output=True, max_step=max_step)
        if sol.status < 0:
            raise RuntimeError(f"reference: solve_ivp failed at t = {t:.6g} s: {sol.message}")
        nfev += sol.nfev
        t1 = float(sol.t[-1])
        sel = (t_out > t) & (t_out <= t1)
        if sel.any():
            Y[sel] = sol.sol(t_out[sel]).T
        pieces.append((t, t1, sol, mode))
        y = sol.y[:, -1].copy()
        if sol.status == 1:  # an event: switch regime
            # Safeguard: an event that makes no progress again and again
            # (tangency) would loop forever.
            nzero = nzero + 1 if t1 - t <= 1e-15 * max(abs(t1), 1e-9) else 0
            if nzero > 10:
                raise RuntimeError(f"reference: switch without progress at t = {t1:.6g} s")
            which = next(i for i, te in enumerate(sol.t_events) if len(te))
            mode, y = switch(mode, t1, y, which)
        t = t1
    return Y, pieces, nfev


def dense_peak(pieces, rate_of, per_step):
    """Largest |rate| over the dense solutions (solver nodes and ``per_step``
    points inside each step), its time, and (t, largest) of each piece."""
    best, tbest = 0.0, float("nan")
    each = []
    for t0, t1, sol, mode in pieces:
        ts = sol.t
        if len(ts) < 2:
            continue
        fr = np.linspace(0.0, 1.0, per_step + 1)
        tt = (ts[:-1, None] + np.diff(ts)[:, None] * fr[None, :]).ravel()
        yy = sol.sol(tt)
        r = np.array([abs(rate_of(mode, tt[i], yy[:, i])) for i in range(len(tt))])
        i = int(np.argmax(r))
        each.append((float(tt[i]), float(r[i])))
        if r[i] > best:
            best, tbest = float(r[i]), float(tt[i])
    return best, tbest, tuple(each)


def mode_at(pieces, tt):
    """The regime of the segment holding time tt (the first one at a switch)."""
    for t0, t1, sol, mode in pieces:
        if t0 <= tt <= t1:
            return mode
    return pieces[-1][3]


def traction_at_rate(law, p, state, V, Tn, branch):
    """|T_s| at which ``law.rates`` gives the slip rate V >= 0 (brentq);
    for a switching law at V = 0, the strength (where the sliding branch's rate is 0)."""
    def f(T):
        if branch:
            return law.rates(p, state, T, Tn, branch="slide")[0] - V
        return law.rates(p, state, T, Tn)[0] - V
    lo, hi = 0.0, max(Tn, 1.0)
    if f(lo) >= 0.0:
        return 0.0
    while f(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
        if hi > 1e30:
            raise RuntimeError("reference: no traction gives this slip rate")
    return brentq(f, lo, hi, xtol=1e-12, rtol=4.0 * np.finfo(float).eps, maxiter=200)
