"""Integrating a Povirk–Needleman point over one bulk step (the law's
equations: :mod:`.povirk_needleman_equations`).

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

from .base import frictional_work, sign
from .povirk_needleman_equations import (B, C, D, GAMMA, L0, L1, L2, M, MU_D, MU_S, N_STORAGE, SUB_STIFF, SUB_TOL, V0,
                                         _g_dg, _pow, _rate, strength_factor)

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
# the rigid verb's history (its two-step form): T^{n−1} [Pa] and V^{n−½} [m/s], signed
_PREV_T, _PREV_V = 6, 7
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


# One piece (numba): the Newton iteration shares a dozen intermediate values
# between the residual, its derivative and the bracket; split into calls they
# would travel as tuples through the innermost loop of the time step.
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


# One piece (numba): stick, onset and the adaptive sliding sub-steps form one
# loop over the step with a shared state (the memo, the running strength
# bound); it is the kernel's inner call, inlined per point.
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
def _relax(th, target, x):
    """θ relaxed exactly over a "distance" x >= 0 towards ``target``: θ e^(−x) + target (1 − e^(−x))."""
    return th * math.exp(-x) - target * math.expm1(-x)


@numba.njit(cache=True)
def _theta_exact(p, th0, th1, th2, w, Tn, h):
    """The θ's after h at the constant slip rate w >= 0 and normal traction Tn,
    exactly (each equation is linear in its θ at constant w): θ0 = θ0 e^(−x) +
    B h E(x), x = B w h/L0, E(x) = (1 − e^(−x))/x; θ1 → C T_n, θ2 → D T_n over
    the slip w h/L1, w h/L2."""
    x = p[B] * w * h / p[L0]
    E = 1.0 - 0.5 * x if x < 1e-8 else -math.expm1(-x) / x
    a0 = th0 * math.exp(-x) + p[B] * h * E
    a1 = _relax(th1, p[C] * Tn, w * h / p[L1])
    a2 = _relax(th2, p[D] * Tn, w * h / p[L2])
    return a0, a1, a2


@numba.njit(cache=True)
def rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """One step t^n → t^{n+1} of a rigid split-node pair (contract in :mod:`.base`),
    second order.

    The rigid limit of the law holds at the middle of the step, where the
    pair's slip rate v = V^{n+½} lives, against the traction of t^{n+½}
    extrapolated from the step's T^n and the previous step's T^{n−1}:
    |T̂| = g(θ0)(θ1 + θ2)(1 + v/V0)^(1/m), T̂ = (3 T^n − T^{n−1})/2, T^n =
    T_stick − Z V^{n+½} (so T̂ = T̂_0 − (3/2) Z V^{n+½}, T̂_0 = (3 T_stick −
    T^{n−1})/2), with the θ's of t^{n+½} from the backward-Euler update over
    dt/2 at v (θ0 = (θ0ⁿ + B dt/2)/(1 + B (dt/2) v/L0), θ1 = (θ1ⁿ + C T_n (dt/2)
    v/L1)/(1 + (dt/2) v/L1), likewise θ2) and T_n = (3 T_n^n − T_n^{n−1})/2.  If
    |T̂_0| <= g(θ0ⁿ + B dt/2)(θ1 + θ2) the pair sticks: v = 0, T_s = T_stick.
    Otherwise the consistency is solved for y = (1 + v/V0)^(1/m) on [1, y_max]
    by the elastic sub-step's safeguarded Newton iteration (:func:`_slide_substep`
    with γ = 1, zero jump rate, h = dt/2 and C_s h = 3Z/2: its trial traction is
    then T̂_0 and its traction drop (3/2) Z v).  The θ's then advance exactly at v
    (the step's mean rate) over the whole step, and the slip by v dt: second
    order in dt, and at creep (stiff) a perturbation dies out in a step or two
    with no alternation (the BDF2 rule's damping; :func:`.rate_state.rigid`).
    The first step (no history: memo NaN) and the first after an opening
    (T_n^{n−1} <= 0) take T̂ = T^n, the law at the middle of the step against
    the traction of t^n.  Returns one local iteration count (one implicit solve).
    """
    if dt <= 0.0:
        # Safeguard: no time, no slip (and Z/dt below is undefined)
        return T_stick, 0.0, 0.0, 0.0, 0
    h = 0.5 * dt
    hist = s.size >= N_STORAGE and Tn0 > 0.0
    tp = s[_PREV_T] if hist else np.nan
    vp = s[_PREV_V] if hist else np.nan
    if tp == tp and vp == vp:
        That = 1.5 * T_stick - 0.5 * tp
        Zh = 1.5 * Z
        tnh = 1.5 * Tn1 - 0.5 * Tn0
        if tnh <= 0.0:
            tnh = Tn1  # Safeguard: a normal traction falling to zero within half a step
    else:
        That, Zh, tnh = T_stick, Z, Tn1
    # γ = 1, vs = 0, C_s = Zh/h: T* = T̂_0, traction drop h (Zh/h) v = Zh v
    Ts1, _, _, _, w, _, _, _ = _slide_substep(
        p, That, s[0], s[1], s[2], 0.0, 1.0, tnh, tnh, 0.0, Zh / h, h, 1.0
    )
    vsig = sign(That) * w
    Ts = T_stick - Z * vsig
    # the state at t^{n+1}: exact over dt at w
    a0, a1, a2 = _theta_exact(p, s[0], s[1], s[2], w, tnh, dt)
    s[0] = a0
    s[1] = a1
    s[2] = a2
    # the strength of the new state, for the memo of a later ``advance``
    _remember(s, a0, a1 + a2, strength_factor(p, a0) * (a1 + a2))
    if s.size >= N_STORAGE:
        s[_PREV_T] = Ts
        s[_PREV_V] = vsig
    ds = w * dt
    return Ts, w, ds, abs(Ts) * ds, 1
