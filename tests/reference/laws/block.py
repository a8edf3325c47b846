"""The rigid (split-node) verb's continuous problem, solved independently: a
rigid block on the frictional contact (:func:`block_slider`; slip weakening
exactly, :func:`slip_weakening_block`), and fricfem's ``rigid`` driven through
the same problem in the split-node step (:func:`drive_rigid`)."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from fricfem.friction.base import Law, as_params, storage
from .common import Reference, const, has_branch, mode_at, dense_peak, segments, sgn, traction_at_rate  # noqa: F401
from .spring import _sw_params


def _velocity_variable(branch: bool, v_floor, V_init: float) -> tuple:
    """(vel(y), dy/dV, y(V_init)): the block velocity's variable, V itself for a
    switching law, asinh(V/v_floor) otherwise (smooth through 0 across decades)."""
    if branch:
        return (lambda y0: y0), (lambda V: 1.0), V_init

    def vel(y0):
        # +-inf for a solver's trial point far out (the rhs then returns NaN: retry shorter)
        return v_floor * math.sinh(y0) if abs(y0) < 700.0 else math.copysign(math.inf, y0)

    return vel, (lambda V: 1.0 / math.hypot(v_floor, V)), math.asinh(V_init / v_floor)


def _start_mode(V_init: float, F0: float, strength: float) -> str:
    """The regime a switching law starts in: sliding along V_init, else stuck
    unless the force exceeds the strength."""
    if V_init != 0.0:
        return "slide+" if V_init > 0.0 else "slide-"
    return "stick" if abs(F0) <= strength else ("slide+" if F0 >= 0.0 else "slide-")


def _atol(rtol, Tn0, V_init, t, m, s0, branch) -> np.ndarray:
    """Absolute tolerances on (velocity variable, state, slip, work) from their scales."""
    Tsc = max(Tn0, 1.0)
    Vsc = max(abs(V_init), Tsc * (t[-1] - t[0]) / m * 1e-3, 1e-6)
    return rtol * np.concatenate(([Vsc if branch else 1.0], np.where(s0 != 0.0, np.abs(s0), 1.0),
                                  [Vsc * (t[-1] - t[0]), Tsc * Vsc * (t[-1] - t[0])]))


def _block_system(law, p, ns, branch, vel, dy_dv, Tn_f, force, m) -> tuple:
    """The block's ODE system per regime, for :func:`~.common.segments`:
    (tau, rhs, event, switch); y = (velocity variable, state, slip, work)."""

    def tau(y, tt, mode):
        """(friction traction on the block, state rates) while sliding.  A
        switching law slides along the mode's direction sg and uses the smooth
        continuation of its sliding branch (slightly negative sg·V before the
        stop event fires), so the right-hand side is smooth within the mode;
        a law without a stick regime has τ odd and smooth in V."""
        V = vel(y[0])
        st = y[1:1 + ns]
        if branch:
            sg = 1.0 if mode == "slide+" else -1.0
            T = traction_at_rate(law, p, st, sg * V, Tn_f(tt), True)
            return sg * T, law.rates(p, st, T, Tn_f(tt), branch="slide")[1]
        T = traction_at_rate(law, p, st, abs(V), Tn_f(tt), False)
        return sgn(V) * T, law.rates(p, st, T, Tn_f(tt))[1]

    def rhs(mode):
        def f(tt, y):
            dy = np.empty(ns + 3)
            if mode == "stick":
                dy[0] = 0.0
                dy[1:1 + ns] = law.rates(p, y[1:1 + ns], 0.0, Tn_f(tt), branch="stick")[1]
                dy[ns + 1] = dy[ns + 2] = 0.0
                return dy
            V = vel(y[0])
            if not math.isfinite(V):
                dy[:] = math.nan
                return dy
            T, ds = tau(y, tt, mode)
            dy[0] = (force(tt) - T) / m * dy_dv(V)
            dy[1:1 + ns] = ds
            dy[ns + 1] = abs(V)
            dy[ns + 2] = abs(T * V)
            return dy
        return f

    def event(mode, t0, y0):
        if not branch:
            return None
        if mode == "stick":
            def g(tt, y):  # |F| reaches the strength
                return abs(force(tt)) - traction_at_rate(law, p, y[1:1 + ns], 0.0, Tn_f(tt), True)
            g.direction = 1.0
        else:
            sgn0 = {"slide+": 1.0, "slide-": -1.0}[mode]

            def g(tt, y):  # the block comes to rest
                return sgn0 * y[0]
            g.direction = -1.0
        g.terminal = True
        return g

    def switch(mode, tt, y, which):
        y = y.copy()
        y[0] = 0.0
        F = force(tt)
        strength = traction_at_rate(law, p, y[1:1 + ns], 0.0, Tn_f(tt), True)
        if mode != "stick" and abs(F) <= strength:
            return "stick", y
        return ("slide+" if F >= 0.0 else "slide-"), y

    return tau, rhs, event, switch


def block_slider(law: Law, params, t, force: Callable, mass: float, Tn, V_init: float = 0.0,
                 state0=None, Ts0: float = 0.0, rtol: float = 1e-10, atol=None,
                 peak_per_step: int = 4, max_step=None, v_floor=None) -> Reference:
    """A rigid block of mass per unit area ``mass`` [kg/m²] driven by ``force``
    (callable t -> F [Pa]) on the frictional contact under ``Tn`` [Pa]:
    m V̇ = F(t) − sgn(V) τ(|V|, state), state' from ``law.rates``.  Returns
    the block velocity V (signed) as ``slip_rate`` and the friction traction
    sgn(V) τ as ``Ts``.  ``state0`` defaults to ``law.initial_state(p, Tn, Ts0)``.

    A law without a stick regime (rate and state: τ(V) is odd, smooth, and V
    spans many orders of magnitude between creep and sliding) is integrated
    in y = asinh(V/v_floor), which is ~sgn(V) ln(2|V|/v_floor) and smooth
    through V = 0 (default v_floor: the law's slip rate at |T_s| = 10⁻³ T_n in
    the initial state, below which τ is linear in V).  ``max_step`` (default: the spacing of ``t``) keeps the
    solver from stepping over a change of the force while the block sticks.
    """
    if law.rates is None:
        if law.name == "slip_weakening":
            return slip_weakening_block(params, t, force, mass, Tn, V_init=V_init, state0=state0)
        raise ValueError(f"friction law '{law.name}' has no rates and no exact block reference")
    p = as_params(law, params)
    t = np.asarray(t, dtype=np.float64)
    Tn_f = const(Tn)
    s0 = np.array(law.initial_state(p, Tn_f(t[0]), Ts0) if state0 is None else state0, dtype=np.float64)
    ns = len(s0)
    branch = has_branch(law)
    m = float(mass)
    if max_step is None:
        max_step = float(np.min(np.diff(t)))
    if not branch and v_floor is None:
        v_floor = law.rates(p, s0, 1e-3 * Tn_f(t[0]), Tn_f(t[0]))[0]
    vel, dy_dv, y_init = _velocity_variable(branch, v_floor, V_init)

    tau, rhs, event, switch = _block_system(law, p, ns, branch, vel, dy_dv, Tn_f, force, m)

    y0 = np.concatenate(([y_init], s0, [0.0, 0.0]))
    mode = "slide"
    if branch:
        mode = _start_mode(V_init, force(t[0]), traction_at_rate(law, p, s0, 0.0, Tn_f(t[0]), True))
    if atol is None:
        atol = _atol(rtol, Tn_f(t[0]), V_init, t, m, s0, branch)
    Y, pieces, nfev = segments(rhs, event, switch, y0, mode, t, rtol, atol, (), max_step=max_step)
    T = np.zeros(len(t))
    V = np.array([vel(y) for y in Y[:, 0]])
    for i in range(len(t)):
        if mode_at(pieces, t[i]) == "stick":
            T[i] = force(t[i])  # the contact holds the block
        else:
            T[i] = tau(Y[i], t[i], mode_at(pieces, t[i]))[0]
    peak, tpk, each = dense_peak(pieces, lambda md, tt, y: vel(y[0]), peak_per_step)
    return Reference(t, T, np.array([Tn_f(x) for x in t]), V, Y[:, ns + 1], Y[:, ns + 2],
                     Y[:, 1:1 + ns], peak, tpk, nfev, len(pieces), each)


def slip_weakening_block(params, t, force: Callable, mass: float, Tn: float, V_init: float = 0.0,
                         state0=None, rtol: float = 1e-12, max_step=None) -> Reference:
    """The slip-weakening block, event based: stick while |F| <= μ(δ) T_n;
    sliding: m V̇ = F − sgn(V) μ(δ) T_n, δ' = |V|, with events at δ = Dc (the
    kink of μ) and V = 0 (stick or continue along F).  Each segment is smooth
    and non-stiff (DOP853, rtol 1e-12): exact to round-off in practice."""
    mu_s, mu_d, Dc = _sw_params(params)
    t = np.asarray(t, dtype=np.float64)
    m = float(mass)
    d0 = 0.0 if state0 is None else float(np.asarray(state0).ravel()[0])

    def mu(d):
        return mu_s - (mu_s - mu_d) * min(d, Dc) / Dc

    def rhs(mode):
        def f(tt, y):
            if mode == "stick":
                return np.zeros(3)
            sg = 1.0 if mode == "slide+" else -1.0
            T = sg * mu(y[1]) * Tn
            return np.array([(force(tt) - T) / m, abs(y[0]), abs(T * y[0])])
        return f

    def event(mode, t0, y0):
        if mode == "stick":
            def g(tt, y):
                return abs(force(tt)) - mu(y[1]) * Tn
            g.direction = 1.0
            g.terminal = True
            return g
        sg = 1.0 if mode == "slide+" else -1.0

        def stop(tt, y):
            return sg * y[0]
        stop.direction = -1.0
        stop.terminal = True

        def kink(tt, y):
            return y[1] - Dc
        kink.direction = 1.0
        kink.terminal = True
        return [stop, kink]

    def switch(mode, tt, y, which):
        y = y.copy()
        if mode != "stick" and which == 1:
            y[1] = max(y[1], Dc)  # at the kink of μ: same regime, new (smooth) segment
            return mode, y
        y[0] = 0.0
        F = force(tt)
        if mode != "stick" and abs(F) <= mu(y[1]) * Tn:
            return "stick", y
        return ("slide+" if F >= 0.0 else "slide-"), y

    if V_init != 0.0:
        mode = "slide+" if V_init > 0.0 else "slide-"
    else:
        F0 = force(t[0])
        mode = "stick" if abs(F0) <= mu(d0) * Tn else ("slide+" if F0 > 0 else "slide-")
    y0 = np.array([V_init, d0, 0.0])
    Vsc = max(abs(V_init), Tn * (t[-1] - t[0]) / m * 1e-3)
    atol = rtol * np.array([Vsc, Dc, Tn * Dc])
    if max_step is None:
        max_step = float(np.min(np.diff(t)))  # do not step over a change of the force while sticking
    Y, pieces, nfev = segments(rhs, event, switch, y0, mode, t, rtol, atol, (), method="DOP853",
                                max_step=max_step)
    T = np.array([(force(t[i]) if mode_at(pieces, t[i]) == "stick" else sgn(Y[i, 0]) * mu(Y[i, 1]) * Tn)
                  for i in range(len(t))])
    peak, tpk, each = dense_peak(pieces, lambda md, tt, y: y[0], 4)
    return Reference(t, T, np.full_like(t, Tn), Y[:, 0], Y[:, 1], Y[:, 2], Y[:, 1:2], peak, tpk, nfev,
                     len(pieces), each)


def drive_rigid(law: Law, params, t, force: Callable, mass: float, Tn, V_init: float = 0.0,
                state0=None, Ts0: float = 0.0):
    """fricfem's discretisation of the block (a plain Python loop over ``law.rigid``),
    the central-difference step of a split-node pair: the block's velocity at the
    half steps, its slip and the law's state at the whole steps, the friction
    traction of the step t^n → t^{n+1} at t^n::

        m (V^{n+½} − V^{n−½}) / Δ^n = F(t^n) − T^n,   Δ^n = (t^{n+1} − t^{n−1})/2,
        T_stick = m V^{n−½}/Δ^n + F(t^n),  Z = m/Δ^n,  V^{n+½} = sgn(T_stick) v,
        δ^{n+1} = δ^n + v (t^{n+1} − t^n),

    started with a half step (V^{−½} = V_init, Δ^0 = (t^1 − t^0)/2: second order).
    The law's normal traction is T_n(t^n) (Tn1; Tn0 = T_n(t^{n−1})).

    Returns (V, friction traction, slip, work, state, iterations): V[k] = V^{k+½}
    at (t[k] + t[k+1])/2, the traction T[k] = T^k at t[k] and the iterations of
    step k (each len(t) − 1); the slip, the work and the state at ``t``."""
    p = as_params(law, params)
    t = np.asarray(t, dtype=np.float64)
    Tn_f = const(Tn)
    s = storage(law, law.initial_state(p, Tn_f(t[0]), Ts0) if state0 is None else state0)
    ns = len(law.state)
    n = len(t)
    V = np.zeros(n - 1)
    T = np.zeros(n - 1)
    slip = np.zeros(n)
    work = np.zeros(n)
    nit = np.zeros(n - 1, dtype=np.int64)
    state = np.zeros((n, ns))
    state[0] = s[:ns]
    m = float(mass)
    v_prev = float(V_init)
    for k in range(n - 1):
        dt = t[k + 1] - t[k]
        dm = 0.5 * (t[k + 1] - t[k - 1]) if k > 0 else 0.5 * dt
        Tst = m * v_prev / dm + force(t[k])
        Ts, v, ds, dw, it = law.rigid(p, s, Tst, m / dm, Tn_f(t[k - 1] if k > 0 else t[0]), Tn_f(t[k]), dt)
        # the slip's direction: that of T_stick − T^n (= sgn(T_stick) unless a law's
        # two-step form slips against T_stick, where T_stick crosses zero)
        d = Tst - Ts
        v_prev = V[k] = math.copysign(v, d if d != 0.0 else Tst) if v > 0.0 else 0.0
        T[k] = Ts
        slip[k + 1] = slip[k] + ds
        work[k + 1] = work[k] + dw
        nit[k] = it
        state[k + 1] = s[:ns]
    return V, T, slip, work, state, nit
