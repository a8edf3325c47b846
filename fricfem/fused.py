"""The bulk step in one pass over the stiffness: K u, the interface forces, the
struck edge and the central-difference update together.

With ``f = K u^n − F_int(u^n)`` the explicit step of :mod:`fricfem.solver` is

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
  does the work ``R^n (u^{n+1} − u^{n−1})/2``, as the two-pass step of
  :mod:`fricfem.solver` has it (or, for a traction load, the edge force
  enters the update; see :func:`_special_update`);
* interface nodes: a short pre-pass puts ``K u^n`` into the vector ``g`` at
  these rows, and :meth:`Interface.add_forces` adds the negative interface
  forces there through its reverse scatter;
* MPI boundary nodes: rows with columns owned by another rank, whose
  off-rank displacements come through one more PETSc scatter.

Order of a step::

    begin gathering the off-rank displacements, and the interface's
    sweep every row but the interface and MPI boundary rows ("deferred")
    end the gather of off-rank displacements (it travelled during the sweep)
    pre-pass; Interface.add_forces (end its gather, kernel, reverse scatter into g)
    update the deferred rows

The sweep neither reads nor writes ``g`` and leaves u^n in place, so the
interface works after it on the same u^n, and both gathers travel while the
rows are swept.

Round-off.  Each row is summed in the order of PETSc's AIJ product (columns
in order; on a boundary row the owned columns first, then the off-rank ones),
and ``f`` at the interface rows is accumulated as ``(K u) + forces`` in the
order of the reverse scatter, so the step reproduces the two-pass step
(``K.mult``, :meth:`Interface.add_forces`, update) bit for bit (checked on 1
to 4 ranks).  Only ``u · K u`` (energy) and the reaction work are summed in
another order.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numba
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


class BlockRows(NamedTuple):
    """This rank's rows of ``K`` as block CSR with 2×2 blocks.

    ptr    uint32[n_nodes + 1]  block-row pointers (owned nodes)
    col    uint32[n_blocks]     block column: an owned node ``< n_nodes``, or
                                ``n_nodes + k`` for the k-th gathered off-rank node
    val    float64[4 n_blocks]  (K_00, K_01, K_10, K_11) of each block [N/m², per m thickness]
    ghost  int64[n_ghost]       global node index of each gathered off-rank node (sorted)

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
    preloaded  int8[n]       1: an interface row, ``g`` holds ``K u`` + interface
                             forces at the node; 0: ``g`` is zero there
    """

    node: np.ndarray
    impact: np.ndarray
    deferred: np.ndarray
    preloaded: np.ndarray


# Activity of a row (:class:`FusedBulk`): QUIET rows are skipped; ACTIVE rows
# are computed; SPREAD rows are computed and have woken their neighbours.
QUIET, ACTIVE, SPREAD = 0, 1, 2


def block_rows(K: PETSc.Mat) -> BlockRows:
    """Block CSR of the owned rows of ``K`` (AIJ whose layout has block size 2).

    Raises ``ValueError`` unless rows ``2I`` and ``2I + 1`` share their columns
    and the columns come in pairs ``(2J, 2J + 1)``.
    """
    r0, r1 = K.getOwnershipRange()
    if r0 % 2 or r1 % 2:
        raise ValueError(f"fused: the ownership range [{r0}, {r1}) of K splits a node")
    ip, jj, vv = K.getValuesCSR()
    counts = np.diff(np.asarray(ip, dtype=np.int64))
    jj = np.asarray(jj, dtype=np.int64)
    n_nodes = (r1 - r0) // 2
    even_row = np.repeat(np.arange(len(counts)) % 2 == 0, counts)
    c0, c1 = jj[even_row], jj[~even_row]
    ok = (
        np.array_equal(counts[0::2], counts[1::2])
        and not (counts % 2).any()
        and np.array_equal(c0, c1)
        and not (c0[0::2] % 2).any()
        and np.array_equal(c0[1::2], c0[0::2] + 1)
    )
    if not ok:
        raise ValueError("fused: K is not made of 2x2 node blocks (a P1 vector space is expected)")
    gnode = c0[0::2] // 2
    if len(gnode) >= 2**32:
        raise ValueError(f"fused: {len(gnode)} blocks on one rank; at most 2**32 - 1 are supported")
    val = np.column_stack([np.asarray(vv[even_row]).reshape(-1, 2), np.asarray(vv[~even_row]).reshape(-1, 2)])
    ptr = np.concatenate([[0], np.cumsum(counts[0::2] // 2)]).astype(np.uint32)
    owned = (gnode >= r0 // 2) & (gnode < r1 // 2)
    ghost = np.unique(gnode[~owned])
    col = np.empty(len(gnode), dtype=np.uint32)
    col[owned] = gnode[owned] - r0 // 2
    col[~owned] = n_nodes + np.searchsorted(ghost, gnode[~owned])
    return BlockRows(ptr, col, np.ascontiguousarray(val.ravel()), ghost)


def interface_nodes(interface, template: PETSc.Vec) -> np.ndarray:
    """Owned nodes (local indices) that receive interface forces: ones sent back
    through the interface's reverse scatter mark them."""
    if interface is None:
        return np.zeros(0, dtype=np.int64)
    geom = interface.geometry
    ones = geom.force.duplicate()
    ones.set(1.0)
    mark = template.duplicate()
    mark.set(0.0)
    geom.scatter.scatter(ones, mark, PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
    return np.unique(np.flatnonzero(mark.array_r) // 2)


def _has_off_rank(rows: BlockRows, nodes: np.ndarray, n_nodes: int) -> np.ndarray:
    """bool[len(nodes)]: the node's row has off-rank columns."""
    row_of_block = np.repeat(np.arange(n_nodes), np.diff(rows.ptr.astype(np.int64)))
    return np.isin(nodes, row_of_block[rows.col >= n_nodes])


def special_nodes(rows: BlockRows, impact_dofs: np.ndarray, iface_nodes: np.ndarray) -> Special:
    """Merge the interface, struck-edge (x1 dofs: even local indices) and MPI boundary nodes."""
    impact_dofs = np.asarray(impact_dofs, dtype=np.int64)
    if (impact_dofs % 2).any():
        raise ValueError("fused: the prescribed dofs must be x1 components (even local indices)")
    n_nodes = len(rows.ptr) - 1
    bnd = np.flatnonzero(_has_off_rank(rows, np.arange(n_nodes), n_nodes))
    imp = impact_dofs // 2
    node = np.unique(np.concatenate([iface_nodes, imp, bnd]).astype(np.int64))
    impact = np.full(len(node), -1, dtype=np.int32)
    impact[np.searchsorted(node, imp)] = np.arange(len(imp), dtype=np.int32)
    on_interface = np.isin(node, iface_nodes)
    deferred = (on_interface | np.isin(node, bnd)).astype(np.int8)
    preloaded = on_interface.astype(np.int8)
    return Special(np.append(node, n_nodes).astype(np.int32), impact, deferred, preloaded)


# --- kernels: arrays and scalars only ----------------------------------------------------


@numba.njit(inline="always", cache=True)
def _add_block(val, b, x0, x1, s0, s1):
    """Add the 2×2 block at ``val[b:b + 4]`` times (x0, x1) to (s0, s1), term by
    term in PETSc's order (the sums stay bit-identical to its product)."""
    s0 += val[b] * x0
    s0 += val[b + 1] * x1
    s1 += val[b + 2] * x0
    s1 += val[b + 3] * x1
    return s0, s1


@numba.njit(cache=True)
def _row(ptr, col, val, x, I):
    """(K x)_{2I}, (K x)_{2I+1} for a row whose columns are all owned; summed in
    column order, as PETSc's AIJ product."""
    s0 = 0.0
    s1 = 0.0
    for p in range(ptr[I], ptr[I + 1]):
        j = 2 * col[p]
        s0, s1 = _add_block(val, 4 * p, x[j], x[j + 1], s0, s1)
    return s0, s1


@numba.njit(cache=True)
def _row_mixed(ptr, col, val, x, xg, n_nodes, I):
    """The same for a boundary row, ``xg`` holding the gathered off-rank values:
    owned columns first, then the off-rank ones (PETSc's MPIAIJ order)."""
    s0 = 0.0
    s1 = 0.0
    for p in range(ptr[I], ptr[I + 1]):
        J = col[p]
        if J < n_nodes:
            s0, s1 = _add_block(val, 4 * p, x[2 * J], x[2 * J + 1], s0, s1)
    for p in range(ptr[I], ptr[I + 1]):
        J = col[p]
        if J >= n_nodes:
            k = 2 * (J - n_nodes)
            s0, s1 = _add_block(val, 4 * p, xg[k], xg[k + 1], s0, s1)
    return s0, s1


@numba.njit(cache=True)
def preload(ptr, col, val, u, ug, g, sp_node, sp_preloaded, sp_ku):
    """``g = K u`` at the preloaded special nodes (before the interface adds its
    forces), and a copy in ``sp_ku`` (float64[2 n_special], by special index)
    for the energy; ``ug`` the gathered off-rank displacements, if a row needs them."""
    n = ptr.size - 1
    for k in range(sp_preloaded.size):
        if sp_preloaded[k]:
            I = sp_node[k]
            s0, s1 = _row_mixed(ptr, col, val, u, ug, n, I)
            g[2 * I] = s0
            g[2 * I + 1] = s1
            sp_ku[2 * k] = s0
            sp_ku[2 * k + 1] = s1


@numba.njit(cache=True)
def _special_update(I, k, s0, s1, u, unew, v, dt_minv, g, sp_impact, sp_preloaded, imp_mass, imp_prev,
                    dt, u0, u1, v_bc, imp_force, imp_damp, sv):
    """Update the special node ``I`` (its index ``k`` in the special arrays) from
    ``s = (K u)_I``; returns the work of the step's load on it [J/m].

    On the struck edge either u1 is prescribed (``imp_mass`` the masses; U(t^n),
    U(t^{n+1}), v_bc) or, when ``imp_force`` is not empty, a traction acts:
    the force ``imp_force · sv − imp_damp · v^n`` with v^n = (v^{n−½} + v^{n+½})/2
    (``sv`` = sign · V(t^n)), taken implicitly in v^{n+½}."""
    i = 2 * I
    if sp_preloaded[k]:
        f0 = g[i]  # (K u) + forces, summed as the two-pass step does
        f1 = g[i + 1]
        g[i] = 0.0  # ready for the next step
        g[i + 1] = 0.0
    else:
        f0 = s0
        f1 = s1
    work = 0.0
    q = sp_impact[k]
    if q >= 0 and imp_force.size:
        c = dt_minv[I]
        a = 0.5 * c * imp_damp[q]
        v_old = v[i]
        v[i] = (v_old * (1.0 - a) - c * (f0 - imp_force[q] * sv)) / (1.0 + a)
        unew[i] = u[i] + dt * v[i]
        load = imp_force[q] * sv - imp_damp[q] * 0.5 * (v_old + v[i])
        work = load * (0.5 * (unew[i] - imp_prev[q]))
        imp_prev[q] = u[i]
    elif q >= 0:
        # prescribed u1 = U(t^{n+1}), v1 = (U(t^{n+1}) − U(t^n))/dt; reaction R^n = M a^n + f^n
        react = imp_mass[q] * (v_bc - v[i]) / dt + f0
        work = react * (0.5 * (u1 - imp_prev[q]))
        imp_prev[q] = u0
        v[i] = v_bc
        unew[i] = u1
    else:
        v[i] -= dt_minv[I] * f0
        unew[i] = u[i] + dt * v[i]
    v[i + 1] -= dt_minv[I] * f1
    unew[i + 1] = u[i + 1] + dt * v[i + 1]
    return work


@numba.njit(inline="always", cache=True)
def _wake_neighbours(ptr, col, act, n, I):
    """Row ``I`` holds a nonzero displacement from now on: its owned neighbours
    are computed from the next step on (or from this one, if still to come)."""
    for p in range(ptr[I], ptr[I + 1]):
        J = col[p]
        if J < n and act[J] == QUIET:
            act[J] = ACTIVE
    act[I] = SPREAD


@numba.njit(cache=True)
def sweep(ptr, col, val, u, unew, v, dt_minv, g, sp_node, sp_impact, sp_deferred, sp_preloaded,
          imp_mass, imp_prev, dt, u0, u1, v_bc, imp_force, imp_damp, sv, act):
    """One pass over the owned block rows, the deferred special rows excepted.

    u         float64[2 n]    u^n (read)                        [m]
    unew      float64[2 n]    u^{n+1} (written)                 [m]
    v         float64[2 n]    v^{n−½} in, v^{n+½} out           [m/s]
    dt_minv   float64[n]      dt / lumped mass of each node     [s m/kg]
    g         float64[2 n]    see :class:`Special`; zero again on return [N/m]
    imp_mass  float64[n_imp]  lumped masses of the struck dofs  [kg/m]
    imp_prev  float64[n_imp]  u^{n−1} of the struck dofs, set to u^n = U(t^n) [m]
    u0, u1, v_bc  U(t^n), U(t^{n+1}) [m] and (u1 − u0)/dt [m/s]
    act       int8[n]         activity of each row (QUIET rows are skipped; see
                              :class:`FusedBulk`), updated

    Returns (u^n · K u^n over the swept rows [J/m, twice the strain energy],
    reaction work over the step [J/m]).
    """
    n = ptr.size - 1
    k = 0
    nxt = sp_node[0]
    uku = 0.0
    work = 0.0
    for I in range(n):
        i = 2 * I
        if I == nxt:
            kk = k
            k += 1
            nxt = sp_node[k]
            if sp_deferred[kk]:
                continue  # in sweep_deferred, once the messages are in
            s0, s1 = _row(ptr, col, val, u, I)
            uku += u[i] * s0 + u[i + 1] * s1
            work += _special_update(I, kk, s0, s1, u, unew, v, dt_minv, g, sp_impact, sp_preloaded,
                                    imp_mass, imp_prev, dt, u0, u1, v_bc, imp_force, imp_damp, sv)
            if act[I] != SPREAD and (unew[i] != 0.0 or unew[i + 1] != 0.0):
                _wake_neighbours(ptr, col, act, n, I)
            continue
        state = act[I]
        if state == QUIET:
            continue  # u = v = 0 here and at the neighbours: the update is exactly zero
        s0, s1 = _row(ptr, col, val, u, I)
        uku += u[i] * s0 + u[i + 1] * s1
        c = dt_minv[I]
        v[i] -= c * s0
        unew[i] = u[i] + dt * v[i]
        v[i + 1] -= c * s1
        unew[i + 1] = u[i + 1] + dt * v[i + 1]
        if state == ACTIVE and (unew[i] != 0.0 or unew[i + 1] != 0.0):
            _wake_neighbours(ptr, col, act, n, I)
    return uku, work


@numba.njit(cache=True)
def sweep_deferred(ptr, col, val, u, ug, unew, v, dt_minv, g, sp_node, sp_impact, sp_deferred,
                   sp_preloaded, imp_mass, imp_prev, dt, u0, u1, v_bc, imp_force, imp_damp, sv, act, sp_ku):
    """The deferred special rows (interface, MPI boundary), ``ug`` holding the
    gathered off-rank displacements; the preloaded rows' ``K u`` is taken from
    ``sp_ku`` (:func:`preload`).  Otherwise as :func:`sweep`."""
    n = ptr.size - 1
    uku = 0.0
    work = 0.0
    for kk in range(sp_deferred.size):
        if not sp_deferred[kk]:
            continue
        I = sp_node[kk]
        i = 2 * I
        if sp_preloaded[kk]:
            s0 = sp_ku[2 * kk]
            s1 = sp_ku[2 * kk + 1]
        else:
            s0, s1 = _row_mixed(ptr, col, val, u, ug, n, I)
        uku += u[i] * s0 + u[i + 1] * s1
        work += _special_update(I, kk, s0, s1, u, unew, v, dt_minv, g, sp_impact, sp_preloaded,
                                imp_mass, imp_prev, dt, u0, u1, v_bc, imp_force, imp_damp, sv)
        if act[I] != SPREAD and (unew[i] != 0.0 or unew[i + 1] != 0.0):
            _wake_neighbours(ptr, col, act, n, I)
    return uku, work


# --- orchestration ------------------------------------------------------------------------


class FusedBulk:
    """The fused step of one model: built once (:meth:`build`), one verb (:meth:`advance`).

    >>> fused = FusedBulk.build(model)
    >>> fused.rest(state.u, state.t)      # the state is at rest: skip the quiet rows
    >>> uku, work = fused.advance(state.u, state.u_next, state.v, state.u_imp_prev, state.t)
    >>> state.u, state.u_next = state.u_next, state.u

    Skipping what the motion has not reached.  Started from rest, a row whose
    node and neighbours all hold u = v = 0 has an update of exactly zero, so it
    is skipped ("quiet"); it is computed from the step after one of its
    neighbours first holds a nonzero displacement.  The result is the full
    computation's, bit for bit.  (The explicit scheme's numerical precursor
    runs ahead of the c_l front, one ring of cells per step, with values that
    decay faster than exponentially; waking rows only above a tiny threshold
    would skip more, but rounding then differs in the last bits, which the
    adaptive friction integration can amplify, so it is not done.)  The
    special rows are always computed.  The activity belongs to the sequence of
    steps from :meth:`rest`: a call whose ``u`` is not the previous call's
    ``u_next`` at the next time (a state set by hand, a restart) first wakes
    every row; ``skip=False`` never skips.
    """

    def __init__(self, K: PETSc.Mat, dt_minv, dt: float, interface, impact, skip: bool = True):
        """``interface`` the model's interface or None (bulk alone); ``impact`` a
        :class:`fricfem.solver.Impact` (x1 dofs, masses, pulse); ``skip``: skip
        the quiet rows of a state started from rest.  Collective."""
        self.dt = float(dt)
        self.skip = bool(skip)
        dt_minv = np.asarray(dt_minv, dtype=np.float64)
        if not np.array_equal(dt_minv[0::2], dt_minv[1::2]):
            raise ValueError("fused: the lumped mass differs between the two components of a node")
        self.dt_minv = dt_minv[0::2].copy()  # per node: both components carry the same mass
        self.interface = interface
        self.pulse = impact.pulse
        self.imp_mass = np.ascontiguousarray(impact.mass, dtype=np.float64)
        traction = not impact.pulse.prescribed and len(impact.force) == len(impact.dofs)
        self.imp_force = np.ascontiguousarray(impact.force if traction else np.zeros(0), dtype=np.float64)
        self.imp_damp = np.ascontiguousarray(impact.damp if traction else np.zeros(0), dtype=np.float64)
        self.rows = block_rows(K)
        self.g = K.createVecRight()  # see Special.preloaded; zero between steps
        self.g.set(0.0)
        #: wall time per phase, summed over steps [s]: the interface (gather, kernel,
        #: reverse scatter), the sweeps, and the wait for off-rank displacements
        self.seconds = {"interface": 0.0, "sweep": 0.0, "wait": 0.0}
        self.special = special_nodes(self.rows, impact.dofs, interface_nodes(interface, self.g))
        n_nodes = len(self.rows.ptr) - 1
        self.act = np.full(n_nodes, SPREAD, dtype=np.int8)  # awake until rest()
        self.sp_ku = np.zeros(2 * len(self.special.impact))  # K u at the preloaded rows, see preload
        self._expect = None  # (id of the next u, next t) of an unbroken sequence of steps
        comm = K.getComm().tompi4py()
        self.ghost_scatter = None
        self.ug = np.zeros(0)
        if comm.allreduce(len(self.rows.ghost) > 0, op=MPI.LOR):  # collective: all ranks take part
            gdofs = (2 * self.rows.ghost[:, None] + np.arange(2)[None, :]).ravel().astype(PETSc.IntType)
            self.ghost_vec = PETSc.Vec().createSeq(len(gdofs), comm=PETSc.COMM_SELF)
            is_from = PETSc.IS().createGeneral(gdofs, comm=PETSc.COMM_SELF)
            self.ghost_scatter = PETSc.Scatter().create(self.g, is_from, self.ghost_vec, None)
            self.ug = self.ghost_vec.array

    @classmethod
    def build(cls, model, skip: bool = True) -> FusedBulk:
        """From a :class:`fricfem.solver.Model` (K, dt/m, dt, interface, struck edge)."""
        return cls(model.K, model.dt_minv, model.dt, model.interface, model.impact, skip)

    def rest(self, u: PETSc.Vec, t: float) -> None:
        """The state whose displacement vector is ``u`` is at rest (u = v = 0) at
        time ``t``: from there on only rows the motion reaches are computed."""
        if self.skip:
            self.act[:] = QUIET
            self.act[self.special.node[:-1]] = ACTIVE
        self._expect = (id(u), t)

    def wake(self) -> None:
        """Compute every row from now on (a state set by hand)."""
        self.act[:] = SPREAD

    @property
    def active_fraction(self) -> float:
        """Share of this rank's rows that are computed (not quiet) in the next step."""
        return float(np.count_nonzero(self.act)) / max(len(self.act), 1)

    def advance(self, u: PETSc.Vec, u_next: PETSc.Vec, v: PETSc.Vec, imp_prev: np.ndarray, t: float):
        """One step from t^n = ``t``.  Collective.

        Writes u^{n+1} into ``u_next`` and v^{n+½} into ``v`` (``u`` is left as
        u^n), advances the interface points with u^n, and sets ``imp_prev``
        (float64[n_imp], the struck dofs' previous displacement) to U(t^n).

        Returns this rank's ``u^n · K u^n`` [J/m] (twice its share of the strain
        energy) and its reaction work over the step [J/m].
        """
        dt = self.dt
        if self._expect != (id(u), t):
            self.wake()  # not the continuation of the last step: compute everything
        self._expect = (id(u_next), t + dt)
        u0 = self.pulse.displacement(t)
        u1 = self.pulse.displacement(t + dt)
        v_bc = (u1 - u0) / dt
        # a traction load: its nodal coefficients and sign · V(t^n) (empty arrays: prescribed)
        load = (self.imp_force, self.imp_damp, self.pulse.sign * self.pulse.velocity(t))
        r, sp = self.rows, self.special
        ua, una, va, ga = u.array_r, u_next.array, v.array, self.g.array
        insert, forward = PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD
        t0 = time.perf_counter()
        if self.ghost_scatter is not None:
            self.ghost_scatter.begin(u, self.ghost_vec, insert, forward)
        if self.interface is not None:
            self.interface.begin_gather(u)  # travels during the sweep
        t1 = time.perf_counter()
        uku, work = sweep(r.ptr, r.col, r.val, ua, una, va, self.dt_minv, ga, sp.node, sp.impact, sp.deferred,
                          sp.preloaded, self.imp_mass, imp_prev, dt, u0, u1, v_bc, *load, self.act)
        t2 = time.perf_counter()
        if self.ghost_scatter is not None:
            self.ghost_scatter.end(u, self.ghost_vec, insert, forward)
        t3 = time.perf_counter()
        if self.interface is not None:
            preload(r.ptr, r.col, r.val, ua, self.ug, ga, sp.node, sp.preloaded, self.sp_ku)
            self.interface.add_forces(u, self.g, dt, started=True)  # g += −F_int(u^n)
        t4 = time.perf_counter()
        uku_d, work_d = sweep_deferred(r.ptr, r.col, r.val, ua, self.ug, una, va, self.dt_minv, ga, sp.node,
                                       sp.impact, sp.deferred, sp.preloaded, self.imp_mass, imp_prev,
                                       dt, u0, u1, v_bc, *load, self.act, self.sp_ku)
        t5 = time.perf_counter()
        sec = self.seconds
        sec["interface"] += (t1 - t0) + (t4 - t3)
        sec["sweep"] += (t2 - t1) + (t5 - t4)
        sec["wait"] += t3 - t2
        return uku + uku_d, work + work_d
