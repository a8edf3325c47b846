"""Two interfaces in one step: the frictional interface and the projectile's
contact on the buffer (the experiment, :mod:`fricfem.model.bodies`).

:class:`WithContact` has the verbs of :class:`fricfem.step.interface.Interface`,
so the fused step (:class:`fricfem.step.fused.FusedBulk`) drives both as one:
the frictional interface advances as it always does; then the contact pairs
(a :class:`fricfem.step.interface.RigidInterface` with the frictionless
contact law) insert their forces into the frictional interface's ``right``
vector at their own dofs, which that interface never writes (the two sets of
nodes are disjoint), so each row still gets ``(K u) + left + right``.
Everything that reads the interface (recorder, observers, summary) sees the
frictional one: :attr:`initial`, :attr:`law` and :attr:`geometry` are its
(a state's ``points`` are the frictional interface's, its ``contact`` the contact's),
except that the geometry's force-slot scatter marks the contact's nodes as
interface rows too (their ``K u`` is kept and their update deferred).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


class _Marked:
    """The frictional interface's geometry, with a force-slot scatter ``to_left``
    (and no ``to_right``) that reaches the nodes of both interfaces: what
    :func:`fricfem.step.fused.interface_nodes` reads to find the interface rows."""

    def __init__(self, geometry, force: PETSc.Vec, to_left):
        self._geometry = geometry
        self.force = force
        self.to_left = to_left
        self.to_right = None

    def __getattr__(self, name):
        return getattr(self._geometry, name)


class WithContact:
    """The frictional interface ``friction`` and the contact ``contact`` (a rigid
    pair interface whose forces go into ``friction.geometry.right``), as one
    interface.  ``blocks``: global dof blocks of every node either interface
    handles on this rank; ``template`` a vector with the displacement's layout."""

    needs_ku = True  # the contact pairs' trial velocities need K u at their nodes

    def __init__(self, friction, contact, blocks, template: PETSc.Vec):
        self.friction = friction
        self.contact = contact
        self.initial = friction.initial
        self.law = friction.law
        self.slot = friction.slot
        n = len(blocks)
        force = PETSc.Vec().createSeq(2 * n, comm=PETSc.COMM_SELF)
        src = PETSc.IS().createGeneral(np.arange(2 * n, dtype=PETSc.IntType), comm=PETSc.COMM_SELF)
        dofs = (2 * np.asarray(blocks, dtype=np.int64)[:, None] + np.arange(2)[None, :]).ravel()
        dst = PETSc.IS().createGeneral(dofs.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
        self.geometry = _Marked(friction.geometry, force, PETSc.Scatter().create(force, src, template, dst))

    def fresh_points(self) -> dict:
        """A run's own points of both interfaces, by the state's attribute."""
        return {**self.friction.fresh_points(), **self.contact.fresh_points()}

    def begin_gather(self, u: PETSc.Vec) -> None:
        self.friction.begin_gather(u)

    def advance(self, state, u: PETSc.Vec, dt: float, started: bool = False, v=None, ku=None,
                v_edge: float = 0.0) -> tuple:
        """Advance the frictional interface, then the contact (whose forces land in
        the frictional interface's ``right`` vector); returns (left, right) as
        :meth:`fricfem.step.interface.Interface.advance` does.  Collective."""
        left, right = self.friction.advance(state, u, dt, started=started, v=v, ku=ku, v_edge=v_edge)
        self.contact.advance(state, u, dt, v=v, ku=ku)
        return left, right

    def add_forces(self, state, u: PETSc.Vec, f: PETSc.Vec, dt: float, v=None, v_edge: float = 0.0) -> None:
        """:meth:`advance` with ``f`` = K u, then ``f += left`` and ``f += right`` (the two-pass form)."""
        self.advance(state, u, dt, v=v, ku=f, v_edge=v_edge)
        g = self.friction.geometry
        f.axpy(1.0, g.left)
        f.axpy(1.0, g.right)

    def add_spring_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """The frictional interface's springs (the contact has none)."""
        self.friction.add_spring_action(x, y)

    def energy(self, state) -> dict:
        """Both interfaces' energies [J/m] of ``state``, summed over all ranks: the
        contact's work and dissipation are added to the frictional interface's."""
        e, c = self.friction.energy(state), self.contact.energy(state)
        return {k: e[k] + c[k] for k in e}

    def contact_energy(self, state) -> dict:
        """The contact's own energies [J/m] (work done on it, energy lost in its closings)."""
        return self.contact.energy(state)


def contact_force(contact, state) -> float:
    """The total force the projectile exerts on the buffer now [N/m], summed over all ranks."""
    p, g = getattr(state, contact.slot), contact.geometry
    loc = float((p.Tn * g.wq).sum())
    return g.comm.allreduce(loc, op=MPI.SUM)
