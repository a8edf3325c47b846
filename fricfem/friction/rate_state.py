"""Regularized Dieterich–Ruina rate-and-state friction: the code the aging law
(:mod:`.rate_state_aging`) and the slip law (:mod:`.rate_state_slip`) share.

The law
-------
With the slip rate V = Δu̇_slip >= 0 and a dimensionless state Ψ
(Rice & Ben-Zion 1996; Lapusta et al. 2000; the SCEC benchmarks TPV102–104)::

    |T_s| = μ(V, Ψ) T_n,     μ(V, Ψ) = a asinh[ V/(2 V0) exp(Ψ/a) ]

inverted for the slip rate::

    V(|T_s|, Ψ) = 2 V0 sinh(|T_s| / (a T_n)) exp(−Ψ/a)        (> 0 unless T_s = 0)

and one of the two state evolution laws

* aging (Dieterich), TPV101/102:  dΨ/dt = (b V0/L) [exp((f0 − Ψ)/b) − V/V0];
* slip (Ruina), TPV103/104:       dΨ/dt = −(V/L) [Ψ − Ψ_ss(V)],
  Ψ_ss(V) = a ln[(2 V0/V) sinh(f_ss(V)/a)],
  f_ss(V) = f_w + (f_LV(V) − f_w) / [1 + (V/V_w)^8]^(1/8),  f_LV(V) = f0 − (b − a) ln(V/V0).

With the default V_w = 10¹⁰ m/s the strong-weakening factor is exactly 1 in
double precision below ~10⁸ m/s, so the slip law is then the plain one with
f_ss = f_LV (the brief's form).  TPV103's strong rate weakening is the same
law with V_w = 0.1 m/s, f_w = 0.2.

Both laws are linear in a transformed state at constant V, so the state is
integrated exactly for a constant slip rate (as SEM2DPACK's and SeisSol's
solvers do):

* aging: φ = exp((Ψ − f0)/b) obeys dφ/dt = V0/L − (V/L) φ (Dieterich's θ is
  φ L/V0), so φ(t) = φ e^(−x) + (V0/V)(1 − e^(−x)), x = V t/L;
* slip: Ψ(t) = Ψ e^(−x) + Ψ_ss(V)(1 − e^(−x)) (exponential in slip over L).

Integrators
-----------
Every implicit update below solves one scalar equation for the end slip rate
w: with the traction T_end = S − Z w (S the traction if nothing slipped, Z
the traction drop per unit slip rate) and the state Ψ_end(w) integrated
exactly at the constant rate v_γ = v_fix + γ w over the (sub-)step::

    R(u) = u − ln V(S − Z w, Ψ_end(w)) = 0,      u = ln w,

i.e. w = V(T_end, Ψ_end): the law holds at the end.  R → +∞ where T_end → 0
(u_max = ln(S/Z)) and R → −∞ as u → −∞, so a root is bracketed; Newton's
method on u (w varies over 15 orders of magnitude between creep and dynamic
slip) with the bracket kept, geometric bisection whenever an iterate leaves
it, converges to |Δu| <= 1e-12 (relative 1e-12 in w).

* ``advance`` (elastic interface, Ṫ_s = C_s(Δu̇_s − sgn(T_s) V)): adaptive
  generalised-midpoint sub-steps: S = |T*|, T* = T_s + h C_s (Δu̇_s − (1 − γ) v
  sgn(T_s)), Z = γ h C_s, v_γ = (1 − γ) v + γ w (γ = 1/2: trapezoidal in the
  traction and mid-rate exponential in the state, second order).  A sub-step
  is accepted when the change of the slip rate over it, h C_s |w − v|, and the
  change of the end state it causes, |∂Ψ_end/∂v_γ| |w − v|, are both below
  ``substep_tol`` × a T_n (resp. × a), and h C_s ∂V/∂|T_s| <= ``substep_stiff``
  (keeps the trapezoidal rule out of its undamped regime: its amplification
  (1 − z/2)/(1 + z/2) is −2/3 at z = 10, the default; with 2, as
  Povirk–Needleman's, the errors on the point tests of
  docs/friction_reference.md were the same within 30 % for 2–3 times the
  sub-steps above 100 m/s); otherwise it is
  redone shorter (h · 0.9/r), the next grows by at most 2×.  Below
  dt/512 the limits are dropped and the sub-step is backward Euler (γ = 1,
  L-stable).  T_n is linear in time over the bulk step.
* ``rigid`` (split-node interface, second order): the same solve at the
  middle of the step, h = dt/2, against the traction of t^{n+½} extrapolated
  from T^n and T^{n−1}: S = |3 T_stick − T^{n−1}|/2, Z → 3 Z/2, v_fix =
  |V^{n−½}|/4, γ = 3/4 (the half step's mean rate); w is the pair's slip rate
  of the step, V^{n+½}; the state then advances exactly at w over the whole
  step, and the slip by w dt (:func:`rigid`).  SEM2DPACK's bc_dynflt_rsf
  (Kaneko et al. 2008), whose velocities and tractions share whole steps,
  takes two passes at fixed state (state at the old rate, solve V; state at
  the mean rate, solve V again); the coupled solve here is that second pass
  iterated to convergence.
* ``slide`` (imposed slip rate): the exact state update at constant V.
"""

import math

import numba
import numpy as np

from .base import Param, frictional_work, param_index, sign

AGING, SLIP = 0, 1

COMMON_PARAMS = (
    Param("a", 0.008, "", 1e-5, 1.0, "direct-effect parameter a"),
    Param("b", 0.012, "", 1e-6, 1.0, "evolution-effect parameter b (b > a: velocity weakening)"),
    Param("L", 1e-6, "m", 1e-9, 10.0, "state evolution slip L"),
    Param("V0", 1e-6, "m/s", 1e-12, 1e3, "reference slip rate V0"),
    Param("f0", 0.6, "", 0.0, 5.0, "steady-state friction coefficient at V0"),
    Param("V_ini", 1e-12, "m/s", 1e-30, 1e3,
          "initial slip rate: with the initial tractions it sets the initial state (as TPV102)"),
    Param("gamma", 0.5, "", 0.5, 1.0,
          "implicitness of the sub-step (1/2 trapezoidal, 1 backward Euler)"),
    Param("substep_tol", 0.03, "", 1e-4, 1.0,
          "largest change per sub-step of C_s h V and of the end state caused by the change of V, "
          "relative to a T_n and a"),
    Param("substep_stiff", 10.0, "", 1e-3, 100.0,
          "largest h C_s ∂V/∂|T_s| per sub-step (10: the trapezoidal rule damps a perturbation by 2/3 "
          "per sub-step at the limit)"),
)
#: The slip law's parameters (:mod:`.rate_state_slip`): the common ones and its strong rate weakening.
SLIP_PARAMS = COMMON_PARAMS + (
    Param("f_w", 0.2, "", 0.0, 5.0, "fully weakened friction coefficient of the strong rate weakening (TPV103)"),
    Param("V_w", 1e10, "m/s", 1e-6, 1e10,
          "weakening slip rate of the strong rate weakening (1e10: none below 1e8 m/s; TPV103: 0.1)"),
)

# Parameter indices in the packed array, from the names (both laws; F_W, V_W: slip law only, whose
# PARAMS extend the aging law's)
A, B, L, V0, F0, V_INI, GAMMA, SUB_TOL, SUB_STIFF, F_W, V_W = param_index(
    SLIP_PARAMS, "a", "b", "L", "V0", "f0", "V_ini", "gamma", "substep_tol", "substep_stiff", "f_w", "V_w")

STATE = ("psi",)
# the rigid verb's memo: the previous step's traction T^{n−1} [Pa] and slip rate V^{n−½} [m/s], signed
MEMO = 2

MAX_SUBSTEPS = 512
_NEWTON_MAXIT = 200
_NEWTON_TOL = 1e-12  # on u = ln w: relative precision of the slip rate
# a Newton step below this is the last one (the next would be its square)
_NEWTON_CLOSE = 1e-7
_LN2 = math.log(2.0)


# --- elementary functions, written to neither overflow nor cancel ----------------------


@numba.njit(cache=True)
def lnsinh(z):
    """ln sinh(z) for z >= 0 (−inf at 0)."""
    if z > 20.0:
        return z - _LN2 + math.log1p(-math.exp(-2.0 * z))
    if z <= 0.0:
        return -np.inf
    if z < 1e-4:
        return math.log(z) + z * z / 6.0
    return math.log(math.sinh(z))


@numba.njit(cache=True)
def lncosh(z):
    """ln cosh(z) for z >= 0."""
    return z - _LN2 + math.log1p(math.exp(-2.0 * z))


@numba.njit(cache=True)
def coth(z):
    """coth(z) for z > 0."""
    if z > 20.0:
        return 1.0
    if z < 1e-4:
        return 1.0 / z + z / 3.0
    return 1.0 / math.tanh(z)


@numba.njit(cache=True)
def _ln_e(x):
    """ln E(x) and d ln E/dx for E(x) = (1 − e^(−x))/x, x >= 0 (E(0) = 1)."""
    if x < 1e-5:
        return -0.5 * x + x * x / 24.0, -0.5 + x / 12.0
    lne = math.log(-math.expm1(-x)) - math.log(x)
    if x > 50.0:
        return lne, -1.0 / x
    return lne, 1.0 / math.expm1(x) - 1.0 / x


# --- the law ----------------------------------------------------------------------------


@numba.njit(cache=True)
def mu(p, v, psi):
    """μ(V, Ψ) = a asinh[V/(2 V0) exp(Ψ/a)]  (0 at V = 0)."""
    if v <= 0.0:
        return 0.0
    a = p[A]
    la = math.log(v / (2.0 * p[V0])) + psi / a  # ln of the asinh argument
    if la > 20.0:
        # asinh(x) = ln x + ln 2 + ln(1/2 + sqrt(1/4 + 1/(4x²))) ≈ ln x + ln 2 + 1/(4x²)
        return a * (la + _LN2 + math.log1p(0.25 * math.exp(-2.0 * la)))
    if la < -700.0:
        return 0.0  # asinh(x) = x underflows
    return a * math.asinh(math.exp(la))


@numba.njit(cache=True)
def ln_rate(p, Ts_abs, Tn, psi):
    """ln V for V = 2 V0 sinh(|T_s|/(a T_n)) exp(−Ψ/a); −inf at T_s = 0, +inf at T_n <= 0 < |T_s|."""
    if Ts_abs <= 0.0:
        return -np.inf
    if Tn <= 0.0:
        return np.inf  # Safeguard: no normal traction, no strength
    return math.log(2.0 * p[V0]) + lnsinh(Ts_abs / (p[A] * Tn)) - psi / p[A]


@numba.njit(cache=True)
def rate(p, Ts_abs, Tn, psi):
    """V(|T_s|, Ψ) [m/s]."""
    return math.exp(min(ln_rate(p, Ts_abs, Tn, psi), 700.0))


@numba.njit(cache=True)
def dv_dts(p, Ts_abs, Tn, psi):
    """∂V/∂|T_s| = 2 V0 cosh(|T_s|/(a T_n)) exp(−Ψ/a) / (a T_n) [m/(s·Pa)]."""
    if Tn <= 0.0:
        return np.inf
    aTn = p[A] * Tn
    return math.exp(min(math.log(2.0 * p[V0] / aTn) + lncosh(Ts_abs / aTn) - psi / p[A], 700.0))


@numba.njit(cache=True)
def f_ss(p, v):
    """The slip law's steady-state coefficient f_ss(V) (TPV103) and V df_ss/dV, V > 0."""
    flv = p[F0] - (p[B] - p[A]) * math.log(v / p[V0])
    vdflv = -(p[B] - p[A])
    if flv < 0.0:
        # Safeguard (as SeisSol): f_LV >= 0 (only for V/V0 > exp(f0/(b − a)))
        flv = 0.0
        vdflv = 0.0
    r = (v / p[V_W]) ** 8
    if r < 1e-18:  # 1 + r == 1 in double precision: no strong weakening
        return flv, vdflv
    d = (1.0 + r) ** 0.125
    return p[F_W] + (flv - p[F_W]) / d, vdflv / d - (flv - p[F_W]) * r / ((1.0 + r) * d)


@numba.njit(cache=True)
def psi_ss(kind, p, v):
    """Steady state Ψ_ss(V) and V dΨ_ss/dV, V > 0."""
    if kind == AGING:
        return p[F0] + p[B] * math.log(p[V0] / v), -p[B]
    a = p[A]
    f, vdf = f_ss(p, v)
    z = max(f / a, 1e-300)  # Safeguard: f_ss >= 0 (above)
    return a * (math.log(2.0 * p[V0] / v) + lnsinh(z)), -a + vdf * coth(z)


@numba.njit(cache=True)
def steady_mu_kind(kind, p, v):
    """μ_ss(V) = μ(V, Ψ_ss(V)); for the slip law this is f_ss(V) exactly.  V > 0."""
    if v <= 0.0:
        return np.nan
    if kind == SLIP:
        return f_ss(p, v)[0]
    return mu(p, v, psi_ss(AGING, p, v)[0])


@numba.njit(cache=True)
def state_end(kind, p, psi, v, h):
    """Ψ after a time h >= 0 at the constant slip rate v >= 0 (exact), and
    v ∂Ψ_end/∂v (0 at v = 0)."""
    x = v * h / p[L]
    if kind == AGING:
        b = p[B]
        # ln φ_end = ln[φ e^(−x) + (h V0/L) E(x)], a log-sum-exp (φ may under/overflow)
        lne, dlne = _ln_e(x)
        l1 = (psi - p[F0]) / b - x
        if h <= 0.0:
            return psi, 0.0
        l2 = math.log(h * p[V0] / p[L]) + lne
        mx = max(l1, l2)
        lnend = mx + math.log(math.exp(l1 - mx) + math.exp(l2 - mx))
        wa = math.exp(l1 - lnend)  # share of the decaying initial state
        return p[F0] + b * lnend, b * x * (-wa + (1.0 - wa) * dlne)
    # slip law
    if v <= 0.0 or h <= 0.0:
        return psi, 0.0
    ex = math.exp(-x)
    om = -math.expm1(-x)
    pss, vdpss = psi_ss(SLIP, p, v)
    return psi * ex + pss * om, x * ex * (pss - psi) + vdpss * om


@numba.njit(cache=True)
def solve_rate(kind, p, psi, vfix, gam, h, S, Z, Tn, u0):
    """The end slip rate w of an implicit update (module docstring):
    S − Z w = μ(w, Ψ_end) T_n, Ψ_end integrated exactly over h at v_fix + γ w.

    ``u0``: first guess of ln w (any value; clipped into the bracket).
    Returns (w, Ψ_end, T_end = S − Z w, v_γ ∂Ψ_end/∂v_γ, iterations).
    """
    if S <= 0.0:
        # nothing to slip for: T_end = 0, w = 0
        pe, dpe = state_end(kind, p, psi, vfix, h)
        return 0.0, pe, 0.0, dpe, 0
    if Tn <= 0.0:
        # Safeguard: no strength; the traction relaxes completely
        w = S / Z
        pe, dpe = state_end(kind, p, psi, vfix + gam * w, h)
        return w, pe, 0.0, dpe, 0
    a = p[A]
    aTn = a * Tn
    ln2v0 = math.log(2.0 * p[V0])
    uhi = math.log(S / Z)  # T_end = 0 there: R = +inf
    ulo = -np.inf
    u = u0
    # Safeguard: a start outside the bracket (or not finite) starts just below T_end = 0's rate
    if not (u < uhi):
        u = uhi - 1.0
    w, pe, dpe, Tend = 0.0, psi, 0.0, S
    it = 0
    for it in range(1, _NEWTON_MAXIT + 1):
        w = math.exp(u)
        Tend = S - Z * w
        vg = vfix + gam * w
        pe, dpe = state_end(kind, p, psi, vg, h)
        if Tend <= 0.0:
            # Safeguard: rounding put u at/above the T_end = 0 end of the bracket
            uhi = u
            un = 0.5 * (ulo + uhi) if ulo > -np.inf else u - 1.0
            u = un
            continue
        z = Tend / aTn
        R = u - (ln2v0 + lnsinh(z) - pe / a)
        if R == 0.0:
            break
        dR = 1.0 + Z * w * coth(z) / aTn + (dpe * gam * w / vg if vg > 0.0 else 0.0) / a
        if R > 0.0:
            uhi = u
        else:
            ulo = u
        un = u - R / dR if dR > 0.0 else np.nan
        # Safeguard: Newton inside the bracket, else geometric bisection; with no
        # lower end yet, step down by a factor e² in w (R < 0 far enough down:
        # R → −∞ like u while ln V stays bounded).
        if not (ulo < un < uhi):
            un = 0.5 * (ulo + uhi) if ulo > -np.inf else min(u, uhi) - 2.0
        elif abs(un - u) <= _NEWTON_CLOSE:
            # converging quadratically: un is exact to ~(un − u)², round-off;
            # take it with its end state (no further residual)
            u = un
            w = math.exp(u)
            Tend = S - Z * w
            pe, dpe = state_end(kind, p, psi, vfix + gam * w, h)
            break
        if abs(un - u) <= _NEWTON_TOL:
            break  # keep u: the end state above belongs to it
        if uhi - ulo <= _NEWTON_TOL:
            break  # bracket collapsed (round-off)
        u = un
    return w, pe, max(Tend, 0.0), dpe, it


@numba.njit(cache=True)
def advance(kind, p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """One bulk step dt on the elastic interface (contract in :mod:`.base`), by
    adaptive implicit sub-steps (module docstring)."""
    psi = s[0]
    gam = p[GAMMA]
    tol = p[SUB_TOL]
    kap = p[SUB_STIFF]
    a = p[A]
    v = rate(p, abs(Ts), Tn0, psi)
    if dt <= 0.0:
        return Ts, v, 0.0, 0.0, 1
    hmin = dt / MAX_SUBSTEPS
    t = 0.0
    dslip = 0.0
    dwork = 0.0
    nsub = 0
    # first sub-step from the stiffness h C_s ∂V/∂|T_s| = κ
    k0 = Cs * dv_dts(p, abs(Ts), Tn0, psi)
    h = kap / k0 if k0 > 0.0 else dt
    r = 0.0
    while True:
        rem = dt - t
        h = min(max(h, hmin), rem)
        while True:
            tnb = Tn0 + (Tn1 - Tn0) * (t + h) / dt
            # Safeguard: at the floor the accuracy limits are dropped and the
            # sub-step is backward Euler (L-stable).
            forced = h <= hmin * 1.000001
            g = 1.0 if forced else gam
            vfix = (1.0 - g) * v
            Tstar = Ts + h * Cs * (vs - vfix * sign(Ts))
            u0 = math.log(v) if v > 0.0 else np.inf
            w, pe, Tabs, dpe, _ = solve_rate(kind, p, psi, vfix, g, h, abs(Tstar), g * h * Cs, tnb, u0)
            vg = vfix + g * w
            Ts1 = sign(Tstar) * Tabs
            # Accuracy limits on the solved sub-step: the change of the slip
            # rate (as traction, C_s h |w − v|, against a T_n), the change of the
            # end state it causes (against a), and the stiffness h C_s ∂V/∂|T_s|.
            r = 0.0
            if tnb > 0.0:
                dv = abs(w - v)
                e1 = Cs * h * dv / (a * tnb)
                e2 = abs(dpe) / vg * dv / a if vg > 0.0 else 0.0
                stiff = h * Cs * dv_dts(p, Tabs, tnb, pe)
                r = max(max(e1, e2) / tol, stiff / kap)
            if forced or r <= 1.0:
                break
            h = max(h * max(0.9 / r, 0.1), hmin)
        ds = h * vg
        dwork += frictional_work(Ts, Ts1, ds)
        dslip += ds
        Ts, psi, v = Ts1, pe, w
        nsub += 1
        if h >= rem:
            break
        t += h
        h = h * min(0.9 / r, 2.0) if r > 0.0 else 2.0 * h
    s[0] = psi
    return Ts, v, dslip, dwork, nsub


@numba.njit(cache=True)
def rigid(kind, p, s, T_stick, Z, Tn0, Tn1, dt):
    """One step t^n → t^{n+1} of the rigid (split-node) interface (contract in
    :mod:`.base`), second order: the law holds at the middle of the step, where
    the pair's slip rate w = V^{n+½} lives, against the traction of t^{n+½}
    extrapolated from the step's T^n and the previous step's T^{n−1}::

        |T̂| = μ(w, Ψ^{n+½}) T_n^{n+½},   T̂ = (3 T^n − T^{n−1})/2,   T^n = T_stick − Z V^{n+½},

    i.e. S − (3/2) Z w with S = |3 T_stick − T^{n−1}|/2 (:func:`solve_rate`), the
    slip along sgn(3 T_stick − T^{n−1}); Ψ^{n+½} is the state of t^n integrated
    exactly over dt/2 at the mean rate of that half step, (|V^{n−½}| + 3 w)/4,
    inside the solve (the corrected pass of Kaneko et al. 2008, iterated to
    convergence), and T_n^{n+½} = (3 T_n^n − T_n^{n−1})/2.  Then Ψ^{n+1} is exact
    at w (the mean rate of the step) over dt, and the slip w dt.  In the stiff
    limit (creep: ∂τ/∂V dt/m ≫ 1) a perturbation of the slip rate is multiplied
    by ≈ ±i (2 m/(∂τ/∂V dt))^½ per step, the BDF2 rule's: it dies out in a step
    or two, with no alternation (a form at t^n with V^n = (V^{n−½} + V^{n+½})/2,
    trapezoidal in V, keeps it undamped).  T^{n−1} and V^{n−½} are the memo
    s[1], s[2]: NaN (the first step) or a pair that was open (T_n^{n−1} <= 0)
    takes the law at the middle of the step against T^n itself for that one
    step (first order in one step: second order overall)."""
    psi = s[0]
    tp = s[1]
    vp = s[2]
    if Tn0 > 0.0 and tp == tp and vp == vp:
        Ssig = 1.5 * T_stick - 0.5 * tp
        Zh = 1.5 * Z
        tnh = 1.5 * Tn1 - 0.5 * Tn0
        if tnh <= 0.0:
            tnh = Tn1  # Safeguard: a normal traction falling to zero within half a step
        vfix = 0.25 * abs(vp)
        gam = 0.75
    else:
        Ssig, Zh, tnh, vfix, gam = T_stick, Z, Tn1, 0.0, 1.0
    S = abs(Ssig)
    u0 = ln_rate(p, S, tnh, psi)  # first guess: the rate at the trial traction with the current state
    w, pe, Tabs, _, it = solve_rate(kind, p, psi, vfix, gam, 0.5 * dt, S, Zh, tnh, u0)
    vsig = sign(Ssig) * w
    Ts = T_stick - Z * vsig
    s[0] = state_end(kind, p, psi, w, dt)[0]
    s[1] = Ts
    s[2] = vsig
    ds = w * dt
    return Ts, w, ds, abs(Ts) * ds, max(it, 1)


@numba.njit(cache=True)
def slide(kind, p, s, v, Tn0, Tn1, dt):
    """Advance Ψ over dt at the imposed slip rate v (exact for constant v);
    return the strength μ(v, Ψ) T_n at the end."""
    s[0] = state_end(kind, p, s[0], v, dt)[0]
    return mu(p, v, s[0]) * Tn1


# --- plain-Python pieces: initial state and the continuous equations --------------------


def _lnsinh_py(z):
    if z > 20.0:
        return z - _LN2 + math.log1p(-math.exp(-2.0 * z))
    return math.log(math.sinh(z))


def psi_ss_py(kind, p, v):
    """Ψ_ss(V) from the equations (plain Python; V > 0)."""
    a, b = float(p[A]), float(p[B])
    if kind == AGING:
        return p[F0] + b * math.log(p[V0] / v)
    flv = max(p[F0] - (b - a) * math.log(v / p[V0]), 0.0)
    r = (v / p[V_W]) ** 8 if v < 1e30 * p[V_W] else math.inf
    fss = p[F_W] + (flv - p[F_W]) / (1.0 + r) ** 0.125
    return a * math.log(2.0 * p[V0] / v) + a * _lnsinh_py(fss / a)


def initial_state(kind, p, Tn0, Ts0):
    """Ψ such that |Ts0| = μ(V_ini, Ψ) Tn0 (TPV102):
    Ψ = a ln[(2 V0/V_ini) sinh(|Ts0|/(a Tn0))].  With no initial shear traction
    (or no normal traction) that state is −∞; then Ψ = Ψ_ss(V_ini), the steady
    state of sliding at V_ini (a contact aged at V_ini)."""
    a = p[A]
    if Ts0 != 0.0 and Tn0 > 0.0:
        return np.array([a * (math.log(2.0 * p[V0] / p[V_INI]) + _lnsinh_py(abs(Ts0) / (a * Tn0)))])
    return np.array([psi_ss_py(kind, p, p[V_INI])])


def _exp(x):
    """exp(x), +inf instead of an OverflowError (an ODE solver's trial point far
    outside the solution then fails its Newton iteration and retries shorter)."""
    return math.exp(x) if x < 709.0 else math.inf


def rates(kind, p, state, Ts, Tn):
    """The continuous equations (plain Python, from the formulas in the module
    docstring): V = 2 V0 sinh(|T_s|/(a T_n)) exp(−Ψ/a) and dΨ/dt."""
    a, b = float(p[A]), float(p[B])
    psi = float(state[0])
    if Tn <= 0.0:
        raise ValueError("rate-and-state rates: T_n must be > 0")
    z = abs(float(Ts)) / (a * Tn)
    v = _exp(math.log(2.0 * p[V0]) + _lnsinh_py(z) - psi / a) if z > 0.0 else 0.0
    if not math.isfinite(v):
        return v, np.array([math.nan])
    if kind == AGING:
        dpsi = b * p[V0] / p[L] * (_exp((p[F0] - psi) / b) - v / p[V0])
    elif v > 0.0:
        dpsi = -v / p[L] * (psi - psi_ss_py(SLIP, p, v))
    else:
        dpsi = 0.0  # V Ψ_ss(V) -> 0 as V -> 0
    return v, np.array([dpsi])
