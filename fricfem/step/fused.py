"""The bulk step in one pass over the stiffness: K u, the interface forces, the
struck edge and the central-difference update together.

With ``f = K u^n − F_int(u^n)`` the explicit central-difference step is

    v^{n+½} = v^{n−½} − dt M⁻¹ f(u^n),      u^{n+1} = u^n + dt v^{n+½}.

Row ``i`` of the update needs only row ``i`` of ``K u^n``, so one sweep over
the rows of ``K`` computes ``s_i = Σ_j K_ij u^n_j`` and at once updates
``v_i`` and ``u^{n+1}_i``: the matrix and each vector are read once, instead
of a product ``K u`` followed by a separate update pass.  The new displacement
goes into a second buffer (later rows still read u^n); the caller swaps the
two buffers.

Storage.  The P1 vector space interleaves the two components of a node
(dof ``2 I + c``), so ``K`` is made of 2×2 blocks, kept as block CSR (one
column index per block, a quarter of the scalar CSR's).  The few hundred rows
that need more than the plain update are listed once, sorted ("special"):

* struck-edge nodes: u1 is prescribed, ``u1 = U(t^{n+1})``, with the half-step
  velocity ``(U(t^{n+1}) − U(t^n))/dt``, and the reaction ``R^n = M a^n + f^n``
  does the work ``R^n (u^{n+1} − u^{n−1})/2``, as the two-pass step
  (``tests/reference/two_pass.py``) has it (or, for a traction load, the edge force
  enters the update; see :func:`_special_update`);
* interface nodes: a short pre-pass keeps ``K u^n`` at these rows, and
  :meth:`fricfem.step.interface.Interface.advance` delivers the negative
  interface forces from the segment on each node's left and on its right;
* MPI boundary nodes: rows with columns owned by another rank, whose
  off-rank displacements come through one more PETSc scatter.

Order of a step::

    begin gathering the off-rank displacements, and the interface's
    sweep every row but the interface and MPI boundary rows ("deferred")
    end the gather of off-rank displacements (it travelled during the sweep)
    pre-pass; Interface.advance (end its gather, kernel, send the force slots)
    update the deferred rows

The sweep leaves u^n in place, so the interface works after it on the same
u^n, and both gathers travel while the rows are swept.

Round-off.  K's entries are summed over their cells in the grid's order, each
row of ``K u`` over its blocks in the grid's node order, and an interface
row's force is ``(K u) + left + right`` in that order
(:mod:`fricfem.model.numbering`): every number the step makes has the same
bits on any number of ranks (tested on 1 and 2 ranks in the suite, 1 to 4 in
``benchmarks/rank_reproducibility.py``).  Only ``u · K u`` (energy) and the
reaction work are summed across ranks in another order.

The numba kernels are :mod:`fricfem.kernels.bulk`; here is what builds their
data once (:func:`block_rows`, :func:`special_nodes`) and :class:`FusedBulk`,
whose one verb :meth:`FusedBulk.advance` moves a :class:`fricfem.step.state.State`.
"""

from __future__ import annotations

import copy
import time
from typing import NamedTuple

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..kernels import bulk
from ..kernels import sem as sem_kernels
from ..kernels.cache import ensure_fresh

class BlockRows(NamedTuple):
    """This rank's rows of ``K`` as block CSR with 2×2 blocks.

    ptr    uint32[n_nodes + 1]  block-row pointers (owned nodes)
    col    uint32[n_blocks]     block column: an owned node ``< n_nodes``, or
                                ``n_nodes + k`` for the k-th gathered off-rank node;
                                in grid order within a row (the order of the sums)
    val    float64[4 n_blocks]  (K_00, K_01, K_10, K_11) of each block [N/m², per m thickness]
    ghost  int64[n_ghost]       global block index of each gathered off-rank node (grid order)

    The indices are unsigned so that numba's gathers ``x[2 col[p]]`` carry no
    negative-index wrap-around test: that alone makes the sweep ~1.5× faster.
    """

    ptr: np.ndarray
    col: np.ndarray
    val: np.ndarray
    ghost: np.ndarray


class Special(NamedTuple):
    """Nodes whose update needs more than the plain row (this rank, sorted).

    node       int32[n + 1]  owned node index, then the sentinel ``n_nodes``
    impact     int32[n]      index of the node's x1 dof in the struck-edge arrays, or −1
    deferred   int8[n]       1: updated after the main sweep (interface rows, and MPI
                             boundary rows, which wait for the off-rank displacements)
    preloaded  int8[n]       1: an interface row (K u kept by the pre-pass, the
                             interface's forces added)
    damped     int32[n]      index of the node in the dashpot arrays, or −1
    """

    node: np.ndarray
    impact: np.ndarray
    deferred: np.ndarray
    preloaded: np.ndarray
    damped: np.ndarray


def block_rows(num, rows) -> BlockRows:
    """Block CSR of this rank's rows from the canonical rows of
    :func:`fricfem.model.assembly.canonical_rows` (columns in grid order)."""
    ptr, cols, vals = rows
    n = num.n_owned
    local = num.block_of_node[cols]
    owned = (local >= 0) & (local < n)
    ghost_nodes = np.unique(cols[~owned])
    if len(cols) >= 2**32:
        raise ValueError(f"fused: {len(cols)} blocks on one rank; at most 2**32 - 1 are supported")
    col = np.empty(len(cols), dtype=np.uint32)
    col[owned] = local[owned]
    col[~owned] = n + np.searchsorted(ghost_nodes, cols[~owned])
    return BlockRows(np.asarray(ptr, dtype=np.uint32), col, np.ascontiguousarray(vals.ravel()),
                     num.global_block[ghost_nodes])


def identity_rows(n: int, ghost) -> BlockRows:
    """The identity as block rows of ``n`` owned nodes (spectral elements: the
    sweep then passes K u^n, computed matrix-free, through); ``ghost`` the global
    blocks of the off-rank nodes the elements need (gathered each step)."""
    return BlockRows(np.arange(n + 1, dtype=np.uint32), np.arange(n, dtype=np.uint32),
                     np.tile(np.array([1.0, 0.0, 0.0, 1.0]), n), np.asarray(ghost, dtype=np.int64))


def interface_nodes(interface, template: PETSc.Vec) -> np.ndarray:
    """Owned nodes (local indices) that receive interface forces: ones sent
    through the interface's force slots mark them."""
    if interface is None:
        return np.zeros(0, dtype=np.int64)
    geom = interface.geometry
    ones = geom.force.duplicate()
    ones.set(1.0)
    marks = []
    for scatter in (getattr(geom, "to_right", None), geom.to_left):
        if scatter is None:  # a rigid interface: one slot a node
            continue
        mark = template.duplicate()
        mark.set(0.0)
        scatter.scatter(ones, mark, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
        marks.append(np.flatnonzero(mark.array_r) // 2)
    return np.unique(np.concatenate(marks))


def _has_off_rank(rows: BlockRows, nodes: np.ndarray, n_nodes: int) -> np.ndarray:
    """bool[len(nodes)]: the node's row has off-rank columns."""
    row_of_block = np.repeat(np.arange(n_nodes), np.diff(rows.ptr.astype(np.int64)))
    return np.isin(nodes, row_of_block[rows.col >= n_nodes])


def special_nodes(rows: BlockRows, impact_dofs: np.ndarray, iface_nodes: np.ndarray,
                  damped_nodes=np.zeros(0, dtype=np.int64)) -> Special:
    """Merge the interface, struck-edge (x1 dofs: even local indices), dashpot
    and MPI boundary nodes."""
    impact_dofs = np.asarray(impact_dofs, dtype=np.int64)
    if (impact_dofs % 2).any():
        raise ValueError("fused: the prescribed dofs must be x1 components (even local indices)")
    n_nodes = len(rows.ptr) - 1
    bnd = np.flatnonzero(_has_off_rank(rows, np.arange(n_nodes), n_nodes))
    imp = impact_dofs // 2
    damped_nodes = np.asarray(damped_nodes, dtype=np.int64)
    node = np.unique(np.concatenate([iface_nodes, imp, bnd, damped_nodes]).astype(np.int64))
    impact = np.full(len(node), -1, dtype=np.int32)
    impact[np.searchsorted(node, imp)] = np.arange(len(imp), dtype=np.int32)
    damped = np.full(len(node), -1, dtype=np.int32)
    damped[np.searchsorted(node, damped_nodes)] = np.arange(len(damped_nodes), dtype=np.int32)
    on_interface = np.isin(node, iface_nodes)
    deferred = (on_interface | np.isin(node, bnd)).astype(np.int8)
    preloaded = on_interface.astype(np.int8)
    return Special(np.append(node, n_nodes).astype(np.int32), impact, deferred, preloaded, damped)


def _edge(impact) -> tuple:
    """The struck edge's arrays for the kernels: (masses, traction force and damping
    coefficients; the last two empty for a prescribed velocity)."""
    traction = not impact.pulse.prescribed and len(impact.force) == len(impact.dofs)
    return (np.ascontiguousarray(impact.mass, dtype=np.float64),
            np.ascontiguousarray(impact.force if traction else np.zeros(0), dtype=np.float64),
            np.ascontiguousarray(impact.damp if traction else np.zeros(0), dtype=np.float64))


class _Viscous(NamedTuple):
    """A Kelvin–Voigt layer's data for the kernels (:class:`FusedBulk`)."""

    rows: tuple  # (ptr, col, val) of K_L
    eta: float  # [s]
    layer: np.ndarray  # int64: owned nodes with a row in K_L
    plain: np.ndarray  # int8: 1 where the node is not a special row
    scatter: object  # the off-rank velocities K_L's rows need, or None
    vec: object
    vg: np.ndarray
    v_old: np.ndarray  # float64[2 len(layer)]: v^{n−½} at the layer rows


def ghost_gather(ghost, template, comm):
    """(scatter, vector) gathering the off-rank nodes ``ghost`` (global blocks) of
    a vector laid out as ``template``; (None, None) when no rank needs any.  Collective."""
    if not comm.allreduce(len(ghost) > 0, op=MPI.LOR):  # collective: all ranks take part
        return None, None
    gdofs = (2 * np.asarray(ghost)[:, None] + np.arange(2)[None, :]).ravel().astype(PETSc.IntType)
    vec = PETSc.Vec().createSeq(len(gdofs), comm=PETSc.COMM_SELF)
    is_from = PETSc.IS().createGeneral(gdofs, comm=PETSc.COMM_SELF)
    return PETSc.Scatter().create(template, is_from, vec, None), vec


class FusedBulk:
    """The fused step of one model: built once, one verb (:meth:`advance`).

    >>> bulk = FusedBulk(block_rows(num, rows), dt / mass, dt, interface, impact, template, comm)
    >>> uku, work, absorbed = bulk.advance(state)   # state.u_next <- u^{n+1}, state.v <- v^{n+½}

    Skipping what the motion has not reached.  Started from rest, a row whose
    node and neighbours all hold u = v = 0 has an update of exactly zero, so it
    is skipped ("quiet"); it is computed from the step after one of its
    neighbours first holds a nonzero displacement.  The result is the full
    computation's, bit for bit.  (The explicit scheme's numerical precursor
    runs ahead of the c_l front, one ring of cells per step, with values that
    decay faster than exponentially; waking rows only above a tiny threshold
    would skip more, but rounding then differs in the last bits, which the
    adaptive friction integration can amplify, so it is not done.)  The
    special rows are always computed.  Which rows are awake belongs to the
    state (``state.act``, :class:`fricfem.step.state.State`); a state set by
    hand must be woken (``state.wake()``).
    """

    def __init__(self, rows: BlockRows, dt_minv, dt: float, interface, impact, template: PETSc.Vec, comm,
                 dashpots=(np.zeros(0, dtype=np.int64), np.zeros((0, 2))), viscous=None, sem=None):
        """``rows`` this rank's block rows of K (:func:`block_rows`); ``interface``
        the model's :class:`fricfem.step.interface.Interface` or None (bulk
        alone); ``impact`` a :class:`fricfem.model.build.Impact` (x1 dofs,
        masses, pulse, traction coefficients); ``template`` a vector with the
        displacement's layout; ``dashpots`` (owned nodes, coefficients
        float64[m, 2]) of the absorbing edges
        (:func:`fricfem.model.assembly.dashpots`); ``viscous``: None, or (the block
        rows of the Kelvin–Voigt layer's stiffness K_L (:func:`block_rows`; empty rows
        outside the layer), η [s]): the force η K_L v^{n−½} joins K u^n in the layer
        (:meth:`advance`); ``sem``: None, or the spectral elements' matrix-free
        action (:meth:`fricfem.model.assembly.SemStiffness.kernel_args`), whose K u^n
        the rows, then the identity (:func:`identity_rows`), pass on.  Collective."""
        ensure_fresh()  # numba's disk cache matches the sources (fricfem.kernels.cache)
        self.dt = float(dt)
        dt_minv = np.asarray(dt_minv, dtype=np.float64)
        if not np.array_equal(dt_minv[0::2], dt_minv[1::2]):
            raise ValueError("fused: the lumped mass differs between the two components of a node")
        self.dt_minv = dt_minv[0::2].copy()  # per node: both components carry the same mass
        self.interface = interface
        self.pulse = impact.pulse
        self.edge = _edge(impact)
        self.impact_dofs = np.asarray(impact.dofs).copy()
        self.rows = rows
        self.damped_nodes = np.asarray(dashpots[0], dtype=np.int64)
        self.damping = np.ascontiguousarray(dashpots[1], dtype=np.float64).reshape(-1, 2)
        self.special = special_nodes(self.rows, impact.dofs, interface_nodes(interface, template), self.damped_nodes)
        self.n_nodes = len(self.rows.ptr) - 1
        self.sp_ku = np.zeros(2 * len(self.special.impact))  # K u at the interface rows, see kernels.bulk.preload
        self.ku = None  # K u at the interface rows as a vector, for an interface that needs it (rigid)
        if interface is not None and interface.needs_ku:
            self.ku = template.duplicate()
            self.ku.set(0.0)
            k = np.flatnonzero(self.special.preloaded)
            self.ku_dofs = (2 * self.special.node[k][:, None] + np.arange(2)[None, :]).ravel()
            self.ku_from = (2 * k[:, None] + np.arange(2)[None, :]).ravel()
            self.ku_dofs.setflags(write=False)
            self.ku_from.setflags(write=False)
        self.no_force = np.zeros(2 * self.n_nodes)  # the left / right forces without an interface
        for a in (*self.rows, *self.special, *self.edge, self.dt_minv, self.damping, self.damped_nodes,
                  self.impact_dofs, self.no_force):
            a.setflags(write=False)  # the model's: a step only reads them
        self._rows = tuple(self.rows[:3])  # the kernels' plain tuples
        self._special = tuple(self.special)
        self.ghost_scatter, self.ghost_vec = ghost_gather(self.rows.ghost, template, comm)
        self.ug = np.zeros(0) if self.ghost_vec is None else self.ghost_vec.array
        self.sem = None if sem is None else tuple(sem)
        self.fk = np.zeros(2 * self.n_nodes if sem is not None else 0)  # K u^n of the spectral elements
        self.scratch = np.zeros((3, 1, 1, 2) if sem is None else (3, sem[5].shape[0], sem[5].shape[0], 2))
        self.fd = np.zeros(0)  # no Kelvin–Voigt layer: the kernels add nothing
        self.viscous = None
        if viscous is not None:
            lrows, eta = viscous
            layer = np.flatnonzero(np.diff(lrows.ptr.astype(np.int64)) > 0)
            plain = ~np.isin(layer, self.special.node[:-1])
            scatter, vec = ghost_gather(lrows.ghost, template, comm)
            self.viscous = _Viscous(tuple(lrows[:3]), float(eta), layer.astype(np.int64), plain.astype(np.int8),
                                    scatter, vec, np.zeros(0) if vec is None else vec.array,
                                    np.zeros(2 * len(layer)))
            self.fd = np.zeros(2 * self.n_nodes)
            for a in (*lrows, layer, plain):
                a.setflags(write=False)

    def rebind(self, interface, impact) -> "FusedBulk":
        """The same step for another scene on the same mesh, interface geometry and
        struck edge (the interface's points and law, the load): a copy that shares
        K's rows, the special rows, the scatters and the scratch buffers with this one
        (:mod:`fricfem.model.reuse`; the two must not step at the same time).  Not
        collective."""
        if not np.array_equal(np.asarray(impact.dofs), self.impact_dofs):
            raise ValueError("fused: rebind needs the same struck-edge dofs (the special rows depend on them)")
        if (interface is None) != (self.interface is None) or (
                interface is not None and interface.geometry is not self.interface.geometry):
            raise ValueError("fused: rebind needs the same interface geometry (its scatters are shared)")
        new = copy.copy(self)
        new.interface = interface
        new.pulse = impact.pulse
        new.edge = _edge(impact)
        for a in new.edge:
            a.setflags(write=False)
        return new

    def activity(self, at_rest: bool) -> np.ndarray:
        """A fresh activity array (int8[n_nodes]) for a state: at rest, only the
        special rows are awake; otherwise every row is (``kernels.bulk.SPREAD``)."""
        act = np.full(self.n_nodes, bulk.SPREAD, dtype=np.int8)
        # (a Kelvin–Voigt layer: every row, its force is added after the sweep; spectral
        # elements: every row, the identity rows know no neighbours to wake)
        if at_rest and self.viscous is None and self.sem is None:
            act[:] = bulk.QUIET
            act[self.special.node[:-1]] = bulk.ACTIVE
        return act

    def advance(self, state):
        """One step of ``state`` from t^n = ``state.t``.  Collective.

        Writes u^{n+1} into ``state.u_next`` and v^{n+½} into ``state.v``
        (``state.u`` is left as u^n), advances the interface points with u^n,
        sets ``state.u_imp_prev`` and ``state.react_prev`` (the struck dofs'
        previous displacement and load) to U(t^n) and the load at t^n and updates ``state.act`` and ``state.seconds``.

        Returns this rank's ``u^n · K u^n`` [J/m] (twice its share of the strain
        energy), its load's work and the energy its dashpots absorbed, over
        the step that ended at t^n [J/m].
        """
        dt, t = self.dt, state.t
        u, u_next, v, imp_prev, act = state.u, state.u_next, state.v, state.u_imp_prev, state.act
        imp_react = state.react_prev
        absorb = (self.damping, state.damp_prev)
        u0 = self.pulse.displacement(t)
        u1 = self.pulse.displacement(t + dt)
        load = (dt, u0, u1, (u1 - u0) / dt, self.pulse.sign * self.pulse.velocity(t))
        rows, special, edge = self._rows, self._special, self.edge
        ua, una, va = u.array_r, u_next.array, v.array
        gl = gr = self.no_force
        insert, forward = PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD
        t0 = time.perf_counter()
        vis, fd = self.viscous, self.fd
        if vis is not None:  # η K_L v^{n−½}, before the sweep changes v
            if vis.scatter is not None:
                vis.scatter.begin(v, vis.vec, insert, forward)
                vis.scatter.end(v, vis.vec, insert, forward)
            bulk.viscous_forces(vis.rows, vis.layer, va, vis.vg, vis.eta, fd, vis.v_old)
        if self.ghost_scatter is not None:
            self.ghost_scatter.begin(u, self.ghost_vec, insert, forward)
        if self.interface is not None:
            self.interface.begin_gather(u)  # travels during the sweep
        t1 = time.perf_counter()
        x = ua
        if self.sem is not None:  # spectral elements: K u^n first, matrix-free (it needs the off-rank u^n)
            if self.ghost_scatter is not None:
                self.ghost_scatter.end(u, self.ghost_vec, insert, forward)
            sem_kernels.element_ku(*self.sem, ua, self.ug, self.n_nodes, self.fk, self.scratch)
            x = self.fk
        uku, work, absorbed = bulk.sweep(rows, special, edge, load, x, ua, una, va, self.dt_minv, gl, gr, imp_prev,
                                         imp_react, absorb, act, fd)
        t2 = time.perf_counter()
        if self.ghost_scatter is not None and self.sem is None:
            self.ghost_scatter.end(u, self.ghost_vec, insert, forward)
        t3 = time.perf_counter()
        if self.interface is not None:
            bulk.preload(rows, special, x, self.ug, self.sp_ku)
            if self.ku is not None:
                self.ku.array[self.ku_dofs] = self.sp_ku[self.ku_from]
                if vis is not None:  # the trial velocities see the layer's viscous force too
                    self.ku.array[self.ku_dofs] += fd[self.ku_dofs]
            # −F_int(u^n), left and right parts
            gl, gr = self.interface.advance(state, u, dt, started=True, v=v, ku=self.ku, v_edge=load[3])
        t4 = time.perf_counter()
        uku_d, work_d, absorbed_d = bulk.sweep_deferred(rows, special, edge, load, x, ua, self.ug, una, va,
                                                        self.dt_minv, gl, gr, imp_prev, imp_react, absorb, act,
                                                        self.sp_ku, fd)
        if vis is not None:
            inc, state.viscous_ahead = bulk.viscous_plain(vis.layer, vis.plain, fd, ua, una, va, self.dt_minv, dt,
                                                          vis.v_old)
            state.viscous += inc
        t5 = time.perf_counter()
        sec = state.seconds
        sec["interface"] += (t1 - t0) + (t4 - t3)
        sec["sweep"] += (t2 - t1) + (t5 - t4)
        sec["wait"] += t3 - t2
        return uku + uku_d, work + work_d, absorbed + absorbed_d
