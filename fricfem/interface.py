"""The frictional interface: pairing across x2 = 0, Gauss points, one numba kernel, MPI exchange.

Povirk & Needleman (1993) elastic–frictional interface, as used by Coker et al.:
with Δu = u⁺ − u⁻ (upper minus lower plate) between initially coincident
points, n = x2 and s = x1,

    T_n = Σ0 − C_n Δu_n                       (compression positive; open if T_n < 0:
                                               then T_n = T_s = 0)
    Ṫ_s = C_s [Δu̇_s − sgn(T_s) Δu̇_slip]      (Δu̇_slip from the friction law)

evaluated at 4 Gauss points on every interface segment (the paper's "four
point Gaussian integration along the interface").  The bulk solves for
displacement increments from the uniformly compressed state, so the nodal
forces carry the traction increments: the lower plate receives
(T_s − T_s0) e1 − (T_n − T_n0) e2 and the upper plate the opposite.

MPI.  The plates are meshed separately, so the two nodes of a pair are never
neighbours in the dolfinx mesh and (dolfinx's partitioner puts one plate on each
of two ranks) usually live on different ranks.  Segments are dealt out to ranks
in blocks, round-robin along x1 (each rank gets a share of the sliding region);
each rank gathers the displacements of the nodes
its segments touch with one PETSc scatter, runs the kernel, and adds the nodal
forces back with the reverse scatter.  No ghosts are involved.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numba
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .friction import povirk_needleman, slip_weakening, stuck
from .friction.base import ADVANCE_TYPE, storage
from .mesh import TAGS

#: Segments are dealt to ranks in blocks of this many, round-robin along x1.
SEG_BLOCK = 8

#: Gauss–Legendre points and weights on [-1, 1], 4 points.
GAUSS_XI, GAUSS_W = np.polynomial.legendre.leggauss(4)


class Geometry(NamedTuple):
    """Interface geometry seen by one rank.

    x1_nodes  float64[n_nodes]   x1 of every interface node pair, sorted (all ranks) [m]
    segments  int64[n_seg]       this rank's segments (global indices, increasing)
    x1        float64[n_pts]     x1 of this rank's Gauss points [m]
    wq        float64[n_pts]     Gauss weight × half segment length [m]
    shape     float64[4, 2]      linear shape functions at the Gauss points
    seg_w     int32[n_seg, 4]    offsets into the gathered work vector of the x1
                                 component of (lower a, lower b, upper a, upper b);
                                 the x2 component is the next entry
    scatter   PETSc.Scatter      global displacement → work vector
    work      PETSc.Vec          sequential, gathered displacements
    force     PETSc.Vec          sequential, nodal forces before the reverse scatter
    comm      MPI communicator of the mesh
    """

    x1_nodes: np.ndarray
    segments: np.ndarray
    x1: np.ndarray
    wq: np.ndarray
    shape: np.ndarray
    seg_w: np.ndarray
    scatter: object
    work: object
    force: object
    comm: object


def _owned_nodes(V, facet_tags, name):
    """(x1, x2, global block index) of the owned dof nodes on the facets tagged ``name``."""
    msh = V.mesh
    facets = facet_tags.indices[facet_tags.values == TAGS[name]]
    from dolfinx import fem

    blocks = fem.locate_dofs_topological(V, msh.topology.dim - 1, facets)
    imap = V.dofmap.index_map
    blocks = blocks[blocks < imap.size_local]
    x = V.tabulate_dof_coordinates()[blocks]
    glob = imap.local_to_global(blocks.astype(np.int32))
    return x[:, 0], x[:, 1], glob


def build_geometry(V, facet_tags, template: PETSc.Vec) -> Geometry:
    """Pair the interface nodes across ranks and set up the exchange.

    ``template`` is a vector with the layout of the global displacement.
    """
    comm = V.mesh.comm
    bs = V.dofmap.index_map_bs
    sides = {}
    for side in ("lower", "upper"):
        x1, x2, glob = _owned_nodes(V, facet_tags, f"interface_{side}")
        data = comm.allgather(np.column_stack([x1, x2, glob.astype(np.float64)]))
        data = np.vstack(data)
        data = data[np.argsort(data[:, 0], kind="stable")]
        sides[side] = data
    lo, up = sides["lower"], sides["upper"]
    if len(lo) < 2 or len(lo) != len(up):
        raise RuntimeError(
            f"interface: {len(lo)} lower and {len(up)} upper nodes; the mesh needs matching "
            "interface node rows on both plates"
        )
    scale = max(1.0, float(np.abs(lo[:, 0]).max()))
    if np.abs(lo[:, 0] - up[:, 0]).max() > 1e-9 * scale or np.abs(lo[:, 1]).max() > 1e-9 * scale:
        raise RuntimeError("interface: lower and upper interface nodes do not coincide pairwise")
    x1n = lo[:, 0].copy()
    g_lo = lo[:, 2].astype(np.int64)
    g_up = up[:, 2].astype(np.int64)

    # deal segments out in blocks of SEG_BLOCK, round-robin along x1, so that every
    # rank gets a share of the sliding region near the struck edge (load balance)
    nseg = len(x1n) - 1
    segs = np.flatnonzero((np.arange(nseg) // SEG_BLOCK) % comm.size == comm.rank)
    nodes = np.unique(np.concatenate([segs, segs + 1]))
    # gathered work vector: [lower nodes, upper nodes], 2 comps each
    gnodes = np.concatenate([g_lo[nodes], g_up[nodes]])
    gidx = (bs * gnodes[:, None] + np.arange(bs)[None, :]).ravel().astype(PETSc.IntType)
    n_loc = len(nodes)
    a = np.searchsorted(nodes, segs)
    b = np.searchsorted(nodes, segs + 1)
    seg_w = np.column_stack([a, b, n_loc + a, n_loc + b]).astype(np.int32) * bs

    work = PETSc.Vec().createSeq(len(gidx), comm=PETSc.COMM_SELF)
    force = work.duplicate()
    is_from = PETSc.IS().createGeneral(gidx, comm=PETSc.COMM_SELF)
    scatter = PETSc.Scatter().create(template, is_from, work, None)

    shape = np.column_stack([0.5 * (1 - GAUSS_XI), 0.5 * (1 + GAUSS_XI)])
    xa, xb = x1n[segs], x1n[segs + 1]
    half = 0.5 * (xb - xa)
    x1 = (0.5 * (xa + xb)[:, None] + half[:, None] * GAUSS_XI[None, :]).ravel()
    wq = (half[:, None] * GAUSS_W[None, :]).ravel()
    return Geometry(x1n, segs, x1, wq, shape, seg_w, scatter, work, force, comm)


class Points(NamedTuple):
    """Per-Gauss-point interface data on this rank (SI units; all float64[n] unless noted).

    Tn0, Ts0      initial normal / shear traction [Pa] (Σ0 and the initial shear)
    Cn, Cs        interface stiffnesses [Pa/m]
    param_rows    float64[k, n_params]  the distinct friction-law parameter sets
    param_index   int32[n]  the point's row in ``param_rows`` (``params``: the
                  point's own parameters, float64[n, n_params]; one row for all
                  points of a uniform interface keeps the kernel's data small)
    state         float64[n, n_state + memo]   friction-law state, then the law's memo
    Tn, Ts        current tractions [Pa]
    dTs           change of T_s over the last step, Ṫ_s dt [Pa]
    jump_n, jump_s  current jumps Δu_n, Δu_s [m]
    rate_n, rate_s  jump rates over the last step [m/s]
    slip          accumulated frictional slip Δu_slip [m]
    slip_rate     Δu̇_slip [m/s] (>= 0)
    work          work done on the interface by the bulk since t = 0 [J/m²]
    dissipated    frictional work since t = 0 [J/m²]
    is_open       int8: 1 where the interface is open
    nsub          int32: local sub-steps the law took in the last step
    """

    Tn0: np.ndarray
    Ts0: np.ndarray
    Cn: np.ndarray
    Cs: np.ndarray
    param_rows: np.ndarray
    param_index: np.ndarray
    state: np.ndarray
    Tn: np.ndarray
    Ts: np.ndarray
    dTs: np.ndarray
    jump_n: np.ndarray
    jump_s: np.ndarray
    rate_n: np.ndarray
    rate_s: np.ndarray
    slip: np.ndarray
    slip_rate: np.ndarray
    work: np.ndarray
    dissipated: np.ndarray
    is_open: np.ndarray
    nsub: np.ndarray

    @property
    def params(self) -> np.ndarray:
        """float64[n, n_params]: each point's friction-law parameters."""
        return self.param_rows[self.param_index]


def make_points(law, params, n, Tn0, Ts0, Cn, Cs) -> Points:
    """Initial interface points: ``params`` float64[n, n_params] (packed per point);
    ``Tn0``, ``Ts0``, ``Cn``, ``Cs`` scalars or float64[n]."""
    full = lambda v: np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()  # noqa: E731
    Tn0, Ts0, Cn, Cs = full(Tn0), full(Ts0), full(Cn), full(Cs)
    params = np.array(np.broadcast_to(params, (n, len(law.params))), dtype=np.float64, order="C")
    rows, index = np.unique(params, axis=0, return_inverse=True)
    state = np.zeros((n, len(law.state) + law.memo))  # the law's state, then its memo
    for q in range(n):  # once, at set-up
        state[q] = storage(law, law.initial_state(params[q], Tn0[q], Ts0[q]))
    z = lambda: np.zeros(n)  # noqa: E731
    return Points(
        Tn0, Ts0, Cn, Cs, np.ascontiguousarray(rows), index.reshape(-1).astype(np.int32), state,
        Tn0.copy(), Ts0.copy(), z(), z(), z(), z(), z(), z(), z(), z(), z(),
        np.zeros(n, dtype=np.int8), np.ones(n, dtype=np.int32),
    )


@numba.njit(inline="always", cache=True)
def _add_pair_force(fw, la, lb, ua, ub, na, nb, fx, fy):
    """Add the *negative* of a Gauss point's force (fx, fy) on the lower plate
    to the lower nodes a, b (shape values na, nb) and its opposite to the upper."""
    fw[la] -= na * fx
    fw[la + 1] -= na * fy
    fw[lb] -= nb * fx
    fw[lb + 1] -= nb * fy
    fw[ua] += na * fx
    fw[ua + 1] += na * fy
    fw[ub] += nb * fx
    fw[ub + 1] += nb * fy


_f8v = numba.types.float64[::1]
_f8m = numba.types.float64[:, ::1]
_KERNEL_SIGNATURE = numba.types.void(
    ADVANCE_TYPE, _f8v, _f8v, numba.types.int32[:, ::1], _f8m, _f8v, _f8v, _f8v, _f8v, _f8v, _f8m,
    numba.types.int32[::1], _f8m, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v, _f8v,
    numba.types.int8[::1], numba.types.int32[::1], numba.types.float64,
)


def advance_points(advance, w, fw, seg_w, shape, wq, p_Tn0, p_Ts0, p_Cn, p_Cs, param_rows, param_index, state,
                   Tn, Ts, dTs, jn, js, rn, rs, slip, slip_rate, work, dissipated, is_open, nsub, dt):
    """One bulk step of every interface point on this rank.

    ``w`` holds the gathered displacements at the end of the step; the jumps at
    the start of the step are in ``jn``, ``js``.  Writes the *negative* nodal
    interface forces into ``fw`` (they are added to ``K u``).  ``advance`` is the
    friction law's point integrator (see :mod:`fricfem.friction.base`).
    """
    fw[:] = 0.0
    nseg = seg_w.shape[0]
    ng = shape.shape[0]
    for e in range(nseg):
        la = seg_w[e, 0]
        lb = seg_w[e, 1]
        ua = seg_w[e, 2]
        ub = seg_w[e, 3]
        for g in range(ng):
            q = e * ng + g
            na = shape[g, 0]
            nb = shape[g, 1]
            dus = na * (w[ua] - w[la]) + nb * (w[ub] - w[lb])
            dun = na * (w[ua + 1] - w[la + 1]) + nb * (w[ub + 1] - w[lb + 1])
            vs = (dus - js[q]) / dt
            vn = (dun - jn[q]) / dt
            tn_old = Tn[q]
            ts_old = Ts[q]
            tn_new = p_Tn0[q] - p_Cn[q] * dun
            if tn_new < 0.0:  # open: traction-free, no frictional slip
                tn_new = 0.0
                ts_new = 0.0
                sr = 0.0
                is_open[q] = 1
                nsub[q] = 0
            else:
                ts_new, sr, dsl, dwk, ns = advance(param_rows[param_index[q]], state[q], ts_old, tn_old,
                                                   tn_new, vs, p_Cs[q], dt)
                slip[q] += dsl
                dissipated[q] += dwk
                is_open[q] = 0
                nsub[q] = ns
            # work done by the bulk on the interface (trapezoid in time)
            work[q] += (0.5 * (ts_old + ts_new) - p_Ts0[q]) * (dus - js[q]) \
                - (0.5 * (tn_old + tn_new) - p_Tn0[q]) * (dun - jn[q])
            Tn[q] = tn_new
            Ts[q] = ts_new
            dTs[q] = ts_new - ts_old
            jn[q] = dun
            js[q] = dus
            rn[q] = vn
            rs[q] = vs
            slip_rate[q] = sr
            fx = (ts_new - p_Ts0[q]) * wq[q]  # force on the lower plate, x1
            fy = -(tn_new - p_Tn0[q]) * wq[q]  # force on the lower plate, x2
            _add_pair_force(fw, la, lb, ua, ub, na, nb, fx, fy)


# Two compilations of ``advance_points``, both without numba's reference
# counting (``_nrt=False``; the kernel allocates nothing, and the point rows it
# hands to the law are then plain views).
#
# * One kernel per registered law, calling the law's ``advance`` directly
#   (specialised on its dispatcher, so the call is resolved at compile time and
#   inlined).  Measured on the reference mesh (912 points, serial, kernel
#   alone, data evicted from cache by a bulk sweep first): 43 µs per step while
#   the interface sticks, 162 µs with ~850 points sliding.
# * ``interface_kernel``, compiled once for any other ``advance`` (a law
#   registered elsewhere), which is passed in as a first-class function of type
#   ADVANCE_TYPE.  Slower (134 and 264 µs in the same test): numba converts the
#   law's dispatcher into a function pointer at every call, a Python-level
#   lookup that costs 15–70 µs.
#
# All are cached on disk (hence one module-level wrapper per law: numba caches
# module-level functions, not ones a factory makes).
# (numba types a law's dispatcher passed to ``_specialised`` as a first-class
# function and warns that the feature is experimental; it is what fricfem uses.)
warnings.filterwarnings("ignore", message="First-class function type feature is experimental")
interface_kernel = numba.njit(_KERNEL_SIGNATURE, cache=True, _nrt=False)(advance_points)
_specialised = numba.njit(_nrt=False)(advance_points)


@numba.njit(cache=True, _nrt=False)
def _povirk_needleman_kernel(*args):
    _specialised(povirk_needleman.advance, *args)


@numba.njit(cache=True, _nrt=False)
def _povirk_needleman_rate_tangent_kernel(*args):
    _specialised(povirk_needleman.rate_tangent_advance, *args)


@numba.njit(cache=True, _nrt=False)
def _slip_weakening_kernel(*args):
    _specialised(slip_weakening.advance, *args)


@numba.njit(cache=True, _nrt=False)
def _stuck_kernel(*args):
    _specialised(stuck.advance, *args)


_KERNELS = {
    povirk_needleman.advance: _povirk_needleman_kernel,
    povirk_needleman.rate_tangent_advance: _povirk_needleman_rate_tangent_kernel,
    slip_weakening.advance: _slip_weakening_kernel,
    stuck.advance: _stuck_kernel,
}


def point_kernel(advance):
    """The interface kernel for a law's ``advance``: ``kernel(w, fw, ...)`` with
    the arguments of :func:`advance_points` after ``advance``."""
    kernel = _KERNELS.get(advance)
    if kernel is not None:
        return kernel
    return lambda *args: interface_kernel(advance, *args)


@numba.njit(numba.types.void(_f8v, _f8v, numba.types.int32[:, ::1], _f8m, _f8v, _f8v, _f8v), cache=True)
def spring_kernel(w, fw, seg_w, shape, wq, Cn, Cs):
    """``fw = K_int w`` for the linear interface springs (stability estimate)."""
    fw[:] = 0.0
    ng = shape.shape[0]
    for e in range(seg_w.shape[0]):
        la, lb, ua, ub = seg_w[e, 0], seg_w[e, 1], seg_w[e, 2], seg_w[e, 3]
        for g in range(ng):
            q = e * ng + g
            na, nb = shape[g, 0], shape[g, 1]
            fx = Cs[q] * wq[q] * (na * (w[ua] - w[la]) + nb * (w[ub] - w[lb]))
            fy = Cn[q] * wq[q] * (na * (w[ua + 1] - w[la + 1]) + nb * (w[ub + 1] - w[lb + 1]))
            _add_pair_force(fw, la, lb, ua, ub, na, nb, fx, fy)


class Interface:
    """Interface geometry, point data and the friction law, with the two verbs the
    time loop needs: :meth:`add_forces` and :meth:`add_spring_action`."""

    def __init__(self, geometry: Geometry, points: Points, law):
        self.geometry = geometry
        self.points = points
        self.law = law
        self.kernel = point_kernel(law.advance)

    def _gather(self, u: PETSc.Vec) -> np.ndarray:
        g = self.geometry
        g.scatter.scatter(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
        return g.work.array

    def _add_back(self, f: PETSc.Vec) -> None:
        g = self.geometry
        g.scatter.scatter(g.force, f, PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)

    def begin_gather(self, u: PETSc.Vec) -> None:
        """Start gathering the displacements ``u`` the interface needs (from other
        ranks too); :meth:`add_forces` with ``started=True`` ends it."""
        g = self.geometry
        g.scatter.begin(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)

    def add_forces(self, u: PETSc.Vec, f: PETSc.Vec, dt: float, started: bool = False) -> None:
        """Advance every interface point to the end of the step whose end
        displacement is ``u``, and add the negative interface forces into ``f``.
        ``started``: :meth:`begin_gather` was called with ``u``."""
        g, p = self.geometry, self.points
        if started:
            g.scatter.end(u, g.work, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
            w = g.work.array
        else:
            w = self._gather(u)
        self.kernel(w, g.force.array, g.seg_w, g.shape, g.wq, p.Tn0, p.Ts0, p.Cn, p.Cs, p.param_rows,
                    p.param_index, p.state, p.Tn, p.Ts, p.dTs, p.jump_n, p.jump_s, p.rate_n, p.rate_s, p.slip,
                    p.slip_rate, p.work, p.dissipated, p.is_open, p.nsub, dt)
        self._add_back(f)

    def add_spring_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """``y += K_int x`` with the elastic interface springs."""
        g, p = self.geometry, self.points
        w = self._gather(x)
        spring_kernel(w, g.force.array, g.seg_w, g.shape, g.wq, p.Cn, p.Cs)
        self._add_back(y)

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
