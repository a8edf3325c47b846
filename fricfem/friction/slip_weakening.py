"""Linear slip-weakening Coulomb friction (Ida 1972; Andrews 1976), on the
elastic interface Ṫ_s = C_s (Δu̇_s − sgn(T_s) Δu̇_slip).

The friction coefficient falls linearly with the accumulated frictional slip δ::

    μ(δ) = μs − (μs − μd) min(δ, Dc) / Dc,        |T_s| <= μ(δ) T_n.

The defaults are those of the SCEC/USGS dynamic-rupture benchmarks
(TPV3/TPV5: μs = 0.677, μd = 0.525, Dc = 0.40 m) — a field-scale weakening
distance, to be scaled down for laboratory plates.

Time integration: an elastic predictor / plastic corrector (return map),
backward Euler in the slip.  With the trial T* = T_s + C_s Δu̇_s dt and
T_n = T_n(t + dt), if |T*| > μ(δ) T_n the slip dδ solves
|T*| − C_s dδ = μ(δ + dδ) T_n exactly (it is linear on each branch of μ).
"""

import numba
import numpy as np

from .base import Law, Param, frictional_work, param_index, sign

PARAMS = (
    Param("mu_s", 0.677, "", 0.0, 1e4, "static friction coefficient μs (a large value locks a barrier)"),
    Param("mu_d", 0.525, "", 0.0, 5.0, "dynamic friction coefficient μd (after slip Dc)"),
    Param("Dc", 0.40, "m", 1e-12, 100.0, "slip-weakening distance"),
)

# Parameter indices in the packed array, from PARAMS' names
MU_S, MU_D, DC = param_index(PARAMS, "mu_s", "mu_d", "Dc")

STATE = ("slip",)


@numba.njit(cache=True)
def mu(p, delta):
    """μ(δ) = μs − (μs − μd) min(δ, Dc)/Dc."""
    return p[MU_S] - (p[MU_S] - p[MU_D]) * min(delta, p[DC]) / p[DC]


@numba.njit(cache=True)
def steady_mu(p, v):
    """Coefficient after long sliding: μd for v > 0 (μs at rest)."""
    return p[MU_D] if v > 0.0 else p[MU_S]


def initial_state(p, Tn0, Ts0):
    """No slip yet: δ = 0."""
    return np.zeros(1)


@numba.njit(cache=True)
def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """Return map over one step (contract in :mod:`.base`); one sub-step, exact
    for the backward-Euler slip.  The slip rate returned is the step's mean
    dδ/dt (the law has no rate dependence)."""
    delta = s[0]
    Tt = Ts + Cs * vs * dt
    a = abs(Tt)
    if a <= mu(p, delta) * Tn1:
        return Tt, 0.0, 0.0, 0.0, 1
    w = (p[MU_S] - p[MU_D]) / p[DC]  # weakening rate dμ/dδ on the sloping branch
    dd = -1.0
    if Cs > Tn1 * w and delta < p[DC]:
        # sloping branch: a − C_s dδ = T_n (μ(δ) − w dδ)
        dd = (a - mu(p, delta) * Tn1) / (Cs - Tn1 * w)
        if delta + dd > p[DC]:
            dd = -1.0
    if dd < 0.0:
        # flat branch μ = μd.  Safeguard: when C_s <= T_n w the interface
        # spring is softer than the weakening (local snap-back); the point
        # then slips at once onto this branch.
        dd = max((a - p[MU_D] * Tn1) / Cs, 0.0)
    s[0] = delta + dd
    Ts1 = sign(Tt) * (a - Cs * dd)
    rate = dd / dt if dt > 0.0 else 0.0
    return Ts1, rate, dd, frictional_work(Ts, Ts1, dd), 1


@numba.njit(cache=True)
def slide(p, s, v, Tn0, Tn1, dt):
    """Slip at rate v for dt; strength μ(δ) T_n at the end."""
    s[0] += v * dt
    return mu(p, s[0]) * Tn1


@numba.njit(cache=True)
def rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """One step t^n → t^{n+1} of a rigid split-node pair (contract in
    :mod:`.base`), closed form.  The pair's traction is that of t^n, so its
    strength is μ(δ^n) T_n with δ^n the slip at t^n (Andrews 1999; Day et al.
    2005): the pair sticks (v = 0, T_s = T_stick) if |T_stick| <= μ(δ^n) T_n;
    otherwise |T_s| = μ(δ^n) T_n and v = (|T_stick| − μ(δ^n) T_n)/Z is the
    slip rate of the step, V^{n+½}; the slip at t^{n+1} is δ^n + v dt.
    Explicit in the slip, so no branch or snap-back case: the weakening
    enters one step later, through δ^{n+1}."""
    delta = s[0]
    a = abs(T_stick)
    strength = mu(p, delta) * Tn1  # at the slip of t^n, the time of the pair's traction
    if a <= strength:
        return T_stick, 0.0, 0.0, 0.0, 1
    v = (a - strength) / Z
    s[0] = delta + v * dt
    ds = v * dt
    return sign(T_stick) * strength, v, ds, strength * ds, 1


LAW = Law(
    name="slip_weakening",
    doc="linear slip-weakening Coulomb friction on the elastic interface",
    params=PARAMS,
    state=STATE,
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    slide=slide,
    rigid=rigid,  # no ``rates``: rate independent; exact references in .reference
)
