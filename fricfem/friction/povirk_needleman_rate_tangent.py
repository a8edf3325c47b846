"""The Povirk–Needleman law integrated as the paper does: one plain
rate-tangent update per bulk step (Peirce, Shih & Needleman 1984; the paper's
Appendix, steps 3–7), for comparison with fricfem's converged integration.

The law itself — parameters, state θ0, θ1, θ2, initial state, steady-state
μ_ss(v) and the slip-driven ``slide`` — is :mod:`.povirk_needleman`'s; only
``advance`` differs: :func:`rate_tangent_advance` (below), with no
sub-steps, no located onset of slip and no implicit solve.  The paper's
automatic step control is not reproduced: the step is the bulk's.  Where this
update is unstable (slip rates of hundreds of m/s at a 20–100 ns step,
docs/friction.md) θ0 turns negative and the values non-finite, and the
watchdog stops the run.  ``gamma``, ``substep_tol`` and ``substep_stiff`` keep their names;
only ``gamma`` (the rate-tangent parameter γ) is read.

    friction.law = "povirk_needleman_rate_tangent"
"""

import numba

from . import povirk_needleman_equations as pn
from .base import Law, frictional_work, sign
from .povirk_needleman_equations import B, C, D, GAMMA, L0, L1, L2, M, V0, g_and_dg, slip_rate


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


LAW = Law(
    name="povirk_needleman_rate_tangent",
    doc="the Povirk–Needleman law with the paper's plain rate-tangent update, one per bulk step "
    "(for comparison; unstable at large slip rates)",
    params=pn.PARAMS,
    state=pn.STATE,
    advance=rate_tangent_advance,
    steady_mu=pn.steady_mu,
    initial_state=pn.initial_state,
    slide=pn.slide,
)
