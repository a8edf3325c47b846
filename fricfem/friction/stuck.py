"""A perfectly stuck elastic interface: Ṫ_s = C_s Δu̇_s, no frictional slip.

The Povirk–Needleman elastic interface with infinite strength; the reference
for wave-propagation and energy tests of the bulk/interface coupling.
"""

import numba
import numpy as np

from .base import Law


@numba.njit(cache=True)
def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    return Ts + Cs * vs * dt, 0.0, 0.0, 0.0, 1


@numba.njit(cache=True)
def steady_mu(p, v):
    return np.inf


def initial_state(p, Tn0, Ts0):
    return np.zeros(0)


@numba.njit(cache=True)
def rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """The rigid split-node pair never slips: T_s = T_stick, v = 0."""
    return T_stick, 0.0, 0.0, 0.0, 1


LAW = Law(
    name="stuck",
    doc="elastic interface that never slides (Ṫ_s = C_s Δu̇_s)",
    params=(),
    state=(),
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    rigid=rigid,
)
