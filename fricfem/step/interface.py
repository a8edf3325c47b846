"""The interface in the time loop: gather the displacements its points need,
advance every point with the law's kernel, add the forces back (collective).

The data (geometry, exchange, points) is :mod:`fricfem.model.interface`; the
numba loop :mod:`fricfem.kernels.interface`.
"""

from __future__ import annotations

import warnings

import numpy as np
from mpi4py import MPI
from numba.core.errors import NumbaExperimentalFeatureWarning
from petsc4py import PETSc

from ..kernels.cache import ensure_fresh
from ..kernels.interface import kernel_for, spring_kernel



class Interface:
    """Interface geometry, point data and the friction law, with the verbs the
    time loop needs: :meth:`begin_gather`, :meth:`advance` (and its two-pass
    form :meth:`add_forces`), :meth:`add_spring_action` and :meth:`energy`."""

    def __init__(self, geometry, points, law):
        """``geometry`` and ``points``: :mod:`fricfem.model.interface` (Geometry, Points);
        ``law``: a :class:`fricfem.friction.Law`."""
        self.geometry = geometry
        self.points = points
        self.law = law
        ensure_fresh()  # numba's disk cache matches the sources (fricfem.kernels.cache)
        self.kernel = kernel_for(law)
        self._compiled = False  # the kernel's first call compiles (or loads) it
        self._geom = (np.hstack([geometry.seg_w, geometry.seg_f]), geometry.shape, geometry.wq)  # plain tuples
        self._const = points.kernel_const()
        self._state = points.kernel_state()

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

    def advance(self, u: PETSc.Vec, dt: float, started: bool = False) -> tuple:
        """Advance every interface point to the end of the step whose end
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
        if self._compiled:
            self.kernel(w, g.force.array, self._geom, self._const, self._state, dt)
        else:
            with warnings.catch_warnings():
                # numba types the law's ``advance`` handed to the shared kernel body as a
                # first-class function and warns that the feature is experimental; it is
                # resolved at compile time here (kernels.interface.specialise)
                warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
                self.kernel(w, g.force.array, self._geom, self._const, self._state, dt)
            self._compiled = True
        self._send()
        return g.left.array_r, g.right.array_r

    def add_forces(self, u: PETSc.Vec, f: PETSc.Vec, dt: float) -> None:
        """:meth:`advance`, then ``f += left`` and ``f += right`` (the two-pass form)."""
        self.advance(u, dt)
        f.axpy(1.0, self.geometry.left)
        f.axpy(1.0, self.geometry.right)

    def add_spring_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """``y += K_int x`` with the elastic interface springs."""
        g, p = self.geometry, self.points
        w = self._gather(x)
        spring_kernel(w, g.force.array, self._geom, p.Cn, p.Cs)
        self._send()
        y.axpy(1.0, g.left)
        y.axpy(1.0, g.right)

    def energy(self) -> dict:
        """Interface energies per unit thickness [J/m], summed over all ranks."""
        p, g = self.points, self.geometry
        closed = p.is_open == 0
        elastic = np.where(closed, 0.5 * p.Cn * p.jump_n**2, 0.0)
        elastic += np.where(p.Cs > 0, 0.5 * (p.Ts - p.Ts0) ** 2 / np.where(p.Cs > 0, p.Cs, 1.0), 0.0)
        loc = np.array([np.dot(g.wq, p.work), np.dot(g.wq, elastic), np.dot(g.wq, p.dissipated)])
        tot = np.zeros(3)
        g.comm.Allreduce(loc, tot, op=MPI.SUM)
        return {"interface_work": tot[0], "interface_elastic": tot[1], "dissipated": tot[2]}
