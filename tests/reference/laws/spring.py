"""The elastic-interface point that ``law.advance`` integrates, solved
independently: the ODE with scipy (:func:`spring_slider`), slip weakening
exactly (:func:`slip_weakening_spring`)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from fricfem.friction import slip_weakening as sw
from fricfem.friction.base import Law, as_params
from .common import Reference, const, has_branch, mode_at, dense_peak, segments, sgn, traction_at_rate  # noqa: F401


def spring_slider(law: Law, params, t, jump_rate: Callable, Tn, Cs: float, Ts0: float = 0.0,
                  state0=None, rtol: float = 1e-10, atol=None, breaks=(), peak_per_step: int = 8,
                  max_step: float = np.inf, switch_band: float = 1e-6) -> Reference:
    """The elastic-interface point: Ṫ_s = C_s (Δu̇_s(t) − sgn(T_s) v), state' and v
    from ``law.rates``, by scipy's Radau method.

    t          requested output times [s] (the first is the start)
    jump_rate  callable t -> Δu̇_s [m/s] (e.g. the continuous ramp)
    Tn         callable t -> T_n [Pa], or a constant
    breaks     times where the forcing has a kink (the integration restarts there)
    switch_band  hysteresis of the stick/slip switch [m/s] (see ``event``)
    atol       absolute tolerances of (T_s, state..., slip, work); default rtol
               times their scales (T_n, |state0|, T_n/C_s, T_n²/C_s)
    """
    if law.rates is None:
        raise ValueError(f"friction law '{law.name}' has no rates (use the exact references)")
    p = as_params(law, params)
    t = np.asarray(t, dtype=np.float64)
    Tn_f = const(Tn)
    Tn0 = Tn_f(t[0])
    s0 = np.array(law.initial_state(p, Tn0, Ts0) if state0 is None else state0, dtype=np.float64)
    ns = len(s0)
    branch = has_branch(law)
    Cs = float(Cs)

    def rates(mode, tt, y):
        if branch:
            return law.rates(p, y[1:1 + ns], y[0], Tn_f(tt), branch=mode)
        return law.rates(p, y[1:1 + ns], y[0], Tn_f(tt))

    def rhs(mode):
        def f(tt, y):
            v, ds = rates(mode, tt, y)
            dy = np.empty(ns + 3)
            dy[0] = Cs * (jump_rate(tt) - sgn(y[0]) * v)
            dy[1:1 + ns] = ds
            dy[ns + 1] = v
            dy[ns + 2] = abs(y[0]) * v
            return dy
        return f

    def event(mode, t0, y0):
        if not branch:
            return None
        # The switch is located to the solver's tolerance (the sliding
        # branch's rate there is zero to ~V0 m rtol), so the new regime may
        # start with it a hair on the wrong side of zero, and a trajectory that
        # only grazes β = 1 would switch back and forth without progress.  A
        # hysteresis band of ``switch_band`` [m/s] beyond the start value
        # prevents that: a negligible error (slip ~ band × the grazing time).
        g0 = rates("slide", t0, y0)[0]
        off = max(g0, 0.0) + switch_band if mode == "stick" else min(g0, 0.0) - switch_band

        def g(tt, y):  # the sliding branch's slip rate: zero at the strength
            return rates("slide", tt, y)[0] - off
        g.terminal = True
        g.direction = 1.0 if mode == "stick" else -1.0
        return g

    def switch(mode, tt, y, which):
        return ("slide" if mode == "stick" else "stick"), y

    y0 = np.concatenate(([Ts0], s0, [0.0, 0.0]))
    mode = None
    if branch:
        mode = "slide" if rates("slide", t[0], y0)[0] > 0.0 else "stick"
    if atol is None:
        Tsc = max(Tn0, abs(Ts0), 1.0)
        atol = rtol * np.concatenate(([Tsc], np.where(s0 != 0.0, np.abs(s0), 1.0), [Tsc / Cs, Tsc * Tsc / Cs]))
    Y, pieces, nfev = segments(rhs, event, switch, y0, mode, t, rtol, atol, breaks, max_step=max_step)
    # the slip rate at the output times: the law's own v (with its switch: >= 0)
    v = np.array([law.rates(p, Y[i, 1:1 + ns], Y[i, 0], Tn_f(t[i]))[0] for i in range(len(t))])
    peak, tpk, each = dense_peak(pieces, lambda md, tt, y: rates(md, tt, y)[0], peak_per_step)
    return Reference(t, Y[:, 0], np.array([Tn_f(x) for x in t]), v, Y[:, ns + 1], Y[:, ns + 2],
                     Y[:, 1:1 + ns], peak, tpk, nfev, len(pieces), each)


def _sw_params(params):
    p = as_params(sw.LAW, params)
    return p[sw.MU_S], p[sw.MU_D], p[sw.DC]


def slip_weakening_spring(params, t, jump, Tn: float, Cs: float, Ts0: float = 0.0) -> Reference:
    """Exact solution of the slip-weakening elastic point for a non-decreasing
    imposed jump Δu_s(t) (``jump``: values at ``t``, or a callable), constant
    T_n, Ts0 >= 0:

    * stick: T_s = Ts0 + C_s (Δu_s(t) − Δu_s(t0)) until T_s = μs T_n;
    * weakening branch (C_s > T_n (μs − μd)/Dc): T_s = μ(δ) T_n and
      Ṫ_s = C_s (Δu̇_s − δ̇) give δ̇ = C_s Δu̇_s / (C_s − T_n (μs − μd)/Dc), i.e.
      δ = C_s ΔJ / (C_s − T_n w) for the jump ΔJ since the onset, until δ = Dc;
    * then μ = μd: T_s = μd T_n, δ̇ = Δu̇_s.
    If C_s <= T_n w (snap-back) the point jumps at the onset to δ = (μs − μd) T_n / C_s
    on the μd branch.  Work: ∫ |T_s| dδ (exact on each branch).
    """
    mu_s, mu_d, Dc = _sw_params(params)
    t = np.asarray(t, dtype=np.float64)
    J = np.asarray(jump(t) if callable(jump) else jump, dtype=np.float64)
    if np.any(np.diff(J) < 0.0) or Ts0 < 0.0:
        raise ValueError("slip_weakening_spring: the jump must not decrease and Ts0 >= 0")
    J = J - J[0]
    wk = Tn * (mu_s - mu_d) / Dc
    Jon = (mu_s * Tn - Ts0) / Cs  # jump at the onset of slip
    d = np.zeros_like(J)
    after = J > Jon
    if Cs > wk:
        d[after] = Cs * (J[after] - Jon) / (Cs - wk)
        Jdc = Jon + Dc * (Cs - wk) / Cs  # jump at which δ = Dc
        flat = J > Jdc
        d[flat] = Dc + (J[flat] - Jdc)
    else:
        djump = (mu_s - mu_d) * Tn / Cs
        d[after] = djump + (J[after] - Jon)
    Ts = Ts0 + Cs * (J - d)
    # work: ∫ μ(δ) T_n dδ
    dd = np.minimum(d, Dc)
    work = Tn * (mu_s * dd - 0.5 * (mu_s - mu_d) * dd * dd / Dc) + mu_d * Tn * np.maximum(d - Dc, 0.0)
    rate = np.gradient(d, t) if len(t) > 2 else np.zeros_like(t)
    return Reference(t, Ts, np.full_like(t, Tn), rate, d, work, d[:, None], float(rate.max()),
                     float(t[np.argmax(rate)]), 0, 1)
