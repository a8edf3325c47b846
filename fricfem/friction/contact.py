"""Unilateral frictionless contact: the law of the projectile's face on the
steel buffer in the experiment (:mod:`fricfem.model.bodies`).

On the rigid split-node pairs (:func:`fricfem.kernels.interface.advance_pairs`)
the normal traction closes the gap, only in compression (the pair separates
when the traction would pull), and this law sets the shear traction to zero:
the two faces slide freely.  It is not a friction law a scene chooses
(it is not in the registry); on the elastic interface it would be the same
frictionless contact (``advance``: T_s = 0, all of the jump rate is slip).
"""

import numba
import numpy as np

from .base import Law


@numba.njit(cache=True)
def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """No shear traction; the whole tangential jump rate is slip (no work: T_s = 0)."""
    return 0.0, abs(vs), abs(vs) * dt, 0.0, 1


@numba.njit(cache=True)
def steady_mu(p, v):
    return 0.0


def initial_state(p, Tn0, Ts0):
    return np.zeros(0)


@numba.njit(cache=True)
def rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """A closed pair carries no shear traction: T_s = 0 whatever the trial traction
    T_stick (the slip rate |T_stick|/Z is the pair's tangential jump rate; no
    work is done by a zero traction)."""
    v = abs(T_stick) / Z
    return 0.0, v, v * dt, 0.0, 1


LAW = Law(
    name="frictionless_contact",
    doc="unilateral frictionless contact: compression only, zero shear traction",
    params=(),
    state=(),
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    rigid=rigid,
)
