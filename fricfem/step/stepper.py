"""The explicit central-difference step and the time loop, as two verbs.

With ``f = K u − F_int(u)`` (Belytschko et al. 1976; the paper's Newmark
β = 0, γ = ½ with lumped mass)

    v^{n+½} = v^{n−½} − dt M⁻¹ f(u^n),      u^{n+1} = u^n + dt v^{n+½},

and on the struck edge u1 = U(t) = ∫V prescribed (or a traction load).
:func:`step` does it in one sweep over the rows of K
(:class:`fricfem.step.fused.FusedBulk`); :func:`evolve` is the loop as a
generator, so that output stays apart from stepping.
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from ..kernels.reduce import dot3


def step(model, state, energy: dict | None = None) -> None:
    """Advance ``state`` by one step ``model.dt`` (collective).  If ``energy`` is
    a dict it is filled with the energies at t^n [J/m]: kinetic, strain,
    interface work/elastic/dissipated, external work, the energy the absorbing
    edges took out, and the balance error."""
    if energy is not None:
        v_old = state.v.array_r.copy()
    uku, work, absorbed = model.bulk.advance(state)
    state.u, state.u_next = state.u_next, state.u  # u^{n+1}; u^n's buffer takes the next output
    state.work_ext += work
    state.absorbed += absorbed
    if energy is not None:
        kinetic = 0.5 * dot3(model.mass, v_old, state.v.array_r)  # in a fixed order, not BLAS's (.kernels.reduce)
        loc = np.array([kinetic, state.work_ext, 0.5 * uku, state.absorbed])
        tot = np.zeros(4)
        model.comm.Allreduce(loc, tot, op=MPI.SUM)
        energy.update(model.interface.energy())
        energy.update(time=state.t, kinetic=tot[0], strain=tot[2], external=tot[1], absorbed=tot[3])
        energy["balance_error"] = (
            energy["kinetic"] + energy["strain"] + energy["interface_work"] + energy["absorbed"]
            - energy["external"]
        )
    state.t_interface = state.t
    state.t += model.dt
    state.n += 1


def evolve(model, state, t_end: float, energy_every: int = 0):
    """Step until ``t_end`` [s]; yields ``(state, energy or None)`` after every
    step, the energies every ``energy_every`` steps (0: never)."""
    n_end = int(math.floor(t_end / model.dt + 1e-9))
    while state.n < n_end:
        e = {} if energy_every and state.n % energy_every == 0 else None
        step(model, state, e)
        yield state, e
