"""Povirk–Needleman rate- and state-dependent friction with Prakash–Clifton
normal-stress memory — the law of the paper (section "Rate- and
state-dependent friction law"; Povirk & Needleman 1993, Prakash & Clifton 1993).

The law
-------
With the slip rate v = Δu̇_slip >= 0 and three state variables
θ0 [s], θ1 [Pa], θ2 [Pa]::

    |T_s| = g(θ0) (θ1 + θ2) (1 + v/V0)^(1/m)                      (strength)
    g(θ0) = [μd + (μs − μd) exp(−(L0/(θ0 V1))^p)] / [L0/(θ0 V0) + 1]^(1/m)
    θ̇0 = B (1 − θ0 v / L0)
    θ̇1 = −(θ1 − C T_n) v / L1,        θ̇2 = −(θ2 − D T_n) v / L2

Inverted for the slip rate, with β = |T_s| / (g(θ0)(θ1 + θ2))::

    v = V0 (β^m − 1)  if β > 1,  else 0 (stick).

At steady sliding θ0 = L0/v and θ1 + θ2 = (C + D) T_n, so with C + D = 1::

    μ_ss(v) = μd + (μs − μd) exp(−(v/V1)^p).

θ0 has units of time and B is dimensionless (seconds of θ0 gained per second
of sticking); at constant v, θ0 relaxes exponentially in slip over L0/B
(4.3 µm for Table 1), θ1 and θ2 over L1 and L2.  The paper's Table 1 prints
C, D in MPa⁻¹; here they are dimensionless (θ1 + θ2 → T_n in steady state).

The elastic interface carries the shear traction::

    Ṫ_s = C_s (Δu̇_s − sgn(T_s) v).

Time integration
----------------
The paper integrates with the rate-tangent method (Peirce et al. 1984;
paper's Appendix: C_s^tan, Ṙ_p, parameter γ) and automatic step control.  At
the bulk's explicit step (20–100 ns) that update is unstable once the slip
rate reaches hundreds of m/s: the interface stiffness C_s ∂v/∂|T_s| reaches
~3·10⁷ 1/s and θ0, updated explicitly, relaxes at B v/L0 ≈ 1.6·10⁸ 1/s at
700 m/s.  It is kept as :func:`rate_tangent_advance`, for comparison.

:func:`advance` integrates the point over the bulk step ``dt`` with

* the exact elastic update while the point sticks (θ0 ages linearly, θ1, θ2
  frozen), and the onset of slip located inside the step (a bracketed root of
  |T_s(t)| = g(θ0(t))(θ1 + θ2));
* implicit generalised-midpoint sub-steps while it slides: the rate-tangent
  interpolation v = (1 − γ) v(t) + γ v(t + h), applied to the shear traction
  and to all three state variables, solved to round-off by a safeguarded
  Newton iteration on β at the end of the sub-step (started from the slip
  rate at the start, so its first iterate is a linearised, rate-tangent
  update);
* adaptive sub-steps: after each solve the change of T_s and of the strength
  g(θ0)(θ1 + θ2) must stay below ``substep_tol`` times the strength, and
  h C_s ∂v/∂|T_s| below ``substep_stiff``; otherwise the sub-step is redone
  shorter.  Steady sliding needs sub-steps only for the stiffness limit (none
  at 30 MPa and 700 m/s with a 50 ns step).

γ = 1/2 (trapezoidal, second order) is the default: at equal tolerances it is
2–70 times more accurate than backward Euler (γ = 1) on the point tests of
``docs/friction.md``, which also gives the measured errors and costs.
"""

import math

import numba
import numpy as np

from .base import Law, Param, frictional_work, sign

# Parameter indices in the packed array ``p`` (order of PARAMS).
MU_S, MU_D, V0, V1, B, P, M, L0, L1, L2, C, D, THETA0_INIT, GAMMA, SUB_TOL, SUB_STIFF = range(16)

PARAMS = (
    Param("mu_s", 0.6, "", 0.0, 1e4, "static friction coefficient μs (a large value locks a barrier)"),
    Param("mu_d", 0.5, "", 0.0, 5.0, "dynamic friction coefficient μd"),
    Param("V0", 100.0, "m/s", 1e-6, 1e6, "reference slip rate of the rate sensitivity"),
    Param("V1", 26.0, "m/s", 1e-6, 1e6, "slip rate of the steady-state weakening"),
    Param("B", 4.6, "", 1e-3, 1e3, "aging rate of θ0 (seconds of θ0 per second)"),
    Param("p", 1.2, "", 0.01, 10.0, "exponent of the steady-state weakening"),
    Param("m", 5.0, "", 1.0, 100.0, "rate-sensitivity exponent"),
    Param("L0", 20e-6, "m", 1e-9, 1.0, "slip distance of the θ0 evolution"),
    Param("L1", 20e-6, "m", 1e-9, 1.0, "slip distance of the θ1 (normal-stress) evolution"),
    Param("L2", 20e-6, "m", 1e-9, 1.0, "slip distance of the θ2 (normal-stress) evolution"),
    Param("C", 0.7, "", 0.0, 10.0, "share of T_n carried by θ1 in steady state"),
    Param("D", 0.3, "", 0.0, 10.0, "share of T_n carried by θ2 in steady state"),
    Param("theta0_init", 0.1, "L0/V1", 1e-6, 1e6, "initial θ0 in units of L0/V1"),
    Param("gamma", 0.5, "", 0.5, 1.0,
          "implicitness of the sub-step (1/2 trapezoidal, 1 backward Euler)"),
    Param("substep_tol", 0.03, "", 1e-4, 0.5,
          "largest change of T_s and of the strength g(θ0)(θ1+θ2) per sliding "
          "sub-step, relative to the strength"),
    Param("substep_stiff", 2.0, "", 1e-3, 100.0,
          "largest h C_s ∂v/∂|T_s| per sub-step"),
)

STATE = ("theta0", "theta1", "theta2")

# Storage per point: the three state variables, then a memo of the last
# strength evaluated, G = g(θ0)(θ1 + θ2), with the θ0 and θ1 + θ2 it belongs to
# (NaN: none).  ``advance`` reuses it instead of evaluating g again: exactly
# when the state is the one it was evaluated at (a point that slid through the
# previous step), and as a lower bound while the point sticks and θ0 only grows
# (g increases with θ0 when μs >= μd), so that a point well below its strength
# costs no transcendental function at all.  Reused as the strength of the same
# state, the memo is what evaluating g there gives, up to the last Newton
# step's first-order update (round-off); as a bound it changes no decision.
# A state of three entries (no memo) is accepted too.
_KEY_TH0, _KEY_TH, _MEMO_G = 3, 4, 5
N_STORAGE = 6  # len(STATE) + LAW.memo
# relative margin on a remembered strength used as a lower bound for a larger
# θ0 (covers round-off in evaluating g; g itself only grows)
_BOUND = 1.0 - 1e-12

# Largest number of sliding sub-steps per bulk step: below dt/MAX_SUBSTEPS the
# accuracy limits are dropped and the sub-step is backward Euler (L-stable,
# keeps θ0 > 0 and θ1, θ2 between their old value and C T_n, D T_n).
MAX_SUBSTEPS = 512
_NEWTON_MAXIT = 60
_NEWTON_RTOL = 1e-13
# a Newton step below this (relative) is the last one: the next would change y
# by its square, below round-off
_NEWTON_CLOSE = 1e-8


@numba.njit(cache=True)
def _int_exponent(e):
    """``e`` as an int when it is a whole number in [0, 16], else −1."""
    if 0.0 <= e <= 16.0 and e == math.floor(e):
        return int(e)
    return -1


@numba.njit(cache=True)
def _pow(y, e):
    """y**e; by repeated multiplication when e is a small whole number (m = 5
    of Table 1: y**5 and y**4 then cost four products instead of a ``pow``)."""
    n = _int_exponent(e)
    if n < 0:
        return y**e
    r = 1.0
    for _ in range(n):
        r *= y
    return r


@numba.njit(cache=True)
def _g_dg(p, ith0):
    """g(θ0) and dg/dθ0 from 1/θ0 (paper's Appendix, with Q = L0/(V0 θ0) + 1).

    Written with one division (the sliding sub-step evaluates it in a chain of
    dependent operations, where each division costs as much as ~10 products).
    """
    ds = p[MU_S] - p[MU_D]
    x = p[L0] / p[V1] * ith0
    xp = x ** p[P]
    # Safeguard: for θ0 -> 0, x^p overflows; exp(-x^p) -> 0 and so does its
    # derivative term (avoid inf * 0 = NaN).
    if xp > 700.0:
        e = 0.0
        de = 0.0
    else:
        e = math.exp(-xp)
        de = ds * p[P] * xp * e * ith0
    mu_star = p[MU_D] + ds * e
    a = p[L0] / p[V0] * ith0
    q = a + 1.0
    qm = q ** (-1.0 / p[M])
    g = mu_star * qm
    dg = de * qm + mu_star * a * ith0 * qm / (p[M] * q)
    return g, dg


@numba.njit(cache=True)
def g_and_dg(p, th0):
    """g(θ0) and dg/dθ0."""
    return _g_dg(p, 1.0 / th0)


@numba.njit(cache=True)
def strength_factor(p, th0):
    """g(θ0) alone."""
    return g_and_dg(p, th0)[0]


@numba.njit(cache=True)
def slip_rate(p, Ts_abs, th0, th1, th2):
    """Slip rate v = V0(β^m − 1) for β > 1, else 0 [m/s]."""
    return _rate(p, Ts_abs, strength_factor(p, th0) * (th1 + th2))


@numba.njit(cache=True)
def _rate(p, Ts_abs, G):
    """Slip rate for |T_s| and G = g(θ0)(θ1 + θ2), β = |T_s|/G."""
    if Ts_abs <= G:
        return 0.0
    if G <= 0.0:
        # Safeguard: no strength left (θ1 + θ2 = 0) with a nonzero traction.
        return np.inf
    return p[V0] * (_pow(Ts_abs / G, p[M]) - 1.0)


@numba.njit(cache=True)
def steady_mu(p, v):
    """μ_ss(v) = μd + (μs − μd) exp(−(v/V1)^p)."""
    return p[MU_D] + (p[MU_S] - p[MU_D]) * math.exp(-((v / p[V1]) ** p[P]))


def initial_state(p, Tn0, Ts0):
    """θ0 = theta0_init · L0/V1, θ1 = C Σ0, θ2 = D Σ0 (paper, "Friction law parameters")."""
    return np.array([p[THETA0_INIT] * p[L0] / p[V1], p[C] * Tn0, p[D] * Tn0])


def steady_state(p, v, Tn):
    """State of steady sliding at slip rate v > 0 [m/s] under T_n [Pa]:
    θ0 = L0/v, θ1 = C T_n, θ2 = D T_n (then |T_s| = μ_ss(v) T_n if C + D = 1)."""
    return np.array([p[L0] / v, p[C] * Tn, p[D] * Tn])


# --- the paper's plain rate-tangent update (one step, for comparison) -------------------


@numba.njit(cache=True)
def rate_tangent_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """One step of the paper's rate-tangent update (Appendix, steps 3–7).

    Same contract as :func:`advance` but no sub-steps and no implicit solve:
    C_s^tan = C_s / (1 + γ dt C_s ∂v/∂|T_s|),
    Ṙ_p = C_s^tan sgn(T_s) (v + γ dt Σ_i ∂v/∂θ_i θ̇_i),
    Ṫ_s = C_s^tan Δu̇_s − Ṙ_p, and the state rates use the interpolated
    slip rate v_γ = v + γ dt (∂v/∂|T_s| sgn(T_s) Ṫ_s + Σ_i ∂v/∂θ_i θ̇_i).
    The state rates are taken at T_n(t) = Tn0.  Unstable at large dt v.
    """
    th0, th1, th2 = s[0], s[1], s[2]
    gam = p[GAMMA]
    m = p[M]
    g, dg = g_and_dg(p, th0)
    Th = th1 + th2
    beta = abs(Ts) / (g * Th)
    if beta <= 1.0:
        Ts1 = Ts + Cs * vs * dt
        s[0] = th0 + p[B] * dt
        return Ts1, slip_rate(p, abs(Ts1), s[0], s[1], s[2]), 0.0, 0.0, 1
    bm = beta ** m
    v = p[V0] * (bm - 1.0)
    sg = sign(Ts)
    dv_dT = m * p[V0] * bm / beta / (g * Th)
    dv_dth0 = -m * p[V0] * bm * dg / g
    dv_dth12 = -m * p[V0] * bm / Th
    th0dot = p[B] * (1.0 - th0 * v / p[L0])
    th1dot = -(th1 - p[C] * Tn0) * v / p[L1]
    th2dot = -(th2 - p[D] * Tn0) * v / p[L2]
    b = dv_dth0 * th0dot + dv_dth12 * (th1dot + th2dot)
    c_tan = Cs / (1.0 + gam * dt * Cs * dv_dT)
    rp = c_tan * sg * (v + gam * dt * b)
    Tsdot = c_tan * vs - rp
    vg = v + gam * dt * (dv_dT * sg * Tsdot + b)
    Ts1 = Ts + Tsdot * dt
    s[0] = th0 + p[B] * (1.0 - th0 * vg / p[L0]) * dt
    s[1] = th1 - (th1 - p[C] * Tn0) * vg / p[L1] * dt
    s[2] = th2 - (th2 - p[D] * Tn0) * vg / p[L2] * dt
    dslip = vg * dt
    return Ts1, slip_rate(p, abs(Ts1), s[0], s[1], s[2]), dslip, frictional_work(Ts, Ts1, dslip), 1


# --- fricfem's integrator ----------------------------------------------------------------


@numba.njit(cache=True)
def _stick_onset(p, Ts, th0, Th, vs, Cs, h):
    """Time τ in (0, h] at which the elastic trial |T_s + C_s vs τ| reaches the
    aging strength g(θ0 + B τ)(θ1 + θ2); the caller knows f(0) <= 0 < f(h).

    Illinois (modified regula falsi) on the bracket: robust, a few iterations.
    """
    lo, hi = 0.0, h
    # Safeguard: when the trial changes sign it first unloads to zero, where it
    # cannot slip; start the bracket there so f is monotone on it.
    if Ts * vs < 0.0:
        tz = -Ts / (Cs * vs)
        if tz < h:
            lo = tz
    flo = abs(Ts + Cs * vs * lo) - strength_factor(p, th0 + p[B] * lo) * Th
    fhi = abs(Ts + Cs * vs * hi) - strength_factor(p, th0 + p[B] * hi) * Th
    side = 0
    for _ in range(100):
        if hi - lo <= 1e-12 * h:
            break
        t = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < t < hi):
            t = 0.5 * (lo + hi)
        f = abs(Ts + Cs * vs * t) - strength_factor(p, th0 + p[B] * t) * Th
        if f > 0.0:
            hi, fhi = t, f
            if side == 1:
                flo *= 0.5
            side = 1
        else:
            lo, flo = t, f
            if side == -1:
                fhi *= 0.5
            side = -1
        if abs(f) <= 1e-13 * abs(Ts + Cs * vs * t):
            break
    # The slip sub-step that follows starts from a point at or just above the
    # strength; take the upper end of the bracket.
    return hi


@numba.njit(cache=True)
def _slide_substep(p, Ts, th0, th1, th2, v, y0, Tna, Tnb, vs, Cs, h, gam):
    """One implicit generalised-midpoint sub-step of length h while sliding.

    With v_γ = (1 − γ) v + γ w and w the unknown slip rate at the end,
    T_s(h) = T* − h C_s γ w sgn(T*), T* = T_s + h C_s (vs − (1 − γ) v sgn(T_s)),
    and each θ_i(h) follows from the θ-method applied to its (linear in θ_i)
    equation, so it is a closed-form function of w.  The consistency
    |T_s(h)| = g(θ0(h))(θ1(h) + θ2(h)) y, w = V0 (y^m − 1), is solved for
    y in [1, y_max] (y = β at the end; y_max makes T_s(h) = 0) by Newton's
    method, bisecting whenever an iterate leaves the bracket.

    ``y0`` is β = (1 + v/V0)^(1/m) at the start (the Newton iteration starts there).

    Returns (Ts, θ0, θ1, θ2, w, y, G, dslip) at the end; G = g(θ0)(θ1 + θ2).
    """
    m = p[M]
    V0_ = p[V0]
    g1 = 1.0 - gam
    # explicit share of the slip rate (kept 0 for backward Euler even if the
    # start rate is infinite: no strength left at the start)
    gv = g1 * v if g1 > 0.0 else 0.0
    Tstar = Ts + h * Cs * (vs - gv * sign(Ts))
    absT = abs(Tstar)
    # θ_i(w) = (A_i + c_i w) / (1 + k_i w)
    hL0 = h / p[L0]
    hL1 = h / p[L1]
    hL2 = h / p[L2]
    A0 = th0 * (1.0 - p[B] * gv * hL0) + h * p[B]
    k0 = p[B] * gam * hL0
    A1 = th1 * (1.0 - gv * hL1) + gv * p[C] * Tna * hL1
    c1 = gam * p[C] * Tnb * hL1
    k1 = gam * hL1
    A2 = th2 * (1.0 - gv * hL2) + gv * p[D] * Tna * hL2
    c2 = gam * p[D] * Tnb * hL2
    k2 = gam * hL2
    dslip0 = h * gv
    if A0 <= 0.0 or A1 < 0.0 or A2 < 0.0:
        # The explicit part of a γ < 1 step overshot (h too long): no solution.
        return np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan
    iA0 = 1.0 / A0
    same = k1 == k2  # L1 = L2 (Table 1): θ1 and θ2 share their denominator

    e = h * Cs * gam * V0_  # |T_s(h)| = absT − e (y^m − 1)
    # The root lies in (1, y_max] if the point slides at all: F(1) > 0 (the
    # trial traction exceeds the strength at w = 0), and F(y_max) <= 0 where
    # T_s(h) = 0.  Both ends are evaluated only when needed (each costs a
    # transcendental function or three): F(1) once an iterate has F <= 0 (a
    # start at y0 <= 1 evaluates it first), y_max once a bisection needs it.
    ylo = 1.0
    yhi = np.inf
    one_checked = False
    # Start from the slip rate at the start of the sub-step: the first Newton
    # iterate is then the linearised (rate-tangent) update.
    y = y0 if 1.0 <= y0 < np.inf else 1.0
    w, ym1, th0e, th1e, th2e, G = 0.0, 1.0, A0, A1, A2, 0.0
    for _ in range(_NEWTON_MAXIT):
        ym1 = _pow(y, m - 1.0)
        w = V0_ * (ym1 * y - 1.0)
        dw = m * V0_ * ym1
        q0 = 1.0 + k0 * w
        r0 = 1.0 / q0
        th0e = A0 * r0
        r1 = 1.0 / (1.0 + k1 * w)
        r2 = r1 if same else 1.0 / (1.0 + k2 * w)
        th1e = (A1 + c1 * w) * r1
        th2e = (A2 + c2 * w) * r2
        g, dg = _g_dg(p, q0 * iA0)
        Th = th1e + th2e
        G = g * Th
        dG_dw = dg * (-th0e * k0 * r0) * Th + g * ((c1 - k1 * th1e) * r1 + (c2 - k2 * th2e) * r2)
        F = absT - e * (ym1 * y - 1.0) - G * y
        dF = -e * m * ym1 - G - y * dG_dw * dw
        if y == 1.0:  # F(1) itself
            if F <= 0.0:  # sticks at the end of the sub-step
                return Tstar, A0, A1, A2, 0.0, 1.0, G, dslip0
            one_checked = True
        if F == 0.0:
            break
        if F > 0.0:
            ylo = y
        else:
            yhi = y
            if not one_checked and ylo == 1.0:
                one_checked = True
                G0 = strength_factor(p, A0) * (A1 + A2)
                if absT <= G0:  # sticks at the end of the sub-step
                    return Tstar, A0, A1, A2, 0.0, 1.0, G0, dslip0
        # Safeguard: Newton inside the bracket, else bisection.
        ynew = y - F / dF if dF < 0.0 else -1.0
        if not (ylo <= ynew <= yhi):
            if yhi == np.inf:
                yhi = (1.0 + absT / e) ** (1.0 / m)
            ynew = 0.5 * (ylo + yhi)
        elif abs(ynew - y) <= _NEWTON_CLOSE * y:
            # Converging quadratically: ynew is exact to ~(ynew − y)², round-off.
            # Take it; the end state in closed form, G to first order (its
            # error is of the same size), saving one more evaluation of g.
            G += dG_dw * dw * (ynew - y)
            y = ynew
            ym1 = _pow(y, m - 1.0)
            w = V0_ * (ym1 * y - 1.0)
            th0e = A0 / (1.0 + k0 * w)
            r1 = 1.0 / (1.0 + k1 * w)
            th1e = (A1 + c1 * w) * r1
            th2e = (A2 + c2 * w) * (r1 if same else 1.0 / (1.0 + k2 * w))
            break
        if abs(ynew - y) <= _NEWTON_RTOL * y:
            break  # keep y: the end state above belongs to it
        y = ynew
    Ts1 = sign(Tstar) * max(absT - e * (ym1 * y - 1.0), 0.0)
    return Ts1, th0e, th1e, th2e, w, y, G, dslip0 + h * gam * w


@numba.njit(cache=True)
def _remember(s, th0, Th, G):
    """Keep G = g(θ0)·Th in the point's memo (if it has one)."""
    if s.size >= N_STORAGE:
        s[_KEY_TH0] = th0
        s[_KEY_TH] = Th
        s[_MEMO_G] = G


@numba.njit(cache=True)
def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """Integrate one point over the bulk step dt (contract in :mod:`.base`).

    Sticking stretches are integrated exactly, slip onsets located by a
    bracketed root, sliding stretches by adaptive implicit sub-steps (see the
    module docstring).  T_n is linear in time between Tn0 and Tn1.
    """
    m = p[M]
    gam = p[GAMMA]
    tol = p[SUB_TOL]
    kap = p[SUB_STIFF]
    hmin = dt / MAX_SUBSTEPS
    th0, th1, th2 = s[0], s[1], s[2]
    Th = th1 + th2
    absTs = abs(Ts)
    # g grows with θ0 when μs >= μd: a strength known at some θ0 is then a
    # lower bound ``lb`` on the strength after any aging with θ1, θ2 frozen.
    mono = p[MU_S] >= p[MU_D]
    # The strength at the start from the memo: exactly (the memo is of this
    # state), or the lower bound of a smaller θ0.  ``G < 0``: not known yet.
    G = -1.0
    lb = 0.0
    if s.size >= N_STORAGE and Th == s[_KEY_TH]:
        if th0 == s[_KEY_TH0]:
            G = s[_MEMO_G]
        elif th0 > s[_KEY_TH0] and mono:
            lb = s[_MEMO_G]
    if G < 0.0 and absTs <= lb * _BOUND:
        v = 0.0  # sticks at the start: below the strength at a smaller θ0
    else:
        if G < 0.0:
            G = strength_factor(p, th0) * Th
            _remember(s, th0, Th, G)
        if mono:
            lb = G
        v = _rate(p, absTs, G)
    t = 0.0
    dslip = 0.0
    dwork = 0.0
    nsub = 0
    # β at the start (the Newton iterations start there) and the first sub-step
    # from the stiffness h C_s ∂v/∂|T_s| = κ, ∂v/∂|T_s| = m V0 β^(m−1)/G
    y = absTs / G if v > 0.0 else 1.0
    h = kap * G / (Cs * m * p[V0] * _pow(y, m - 1.0)) if v > 0.0 and G > 0.0 else hmin
    onset = False
    while True:
        rem = dt - t
        if v == 0.0 and not onset:
            # Stick: T_s grows elastically, θ0 ages linearly, θ1, θ2 frozen.
            Te = Ts + Cs * vs * rem
            if abs(Te) <= lb * _BOUND:  # below a strength that aging only raises
                Ts = Te
                th0 += p[B] * rem
                nsub += 1
                break
            th_end = th0 + p[B] * rem
            G_end = strength_factor(p, th_end) * Th
            _remember(s, th_end, Th, G_end)
            if abs(Te) <= G_end:
                Ts = Te
                th0 = th_end
                nsub += 1
                break
            tau = _stick_onset(p, Ts, th0, Th, vs, Cs, rem)
            Ts += Cs * vs * tau
            th0 += p[B] * tau
            t += tau
            onset = True
            # First sliding sub-step from the stiffness at β = 1.
            G = strength_factor(p, th0) * Th
            y = 1.0
            h = kap * G / (Cs * m * p[V0]) if G > 0.0 else hmin
            continue
        onset = False
        if rem <= 0.0:
            break
        h = min(max(h, hmin), rem)
        tn_a = Tn0 + (Tn1 - Tn0) * t / dt
        while True:
            tn_b = Tn0 + (Tn1 - Tn0) * (t + h) / dt
            # Safeguard: at the floor the accuracy limits are dropped and the
            # sub-step is backward Euler (L-stable, positivity-preserving).
            forced = h <= hmin * 1.000001
            Ts1, a0, a1, a2, w, y1, G1, ds = _slide_substep(
                p, Ts, th0, th1, th2, v, y, tn_a, tn_b, vs, Cs, h, 1.0 if forced else gam
            )
            # Accuracy limits, checked on the solved sub-step: the change of
            # T_s and of the strength G = g(θ0)(θ1 + θ2) relative to the
            # strength (err <= tol), and the stiffness h C_s ∂v/∂|T_s| <= κ
            # with ∂v/∂|T_s| = m V0 y^(m−1) / G at the end.
            if Ts1 != Ts1:  # NaN: the explicit part of a γ < 1 step overshot
                r = np.inf
            else:
                r = 0.0  # no strength at all (G = 0): T_s(h) = 0 is exact
                Gm = max(G, G1)
                if Gm > 0.0:
                    err = max(abs(Ts1 - Ts), abs(G1 - G)) / Gm
                    stiff = h * Cs * m * p[V0] * _pow(y1, m - 1.0) / G1 if G1 > 0.0 else np.inf
                    r = max(err / tol, stiff / kap)
            if forced or r <= 1.0:
                break
            h = max(h * max(0.9 / r, 0.1), hmin)
        dwork += frictional_work(Ts, Ts1, ds)
        dslip += ds
        Ts, th0, th1, th2, v, y, G = Ts1, a0, a1, a2, w, y1, G1
        # the strength of the new state is known exactly, for the next stick
        # test (in this step) and the next step
        Th = th1 + th2
        lb = G if mono else 0.0
        _remember(s, th0, Th, G)
        nsub += 1
        if h >= rem:
            break
        t += h
        h = h * min(0.9 / r, 2.0) if r > 0.0 else 2.0 * h
    s[0] = th0
    s[1] = th1
    s[2] = th2
    return Ts, v, dslip, dwork, nsub


@numba.njit(cache=True)
def _relax(th, share, z, Tn0, Tn1):
    """θ after slip z·L of dθ/d(slip) = −(θ − share·T_n)/L, T_n linear in slip."""
    om = -math.expm1(-z)  # 1 − e^(−z)
    # 1 − (1 − e^(−z))/z, by its series for small z (cancellation)
    ramp = 1.0 - om / z if z > 1e-6 else z * (0.5 - z / 6.0)
    return th * (1.0 - om) + share * (Tn0 * om + (Tn1 - Tn0) * ramp)


@numba.njit(cache=True)
def slide(p, s, v, Tn0, Tn1, dt):
    """Advance the state over dt at the imposed slip rate v (no interface
    elasticity), T_n linear from Tn0 to Tn1; return the strength |T_s| at the end.

    Exact for constant v: the θ equations are linear in θ_i, solved in closed
    form (exponentials in slip, θ1, θ2 forced by the linear T_n).
    """
    th0 = s[0]
    if v > 0.0:
        th_ss = p[L0] / v
        th0 = th_ss + (th0 - th_ss) * math.exp(-p[B] * v * dt / p[L0])
    else:
        th0 = th0 + p[B] * dt
    s[0] = th0
    if v > 0.0 and dt > 0.0:
        s[1] = _relax(s[1], p[C], v * dt / p[L1], Tn0, Tn1)
        s[2] = _relax(s[2], p[D], v * dt / p[L2], Tn0, Tn1)
    return strength_factor(p, th0) * (s[1] + s[2]) * (1.0 + v / p[V0]) ** (1.0 / p[M])


LAW = Law(
    name="povirk_needleman",
    doc="rate- and state-dependent friction with normal-stress memory "
    "(Povirk & Needleman 1993, Prakash & Clifton 1993; the paper's law)",
    params=PARAMS,
    state=STATE,
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    slide=slide,
    memo=N_STORAGE - len(STATE),
)
