"""Regularized Dieterich–Ruina rate-and-state friction with the aging
(Dieterich) state law, as in the SCEC benchmark TPV102 (TPV101 without the
regularization), on the elastic interface Ṫ_s = C_s (Δu̇_s − sgn(T_s) V)::

    |T_s| = a asinh[ V/(2 V0) exp(Ψ/a) ] T_n
    dΨ/dt = (b V0/L) [ exp((f0 − Ψ)/b) − V/V0 ]

Steady state: Ψ_ss = f0 − b ln(V/V0), μ_ss(V) = a asinh[V/(2V0) exp(Ψ_ss/a)]
(≈ f0 + (a − b) ln(V/V0) once V ≫ V0 exp(−f0/a)).  At constant V the state
φ = exp((Ψ − f0)/b) relaxes exponentially in *time* to V0/V with the time
constant L/V (Dieterich's θ = φ L/V0, dθ/dt = 1 − Vθ/L).

Defaults: TPV102's velocity-weakening values a = 0.008, b = 0.012,
V0 = 1 µm/s, f0 = 0.6, V_ini = 10⁻¹² m/s, with a laboratory-scale L = 1 µm
(TPV102 uses 0.02 m for a fault).  Velocity-strengthening regions (a > b)
are set with ``friction.regions``.  The slip rate is never zero while
T_s ≠ 0.  Shared numerics and the integrators: :mod:`.rate_state`.
"""

import numba

from . import rate_state as rs
from .base import Law

PARAMS = rs.COMMON_PARAMS
STATE = rs.STATE
KIND = rs.AGING


@numba.njit(cache=True)
def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """One bulk step on the elastic interface (contract in :mod:`.base`)."""
    return rs.advance(KIND, p, s, Ts, Tn0, Tn1, vs, Cs, dt)


@numba.njit(cache=True)
def rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """One step of a rigid split-node pair (contract in :mod:`.base`): second
    order, the law at the middle of the step (:func:`.rate_state.rigid`)."""
    return rs.rigid(KIND, p, s, T_stick, Z, Tn0, Tn1, dt)


@numba.njit(cache=True)
def slide(p, s, v, Tn0, Tn1, dt):
    """Imposed slip rate v: exact state update for constant v; returns μ(v, Ψ) T_n."""
    return rs.slide(KIND, p, s, v, Tn0, Tn1, dt)


@numba.njit(cache=True)
def steady_mu(p, v):
    """μ_ss(V) = a asinh[V/(2 V0) exp((f0 − b ln(V/V0))/a)], V > 0."""
    return rs.steady_mu_kind(KIND, p, v)


def initial_state(p, Tn0, Ts0):
    """Ψ with |Ts0| = μ(V_ini, Ψ) Tn0 (TPV102); Ψ_ss(V_ini) when Ts0 = 0."""
    return rs.initial_state(KIND, p, Tn0, Ts0)


def rates(p, state, Ts, Tn):
    """V and dΨ/dt from the equations (plain Python; for the scipy references)."""
    return rs.rates(KIND, p, state, Ts, Tn)


LAW = Law(
    name="rate_state_aging",
    doc="regularized rate-and-state friction, aging (Dieterich) state law (SCEC TPV102)",
    params=PARAMS,
    state=STATE,
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    slide=slide,
    rates=rates,
    rigid=rigid,
    memo=rs.MEMO,
)
