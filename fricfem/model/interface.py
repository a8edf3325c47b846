"""The frictional interface as data: pairing across x2 = 0, Gauss points, the exchange, the points.

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
neighbours in the mesh and (the partition puts one plate on each of two ranks)
usually live on different ranks.  Segments are dealt out to ranks in blocks,
round-robin along x1 (each rank gets a share of the sliding region); each rank
gathers the displacements of the nodes its segments touch with one PETSc
scatter, runs the kernel, and sends each segment's nodal forces to the nodes'
owners into two slots a node (the segment on its left, the one on its right),
which the owner adds in a fixed order.  No ghosts are involved, and nothing
depends on the number of ranks.

Here: the geometry (:func:`build_geometry`) and the per-point data
(:class:`Points`, :func:`make_points`); the numba loop over the points is
:mod:`fricfem.kernels.interface`, the verbs of the time loop
:class:`fricfem.step.interface.Interface`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from petsc4py import PETSc

from ..friction import initial_storage
from .assembly import node_weights
from .grid import TAGS

#: Segments are dealt to ranks in blocks of this many, round-robin along x1.
SEG_BLOCK = 8

#: Gauss–Legendre points and weights on [-1, 1], 4 points, as fixed numbers: what
#: ``np.polynomial.legendre.leggauss(4)`` gives with numpy <= 2.2 (the points are the
#: exact values rounded; the weights 3 ulp from (18 ∓ √30)/36).  leggauss takes them
#: from LAPACK's eigenvalues and numpy 2.3 (the dolfinx 0.11 wheel's) gives weights
#: 2 ulp away, which the sliding front made O(1) differences of (tests/test_stack_bits.py).
GAUSS_XI = np.array([float.fromhex(h) for h in ("-0x1.b8e6dbcf63985p-1", "-0x1.5c23fd9dd3dfcp-2",
                                                 "0x1.5c23fd9dd3dfcp-2", "0x1.b8e6dbcf63985p-1")])
GAUSS_W = np.array([float.fromhex(h) for h in ("0x1.64340f7e7b668p-2", "0x1.4de5f840c24cbp-1",
                                               "0x1.4de5f840c24cbp-1", "0x1.64340f7e7b668p-2")])


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
    seg_f     int32[n_seg, 4]    offsets into ``force`` of the segment's own force
                                 slots for the same four nodes (8 entries a segment)
    scatter   PETSc.Scatter      global displacement → work vector
    to_right  PETSc.Scatter      force slots of each segment's left nodes (a) → ``right``
    to_left   PETSc.Scatter      force slots of each segment's right nodes (b) → ``left``
    work      PETSc.Vec          sequential, gathered displacements
    force     PETSc.Vec          sequential, the segments' nodal forces (8 a segment)
    right     PETSc.Vec          global layout: each node's force from the segment on its right
    left      PETSc.Vec          global layout: each node's force from the segment on its left
    comm      MPI communicator of the mesh
    n_points  int                every rank's points together (segments × points a segment)

    Spectral elements: a segment is one node pair, its one point at the node
    (:func:`build_geometry`).

    A node's interface force is left + right, added in that order on its owner:
    every node gets each part from exactly one segment (INSERT, no summation
    across ranks), so the forces have the same bits on any number of ranks.
    """

    x1_nodes: np.ndarray
    segments: np.ndarray
    x1: np.ndarray
    wq: np.ndarray
    shape: np.ndarray
    seg_w: np.ndarray
    seg_f: np.ndarray
    scatter: object
    to_right: object
    to_left: object
    work: object
    force: object
    right: object
    left: object
    comm: object
    n_points: int


def interface_nodes(num, name: str) -> np.ndarray:
    """Grid nodes on the edges tagged ``name``, sorted by x1."""
    nodes = np.unique(num.facets[num.facet_tags == TAGS[name]])
    return nodes[np.argsort(num.x[nodes, 0], kind="stable")]


def _slot_scatter(force, template, slots, gblocks) -> PETSc.Scatter:
    """Scatter from ``force`` entries ``slots`` (x1 component; x2 is the next)
    to the global dofs of blocks ``gblocks``."""
    src = (slots[:, None] + np.arange(2)[None, :]).ravel().astype(PETSc.IntType)
    dst = (2 * gblocks[:, None] + np.arange(2)[None, :]).ravel().astype(PETSc.IntType)
    return PETSc.Scatter().create(force, PETSc.IS().createGeneral(src, comm=PETSc.COMM_SELF),
                                  template, PETSc.IS().createGeneral(dst, comm=PETSc.COMM_SELF))


def build_geometry(num, template: PETSc.Vec, comm) -> Geometry:
    """Pair the interface nodes of the grid numbering ``num``
    (:mod:`fricfem.model.numbering`) and set up the exchange.  ``template`` is
    a vector with the layout of the global displacement.  Collective.

    The linear triangles integrate the springs at 4 Gauss points a segment.
    Spectral elements integrate them at the GLL nodes themselves, the
    quadrature of their mass and stiffness: each node pair is a "segment" of
    one point at the node (both its ends the node, shape functions (1, 0)),
    weighted by the node's GLL weight along the interface (its ∫ N ds)."""
    lo, up = interface_nodes(num, "interface_lower"), interface_nodes(num, "interface_upper")
    if len(lo) < 2 or len(lo) != len(up):
        raise RuntimeError(
            f"interface: {len(lo)} lower and {len(up)} upper nodes; the mesh needs matching "
            "interface node rows on both plates"
        )
    if not (np.array_equal(num.x[lo, 0], num.x[up, 0]) and not num.x[lo, 1].any() and not num.x[up, 1].any()):
        raise RuntimeError("interface: lower and upper interface nodes do not coincide pairwise")
    x1n = num.x[lo, 0].copy()
    g_lo, g_up = num.global_block[lo], num.global_block[up]

    # deal segments out in blocks of SEG_BLOCK, round-robin along x1, so that every
    # rank gets a share of the sliding region near the struck edge (load balance)
    nodal = num.facet_share is not None
    nseg = len(x1n) if nodal else len(x1n) - 1
    segs = np.flatnonzero((np.arange(nseg) // SEG_BLOCK) % comm.size == comm.rank)
    ends = (segs, segs) if nodal else (segs, segs + 1)  # each segment's nodes a, b
    nodes = np.unique(np.concatenate(ends))
    # gathered work vector: [lower nodes, upper nodes], 2 comps each
    gnodes = np.concatenate([g_lo[nodes], g_up[nodes]])
    gidx = (2 * gnodes[:, None] + np.arange(2)[None, :]).ravel().astype(PETSc.IntType)
    n_loc = len(nodes)
    a, b = np.searchsorted(nodes, ends[0]), np.searchsorted(nodes, ends[1])
    seg_w = np.column_stack([a, b, n_loc + a, n_loc + b]).astype(np.int32) * 2
    seg_f = (8 * np.arange(len(segs))[:, None] + np.array([0, 2, 4, 6])[None, :]).astype(np.int32)

    work = PETSc.Vec().createSeq(len(gidx), comm=PETSc.COMM_SELF)
    scatter = PETSc.Scatter().create(template, PETSc.IS().createGeneral(gidx, comm=PETSc.COMM_SELF), work, None)
    force = PETSc.Vec().createSeq(8 * len(segs), comm=PETSc.COMM_SELF)
    right, left = template.duplicate(), template.duplicate()
    right.set(0.0)
    left.set(0.0)
    # the segment's left nodes (a, lower and upper) get its force as their "right" part
    # (a node's own one-point segment, spectral elements: its "left" part stays zero)
    to_right = _slot_scatter(force, right, np.concatenate([seg_f[:, 0], seg_f[:, 2]]),
                             np.concatenate([g_lo[ends[0]], g_up[ends[0]]]))
    to_left = _slot_scatter(force, left, np.concatenate([seg_f[:, 1], seg_f[:, 3]]),
                            np.concatenate([g_lo[ends[1]], g_up[ends[1]]]))

    if nodal:
        shape = np.array([[1.0, 0.0]])
        x1 = x1n[segs].copy()
        wq = node_weights(num, ("interface_lower",))[lo][segs]
    else:
        shape = np.column_stack([0.5 * (1 - GAUSS_XI), 0.5 * (1 + GAUSS_XI)])
        xa, xb = x1n[segs], x1n[segs + 1]
        half = 0.5 * (xb - xa)
        x1 = (0.5 * (xa + xb)[:, None] + half[:, None] * GAUSS_XI[None, :]).ravel()
        wq = (half[:, None] * GAUSS_W[None, :]).ravel()
    return Geometry(x1n, segs, x1, wq, shape, seg_w, seg_f, scatter, to_right, to_left, work, force, right, left,
                    comm, nseg * len(shape))


class Points(NamedTuple):
    """Per-Gauss-point interface data on this rank (SI units; all float64[n] unless noted).

    The model keeps the initial points, read-only (:meth:`frozen`); each run's
    state has its own (:meth:`fresh`: the constants Tn0 .. param_index shared,
    the evolving arrays state .. nsub its own), which the step updates in place.

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

    def kernel_const(self) -> tuple:
        """The constant part as the kernel's plain tuple (:mod:`fricfem.kernels.interface`)."""
        return tuple(self[:6])

    def kernel_state(self) -> tuple:
        """The evolving part (state .. nsub) as the kernel's plain tuple of the same arrays."""
        return tuple(self[6:])

    @property
    def evolving(self) -> tuple:
        """The names of the fields a step changes (:data:`EVOLVING`)."""
        return self._fields[6:]

    def frozen(self) -> "Points":
        """These points as a model keeps them: every array read-only (the constants,
        ``param_rows`` (the law's ``p``) among them, and the evolving arrays'
        initial values, which each run copies: :meth:`fresh`).  A law that writes
        ``p`` is refused when it is registered (numba will not compile the write
        for a read-only array: ``fricfem.friction.register_law``)."""
        for a in self:
            a.setflags(write=False)
        return self

    def fresh(self) -> "Points":
        """A run's own points: the constants shared (read-only), the evolving arrays
        (:data:`EVOLVING`) copied from these, writeable."""
        return self._replace(**{k: np.array(getattr(self, k)) for k in EVOLVING})


#: the fields of :class:`Points` a step changes (a run's, :class:`fricfem.step.state.State`);
#: the others are the model's constants
EVOLVING = Points._fields[6:]


def make_points(law, params, n, Tn0, Ts0, Cn, Cs, state_Ts0=None) -> Points:
    """Initial interface points: ``params`` float64[n, n_params] (packed per point);
    ``Tn0``, ``Ts0``, ``Cn``, ``Cs`` scalars or float64[n].  ``state_Ts0``: the
    shear traction the law's initial state is set from (default ``Ts0``, each
    point's own; e.g. the background traction outside a nucleation patch, so that
    the patch starts overstressed against its state)."""
    full = lambda v: np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()  # noqa: E731
    Tn0, Ts0, Cn, Cs = full(Tn0), full(Ts0), full(Cn), full(Cs)
    Tss = Ts0 if state_Ts0 is None else full(state_Ts0)
    params = np.array(np.broadcast_to(params, (n, len(law.params))), dtype=np.float64, order="C")
    rows, index = np.unique(params, axis=0, return_inverse=True)
    state = initial_storage(law, params, Tn0, Tss)  # the law's state, then its memo
    z = lambda: np.zeros(n)  # noqa: E731
    return Points(
        Tn0, Ts0, Cn, Cs, np.ascontiguousarray(rows), index.reshape(-1).astype(np.int32), state,
        Tn0.copy(), Ts0.copy(), z(), z(), z(), z(), z(), z(), z(), z(), z(),
        np.zeros(n, dtype=np.int8), np.ones(n, dtype=np.int32),
    )


class ParamField(NamedTuple):
    """A law's parameters along x1, resolved from a scene once (plain data; the
    model evaluates it at its points): ``base`` the packed parameters
    float64[n_params]; ``regions`` ((x1_min, x1_max, packed), ...) applied in
    order where x1_min <= x1 <= x1_max (regions do not overlap: scene
    validation); ``profiles`` ((index, knots x1, knot values), ...) interpolated
    linearly after them (constant beyond the ends)."""

    base: np.ndarray
    regions: tuple = ()
    profiles: tuple = ()

    def __call__(self, x1) -> np.ndarray:
        """float64[n, n_params] at the points ``x1`` [m]."""
        x1 = np.asarray(x1, dtype=np.float64)
        out = np.tile(self.base, (len(x1), 1))
        for lo, hi, packed in self.regions:
            out[(x1 >= lo) & (x1 <= hi)] = packed
        for index, kx, kv in self.profiles:
            out[:, index] = np.interp(x1, kx, kv)
        return out


class TractionField(NamedTuple):
    """An initial shear traction along x1 [Pa], resolved from a scene once:
    ``base`` everywhere, then ``patches`` ((x1_min, x1_max, value), ...) in order."""

    base: float
    patches: tuple = ()

    def __call__(self, x1) -> np.ndarray:
        """float64[n] at ``x1`` [m]."""
        x1 = np.asarray(x1, dtype=np.float64)
        out = np.full(len(x1), self.base)
        for lo, hi, value in self.patches:
            out[(x1 >= lo) & (x1 <= hi)] = value
        return out


def per_point(value, x1, width=None) -> np.ndarray:
    """A per-point array (a writeable copy) from a scalar/array or a callable of x1."""
    v = value(x1) if callable(value) else value
    v = np.asarray(v, dtype=np.float64)
    shape = (len(x1),) if width is None else (len(x1), width)
    return np.array(np.broadcast_to(v, shape), dtype=np.float64, order="C")


def pair_mean(f, x1_nodes: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """The mean of a field along x1 over each node pair's share of the interface,
    weighted by the node's hat function N_k: ∫ N_k f ds / ∫ N_k ds, by the
    elastic interface's 4-point Gauss rule on the (up to) two segments beside
    the node.  ``f``: a callable of x1 [m] (float64[m] -> float64[m]).

    This is the traction a rigid pair carries when the field is a traction:
    its nodal force ∫ N_k f ds divided by its length A_k, the same force the
    elastic interface's Gauss points give the node.  A field that jumps at a
    node (a patch edge on the grid) gives that node the mean of its two sides,
    so the patch acts over its own length, not over half a cell more on each
    side, as a point value at the node would (an error of first order in the
    cell size)."""
    xn = np.asarray(x1_nodes, dtype=np.float64)
    k = np.asarray(pairs, dtype=np.int64)
    s = 0.5 * (1.0 + GAUSS_XI)  # Gauss points on [0, 1]
    num = np.zeros(len(k))
    den = np.zeros(len(k))
    for a, b, shape in ((k - 1, k, s), (k, k + 1, 1.0 - s)):
        ok = (a >= 0) & (b < len(xn))
        h = np.where(ok, xn[np.clip(b, 0, len(xn) - 1)] - xn[np.clip(a, 0, len(xn) - 1)], 0.0)
        x = xn[np.clip(a, 0, len(xn) - 1)][:, None] + h[:, None] * s[None, :]
        w = 0.5 * h[:, None] * GAUSS_W[None, :] * shape[None, :]
        vals = np.asarray(f(x.ravel()), dtype=np.float64).reshape(x.shape)
        num += (w * vals).sum(axis=1)
        den += w.sum(axis=1)
    return num / den


class PairGeometry(NamedTuple):
    """The rigid (split-node) interface seen by one rank: node pairs, not Gauss points.

    x1_nodes  float64[n_nodes]   x1 of every interface node pair, sorted (all ranks) [m]
    pairs     int64[n_pairs]     this rank's pairs (indices into x1_nodes, increasing)
    x1        float64[n_pairs]   their x1 [m]
    wq        float64[n_pairs]   each pair's interface length A = ∫ N ds (half of each
                                 adjacent segment) [m per m]
    mass      float64[2 n_pairs] lumped masses of the pair's lower, upper node [kg/m]
    edge      float64[2 n_pairs + 1]  1.0 where the lower / upper node's x1 velocity is
                                 prescribed (the struck edge's corner), then the
                                 prescribed velocity of the current step [m/s]
    scatter   PETSc.Scatter      global vector → work layout [lower nodes, upper nodes], 2 comps each
    work_u, work_v, work_k  PETSc.Vec  gathered u^n, v^{n−½} and (K u^n) at the pairs
    force     PETSc.Vec          the pairs' negative nodal forces (lower x, y, upper x, y)
    to_left   PETSc.Scatter      ``force`` → ``left`` (each node has one pair: one slot)
    left, right  PETSc.Vec       global layout; ``right`` stays zero
    comm
    """

    x1_nodes: np.ndarray
    pairs: np.ndarray
    x1: np.ndarray
    wq: np.ndarray
    mass: np.ndarray
    edge: np.ndarray
    scatter: object
    work_u: object
    work_v: object
    work_k: object
    force: object
    to_left: object
    left: object
    right: object
    comm: object


def build_pairs(num, template: PETSc.Vec, mass: np.ndarray, comm, prescribed=()) -> PairGeometry:
    """The node pairs of the grid numbering ``num`` dealt to ranks (blocks of
    SEG_BLOCK, round-robin along x1) and their exchange; ``mass`` the owned
    lumped masses (per dof); ``prescribed`` the owned local dofs whose
    velocity is prescribed (the struck edge).  Collective."""
    lo, up = interface_nodes(num, "interface_lower"), interface_nodes(num, "interface_upper")
    if len(lo) < 2 or len(lo) != len(up) or not np.array_equal(num.x[lo, 0], num.x[up, 0]):
        raise RuntimeError("interface: the lower and upper interface nodes do not pair up")
    # each pair's length ∫ N_k ds along the interface (spectral elements: the GLL weight)
    weights = node_weights(num, ("interface_lower",))[lo]
    return pair_geometry(num.x[lo, 0].copy(), num.global_block[lo], num.global_block[up], (0, 1), template, mass,
                         comm, prescribed, weights=weights)


def pair_geometry(xs, g_a, g_b, comps, template: PETSc.Vec, mass: np.ndarray, comm, prescribed=(),
                  target: PETSc.Vec | None = None, weights: np.ndarray | None = None) -> PairGeometry:
    """Split-node pairs along a straight interface: node ``g_a[k]`` (the "lower"
    side) against ``g_b[k]`` (the "upper" one) at position ``xs[k]`` along it,
    dealt to ranks in blocks of SEG_BLOCK; ``comps`` the components gathered as
    the pair kernel's (s, n): (0, 1) for the interface x2 = 0, (1, 0) for a
    face normal to x1 (the experiment's contact).  ``prescribed``: owned local
    dofs whose velocity is prescribed; ``target``: the vector the pairs' forces
    are inserted into (default: a new one, ``left``); ``weights``: each node's
    length A = ∫ N ds [m per m] (default: half of each adjacent segment, the
    linear elements').  Collective."""
    pairs = np.flatnonzero((np.arange(len(xs)) // SEG_BLOCK) % comm.size == comm.rank)
    if weights is None:
        length = np.diff(xs)
        A = np.zeros(len(xs))
        A[:-1] += 0.5 * length  # each node gets half of the segment on its right …
        A[1:] += 0.5 * length  # … then half of the one on its left
    else:
        A = np.asarray(weights, dtype=np.float64)
    comps = np.asarray(comps)
    gnodes = np.concatenate([g_a[pairs], g_b[pairs]])
    gidx = (2 * gnodes[:, None] + comps[None, :]).ravel().astype(PETSc.IntType)
    work_u = PETSc.Vec().createSeq(len(gidx), comm=PETSc.COMM_SELF)
    scatter = PETSc.Scatter().create(template, PETSc.IS().createGeneral(gidx, comm=PETSc.COMM_SELF), work_u, None)
    mvec = template.duplicate()
    mvec.array[:] = mass
    work_v, work_k = work_u.duplicate(), work_u.duplicate()
    scatter.scatter(mvec, work_v, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
    n = len(pairs)
    wm = work_v.array.reshape(2, n, 2)  # [lower/upper, pair, comp]
    pair_mass = np.column_stack([wm[0, :, 0], wm[1, :, 0]]).ravel().copy()
    mvec.set(0.0)
    mvec.array[np.asarray(prescribed, dtype=np.int64)] = 1.0
    scatter.scatter(mvec, work_v, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
    wf = work_v.array.reshape(2, n, 2)
    edge = np.append(np.column_stack([wf[0, :, 0], wf[1, :, 0]]).ravel(), 0.0)
    force = PETSc.Vec().createSeq(4 * n, comm=PETSc.COMM_SELF)
    slots = 4 * np.arange(n)
    if target is None:
        target = template.duplicate()
        target.set(0.0)
    right = template.duplicate()
    right.set(0.0)
    src = np.concatenate([slots, slots + 1, slots + 2, slots + 3]).astype(PETSc.IntType)
    dst = np.concatenate([2 * g_a[pairs] + comps[0], 2 * g_a[pairs] + comps[1],
                          2 * g_b[pairs] + comps[0], 2 * g_b[pairs] + comps[1]])
    to_left = PETSc.Scatter().create(force, PETSc.IS().createGeneral(src, comm=PETSc.COMM_SELF), target,
                                     PETSc.IS().createGeneral(dst.astype(PETSc.IntType), comm=PETSc.COMM_SELF))
    return PairGeometry(xs, pairs, xs[pairs].copy(), A[pairs].copy(), pair_mass, edge, scatter, work_u, work_v,
                        work_k, force, to_left, target, right, comm)
