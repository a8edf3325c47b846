"""The equations of Povirk–Needleman rate- and state-dependent friction with Prakash–Clifton
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

The law's equations are here; how a point is integrated over a bulk step
(``advance``, ``rigid``) is :mod:`.povirk_needleman_integrator`; the law
record (``LAW``) and its interface kernel are :mod:`.povirk_needleman`.
"""

import math

import numba
import numpy as np

from .base import Param, param_index

PARAMS = (
    Param("mu_s", 0.6, "", 0.0, 1e4, "static friction coefficient μs (a large value locks a barrier)"),
    Param("mu_d", 0.5, "", 1e-3, 5.0, "dynamic friction coefficient μd (> 0: at μd = 0 the strength g(θ0) "
                                      "vanishes at fast slip and the slip rate is unbounded)"),
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

# Parameter indices in the packed array ``p``, from PARAMS' names
MU_S, MU_D, V0, V1, B, P, M, L0, L1, L2, C, D, THETA0_INIT, GAMMA, SUB_TOL, SUB_STIFF = param_index(
    PARAMS, "mu_s", "mu_d", "V0", "V1", "B", "p", "m", "L0", "L1", "L2", "C", "D", "theta0_init", "gamma",
    "substep_tol", "substep_stiff")

STATE = ("theta0", "theta1", "theta2")

# Storage per point: the three state variables, then a memo of the last
# strength evaluated, G = g(θ0)(θ1 + θ2), with the θ0 and θ1 + θ2 it belongs to,
# then the rigid verb's previous traction T^{n−1} and slip rate V^{n−½}
# (NaN: none); see :mod:`.povirk_needleman_integrator`.
N_STORAGE = 8  # len(STATE) + the memo


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


def _g_plain(p, th0):
    """g(θ0) = [μd + (μs − μd) exp(−(L0/(θ0 V1))^p)] / [L0/(θ0 V0) + 1]^(1/m), plain Python."""
    if not th0 > 0.0:
        return math.nan  # outside the law's domain (an ODE solver's trial point): let it retry
    mu_star = p[MU_D] + (p[MU_S] - p[MU_D]) * math.exp(-((p[L0] / (th0 * p[V1])) ** p[P]))
    return mu_star / (p[L0] / (th0 * p[V0]) + 1.0) ** (1.0 / p[M])


def rates(p, state, Ts, Tn, branch=None):
    """The paper's equations (plain Python): v = V0(β^m − 1) for β > 1, else 0,
    β = |T_s| / (g(θ0)(θ1 + θ2)); θ̇0 = B(1 − θ0 v/L0),
    θ̇1 = −(θ1 − C T_n) v/L1, θ̇2 = −(θ2 − D T_n) v/L2.

    ``branch="slide"``: v = V0(β^m − 1) whatever β (negative below the
    strength: the smooth continuation the references use to locate the
    stick/slip switch); ``branch="stick"``: v = 0.
    """
    th0, th1, th2 = (float(x) for x in state)
    G = _g_plain(p, th0) * (th1 + th2)
    if branch == "stick":
        v = 0.0
    else:
        if G <= 0.0:
            raise ValueError("povirk_needleman rates: no strength (θ1 + θ2 <= 0)")
        v = p[V0] * ((abs(Ts) / G) ** p[M] - 1.0)
        if branch is None and v < 0.0:
            v = 0.0  # stick: β <= 1
    return v, np.array([
        p[B] * (1.0 - th0 * v / p[L0]),
        -(th1 - p[C] * Tn) * v / p[L1],
        -(th2 - p[D] * Tn) * v / p[L2],
    ])
