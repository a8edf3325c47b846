"""The interface in the time loop: gather the displacements its points need,
advance every point with the law's kernel, add the forces back (collective).

The data (geometry, exchange, points) is :mod:`fricfem.model.interface`; the
numba loop :mod:`fricfem.kernels.interface`.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..kernels.cache import ensure_fresh
from ..kernels.interface import first_call, kernel_for, rigid_kernel_for, spring_kernel
from ..kernels.reduce import dot


def freeze(data, keep=()):
    """Mark ``data`` (an array, or a NamedTuple's numpy arrays but those named in
    ``keep``) read-only: the model's arrays a step only reads.  Returns ``data``."""
    if isinstance(data, np.ndarray):
        data.setflags(write=False)
        return data
    for name, a in zip(data._fields, data):
        if isinstance(a, np.ndarray) and name not in keep:
            a.setflags(write=False)
    return data


class Interface:
    """Interface geometry, the initial point data and the friction law, with the
    verbs the time loop needs: :meth:`begin_gather`, :meth:`advance` (and its
    two-pass form :meth:`add_forces`), :meth:`add_spring_action` and :meth:`energy`.

    Part of the model, so read-only in a run: the points a step changes are the
    state's (``state.points``, or the state's attribute named :attr:`slot`; made
    by :meth:`fresh_points`); :attr:`initial` holds their constants and initial
    values, every array read-only.  The PETSc work vectors of the geometry are
    scratch, written before they are read in every step."""

    def __init__(self, geometry, points, law, slot: str = "points"):
        """``geometry`` and ``points``: :mod:`fricfem.model.interface` (Geometry, Points);
        ``law``: a :class:`fricfem.friction.Law`; ``slot``: the attribute of a
        :class:`fricfem.step.state.State` that holds this interface's points."""
        self.geometry = geometry
        self.initial = points.frozen()
        self.law = law
        self.slot = slot
        ensure_fresh()  # numba's disk cache matches the sources (fricfem.kernels.cache)
        self.kernel = kernel_for(law)
        self._compiled = False  # the kernel's first call compiles (or loads) it
        freeze(geometry)
        self._geom = (freeze(np.hstack([geometry.seg_w, geometry.seg_f])), geometry.shape, geometry.wq)  # plain tuples
        self._const = self.initial.kernel_const()

    def fresh_points(self) -> dict:
        """A run's own points, by the state's attribute: ``{slot: Points}``."""
        return {self.slot: self.initial.fresh()}

    def _gather(self, u: PETSc.Vec) -> np.ndarray:
        g = self.geometry
        g.scatter.scatter(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
        return g.work.array

    def _send(self) -> None:
        """The segments' force slots to the nodes' owners (``geometry.left`` and ``right``)."""
        g = self.geometry
        insert, forward = PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD
        g.to_right.begin(g.force, g.right, insert, forward)
        g.to_left.begin(g.force, g.left, insert, forward)
        g.to_right.end(g.force, g.right, insert, forward)
        g.to_left.end(g.force, g.left, insert, forward)

    def begin_gather(self, u: PETSc.Vec) -> None:
        """Start gathering the displacements ``u`` the interface needs (from other
        ranks too); :meth:`advance` with ``started=True`` ends it."""
        g = self.geometry
        g.scatter.begin(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)

    needs_ku = False  # the elastic interface needs only the displacements

    def advance(self, state, u: PETSc.Vec, dt: float, started: bool = False, v=None, ku=None, v_edge=0.0) -> tuple:
        """Advance every interface point of ``state`` to the end of the step whose end
        displacement is ``u``; returns the owned arrays (left, right) of the
        *negative* interface forces at each node from the segment on its left
        and on its right (a node's force is ``left + right``, in that order).
        ``started``: :meth:`begin_gather` was called with ``u``.  Collective."""
        g = self.geometry
        if started:
            g.scatter.end(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
            w = g.work.array
        else:
            w = self._gather(u)
        pts = getattr(state, self.slot).kernel_state()
        if self._compiled:
            self.kernel(w, g.force.array, self._geom, self._const, pts, dt)
        else:  # compiles or loads the law's kernel; numba's cache warning caught there
            first_call(self.kernel, w, g.force.array, self._geom, self._const, pts, dt)
            self._compiled = True
        self._send()
        return g.left.array_r, g.right.array_r

    def add_forces(self, state, u: PETSc.Vec, f: PETSc.Vec, dt: float, v=None) -> None:
        """:meth:`advance`, then ``f += left`` and ``f += right`` (the two-pass form;
        ``f`` holds K u)."""
        self.advance(state, u, dt, v=v, ku=f)
        f.axpy(1.0, self.geometry.left)
        f.axpy(1.0, self.geometry.right)

    def add_spring_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """``y += K_int x`` with the elastic interface springs."""
        g, p = self.geometry, self.initial
        w = self._gather(x)
        spring_kernel(w, g.force.array, self._geom, p.Cn, p.Cs)
        self._send()
        y.axpy(1.0, g.left)
        y.axpy(1.0, g.right)

    def energy(self, state) -> dict:
        """Interface energies per unit thickness [J/m] of ``state``, summed over all ranks."""
        p, g = getattr(state, self.slot), self.geometry
        closed = p.is_open == 0
        elastic = np.where(closed, 0.5 * p.Cn * p.jump_n**2, 0.0)
        elastic += np.where(p.Cs > 0, 0.5 * (p.Ts - p.Ts0) ** 2 / np.where(p.Cs > 0, p.Cs, 1.0), 0.0)
        loc = np.array([dot(g.wq, p.work), dot(g.wq, elastic), dot(g.wq, p.dissipated)])  # fixed order, not BLAS
        tot = np.zeros(3)
        g.comm.Allreduce(loc, tot, op=MPI.SUM)
        return {"interface_work": tot[0], "interface_elastic": tot[1], "dissipated": tot[2]}


class RigidInterface:
    """The rigid (split-node) interface: the traction of each node pair follows
    from the pair's trial velocities and the law's ``rigid`` verb
    (:func:`fricfem.kernels.interface.advance_pairs`); no interface spring, so
    the stable step is the bulk's.  The same verbs as :class:`Interface`;
    the points are the node pairs (:class:`fricfem.model.interface.PairGeometry`)."""

    needs_ku = True  # the pairs' trial velocities need K u at their nodes

    def __init__(self, geometry, points, law, slot: str = "points"):
        ensure_fresh()  # numba's disk cache matches the sources (fricfem.kernels.cache)
        self.geometry = geometry
        self.initial = points.frozen()
        self.law = law
        self.slot = slot
        self.kernel = rigid_kernel_for(law)
        freeze(geometry, keep=("edge",))
        self._pgeom = (geometry.mass, geometry.wq, geometry.edge)  # edge[-1]: scratch, this step's v_edge
        self._const = self.initial.kernel_const()
        self._compiled = False

    def fresh_points(self) -> dict:
        """A run's own points (pairs), by the state's attribute: ``{slot: Points}``."""
        return {self.slot: self.initial.fresh()}

    def begin_gather(self, u: PETSc.Vec) -> None:
        """Start gathering the pairs' displacements; :meth:`advance` ends it."""
        g = self.geometry
        g.scatter.begin(u, g.work_u, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)

    def advance(self, state, u: PETSc.Vec, dt: float, started: bool = False, v=None, ku=None,
                v_edge: float = 0.0) -> tuple:
        """Advance every pair of ``state`` over the step from u^n, v^{n−½} and ``ku`` = K u^n
        (at least at the interface nodes), the struck edge moving at ``v_edge``
        along x1 over the step; returns the owned arrays (left, right) of the
        negative nodal forces (right is zero: one pair a node).  Collective."""
        g = self.geometry
        g.edge[-1] = v_edge
        insert, forward = PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD
        if started:
            g.scatter.end(u, g.work_u, insert, forward)
        else:
            g.scatter.scatter(u, g.work_u, insert, forward)
        g.scatter.scatter(v, g.work_v, insert, forward)
        g.scatter.scatter(ku, g.work_k, insert, forward)
        args = (g.work_u.array, g.work_v.array, g.work_k.array, g.force.array, self._pgeom, self._const,
                getattr(state, self.slot).kernel_state(), dt)
        if self._compiled:
            self.kernel(*args)
        else:
            first_call(self.kernel, *args)  # see Interface.advance
            self._compiled = True
        g.to_left.scatter(g.force, g.left, insert, forward)
        return g.left.array_r, g.right.array_r

    def add_forces(self, state, u: PETSc.Vec, f: PETSc.Vec, dt: float, v=None, v_edge: float = 0.0) -> None:
        """:meth:`advance` with ``f`` = K u, then ``f += left`` (the two-pass form)."""
        self.advance(state, u, dt, v=v, ku=f, v_edge=v_edge)
        f.axpy(1.0, self.geometry.left)

    def add_spring_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """No interface spring: nothing to add (the stable step is the bulk's)."""

    def energy(self, state) -> dict:
        """Interface energies per unit thickness [J/m] of ``state``, summed over all ranks
        (a rigid contact stores none)."""
        p, g = getattr(state, self.slot), self.geometry
        loc = np.array([dot(g.wq, p.work), 0.0, dot(g.wq, p.dissipated)])  # fixed order, not BLAS
        tot = np.zeros(3)
        g.comm.Allreduce(loc, tot, op=MPI.SUM)
        return {"interface_work": tot[0], "interface_elastic": tot[1], "dissipated": tot[2]}
