"""Regularized Dieterich–Ruina rate-and-state friction with the slip (Ruina)
state law, as in the SCEC benchmarks TPV103/104, on the elastic interface
Ṫ_s = C_s (Δu̇_s − sgn(T_s) V)::

    |T_s| = a asinh[ V/(2 V0) exp(Ψ/a) ] T_n
    dΨ/dt = −(V/L) [ Ψ − Ψ_ss(V) ]
    Ψ_ss(V) = a ln[ (2 V0/V) sinh(f_ss(V)/a) ]
    f_ss(V) = f_w + (f_LV(V) − f_w) / [1 + (V/V_w)^8]^(1/8),   f_LV(V) = f0 − (b − a) ln(V/V0)

These are TPV103's definitions.  Ψ_ss is defined so that μ(V, Ψ_ss(V)) =
f_ss(V) exactly: the regularized steady state is the logarithmic one (unlike
the aging law's, which is regularized).  With the default V_w = 10¹⁰ m/s the
strong-weakening factor [1 + (V/V_w)^8]^(1/8) equals 1 in double precision
for V < 10⁸ m/s, so the law is the plain slip law f_ss = f_LV; V_w = 0.1 m/s
and f_w = 0.2 give TPV103's strong rate weakening.  f_LV is floored at 0 (as
SeisSol does; only reached for V/V0 > exp(f0/(b − a))).

At constant V, Ψ relaxes to Ψ_ss(V) exponentially in *slip* over L.
Defaults as the aging law (:mod:`.rate_state_aging`).  Shared numerics and
integrators: :mod:`.rate_state`.
"""

import numba

from . import rate_state as rs
from .base import Law

PARAMS = rs.SLIP_PARAMS
STATE = rs.STATE
KIND = rs.SLIP


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
    """μ_ss(V) = f_ss(V), V > 0."""
    return rs.steady_mu_kind(KIND, p, v)


def initial_state(p, Tn0, Ts0):
    """Ψ with |Ts0| = μ(V_ini, Ψ) Tn0 (TPV102/103); Ψ_ss(V_ini) when Ts0 = 0."""
    return rs.initial_state(KIND, p, Tn0, Ts0)


def rates(p, state, Ts, Tn):
    """V and dΨ/dt from the equations (plain Python; for the scipy references)."""
    return rs.rates(KIND, p, state, Ts, Tn)


LAW = Law(
    name="rate_state_slip",
    doc="regularized rate-and-state friction, slip (Ruina) state law (SCEC TPV103/104 form)",
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
