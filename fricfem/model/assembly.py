"""Assembled once per run: the stiffness K, the lumped mass, the struck edge's
dofs and weights, and the stable step from λmax of M⁻¹(K + K_int).

Linear triangles (P1 vector space), lumped (row-sum) mass, as in the paper.
K, the mass and the edge weights are summed by fricfem in the grid's order
(:mod:`.numbering`), not through dolfinx's local assembly, so that they have
the same bits on any number of ranks.
The stable step of the explicit central differences is ``2/√λmax`` with λmax
from the Lanczos iteration, which includes the interface springs
(:func:`max_eigenvalue`); the run's step is ``dt_safety`` times it, rounded
down to 3 significant digits (:func:`round_down`) so that it is the same on
any number of ranks.
"""

from __future__ import annotations

import math

import numpy as np

from .. import compat  # noqa: I001  (mpi4py before dolfinx: fricfem/compat.py)
from dolfinx import fem
from petsc4py import PETSc

from . import sem
from .grid import TAGS
from .material import Material


def function_space(msh):
    return compat.function_space(msh, "Lagrange", 1, (2,))


def element_blocks(x, cells, material: Material) -> np.ndarray:
    """2×2 stiffness blocks of linear triangles, float64[n_cells, 3, 3, 4] in
    (K_xx, K_xy, K_yx, K_yy) order [N/m per m thickness]:
    K_ab = A [[(λ+2μ) b_a b_b + μ c_a c_b, λ b_a c_b + μ c_a b_b],
              [λ c_a b_b + μ b_a c_b, (λ+2μ) c_a c_b + μ b_a b_b]],
    b, c the shape-function gradients, A the area (the form ∫ σ(u):ε(v) dx
    of the P1 vector space, in closed form)."""
    pa, pb, pc = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
    det = (pb[:, 0] - pa[:, 0]) * (pc[:, 1] - pa[:, 1]) - (pc[:, 0] - pa[:, 0]) * (pb[:, 1] - pa[:, 1])
    b = np.stack([pb[:, 1] - pc[:, 1], pc[:, 1] - pa[:, 1], pa[:, 1] - pb[:, 1]], axis=1) / det[:, None]
    c = np.stack([pc[:, 0] - pb[:, 0], pa[:, 0] - pc[:, 0], pb[:, 0] - pa[:, 0]], axis=1) / det[:, None]
    area = 0.5 * det
    lam, mu = material.lmbda, material.mu
    if np.ndim(lam):  # moduli per cell (bodies of several materials: fricfem.model.bodies.CellMaterials)
        lam, mu = lam[:, None, None], mu[:, None, None]
    bb = b[:, :, None] * b[:, None, :]
    cc = c[:, :, None] * c[:, None, :]
    bc = b[:, :, None] * c[:, None, :]  # b_a c_b
    cb = c[:, :, None] * b[:, None, :]  # c_a b_b
    blocks = np.stack([(lam + 2 * mu) * bb + mu * cc, lam * bc + mu * cb, lam * cb + mu * bc,
                       (lam + 2 * mu) * cc + mu * bb], axis=-1)
    return blocks * area[:, None, None, None]


def _sum_in_order(keys, values) -> tuple:
    """Group equal ``keys`` (int64[n, k], already sorted) and sum each group's
    ``values`` (float64[n, m]) one after the other in their order: (first row of
    each group, sums float64[n_groups, m]).  The same groups give the same bits
    on any rank (the canonical order of the sums)."""
    if len(keys) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, values.shape[1]))
    new = np.ones(len(keys), dtype=bool)
    new[1:] = (keys[1:] != keys[:-1]).any(axis=1)
    start = np.flatnonzero(new)
    group = np.cumsum(new) - 1
    slot = np.arange(len(keys)) - start[group]
    padded = np.zeros((len(start), int(slot.max()) + 1, values.shape[1]))
    padded[group, slot] = values
    acc = padded[:, 0].copy()
    for k in range(1, padded.shape[1]):
        acc = acc + padded[:, k]  # adding a padding zero changes nothing
    return start, acc


def _touching(num, cells) -> tuple:
    """(own bool[n_grid]: the owned grid nodes, sel: the indices of the ``cells``
    (grid node lists, in grid order) that touch an owned node, increasing)."""
    own = np.zeros(len(num.x), dtype=bool)
    own[num.owned_nodes] = True
    return own, np.flatnonzero(own[cells].any(axis=1))


def canonical_rows(num, material: Material) -> tuple:
    """This rank's rows of K in the grid's order, summed over their cells in
    grid-cell order, so that every entry has the same bits on any number of
    ranks.  ``material``: one :class:`Material`, or moduli per grid cell (an
    object with ``take(cells)``, :class:`fricfem.model.bodies.CellMaterials`).  Returns (rows int64[n_owned + 1] block-row pointers in local block
    order, cols int64[n_blocks] grid nodes, increasing within a row, vals
    float64[n_blocks, 4] (K_xx, K_xy, K_yx, K_yy))."""
    el = num.elements
    cells = num.cells if el is None else el.nodes
    own, sel = _touching(num, cells)
    cells = cells[sel]
    if el is None:
        ke = element_blocks(num.x, cells, material.take(sel) if hasattr(material, "take") else material)
    else:  # spectral elements (fricfem.model.sem); one material
        ke = sem.element_blocks(el.hx[sel], el.hy[sel], el.p, material.lmbda, material.mu)
    k = cells.shape[1]
    R = np.repeat(cells, k, axis=1).ravel()  # (a, b) pairs: a repeated, b tiled
    C = np.tile(cells, (1, k)).ravel()
    E = np.repeat(sel, k * k)
    V = ke.reshape(-1, 4)
    keep = own[R]
    R, C, E, V = R[keep], C[keep], E[keep], V[keep]
    local = num.block_of_node[R]
    order = np.lexsort((E, C, local))
    start, vals = _sum_in_order(np.column_stack([local[order], C[order]]), V[order])
    row = local[order][start]
    cols = C[order][start]
    ptr = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=num.n_owned))])
    return ptr, cols, vals


def layer_rows(num, material: Material, width: float) -> tuple:
    """The rows of K_L, the stiffness of the cells whose centroid has |x2| < ``width``
    [m] only (a Kelvin–Voigt layer about the interface), as :func:`canonical_rows`
    (the same order and sums; rows outside the layer empty).  One material."""
    el = num.elements
    if el is not None:
        keep = np.abs(el.x2) < width
        return canonical_rows(num._replace(elements=el._replace(
            nodes=el.nodes[keep], hx=el.hx[keep], hy=el.hy[keep], x2=el.x2[keep])), material)
    centroid_x2 = num.x[num.cells][:, :, 1].mean(axis=1)
    return canonical_rows(num._replace(cells=num.cells[np.abs(centroid_x2) < width]), material)


def canonical_mass(num, rho) -> np.ndarray:
    """Row-sum lumped mass of the owned dofs, ∫ ρ N_i dx = Σ_cells ρ A/3 over
    each node's cells in grid-cell order (both components) [kg/m]; ``rho`` a
    scalar or float64[n_grid_cells]."""
    el = num.elements
    cells = num.cells if el is None else el.nodes
    own, sel = _touching(num, cells)
    cells = cells[sel]
    if el is None:
        pa, pb, pc = num.x[cells[:, 0]], num.x[cells[:, 1]], num.x[cells[:, 2]]
        det = (pb[:, 0] - pa[:, 0]) * (pc[:, 1] - pa[:, 1]) - (pc[:, 0] - pa[:, 0]) * (pb[:, 1] - pa[:, 1])
        share = (rho[sel] if np.ndim(rho) else rho) * (0.5 * det) / 3.0  # rho: a scalar or one per grid cell
        V = np.repeat(share, 3)[:, None]
    else:  # the GLL quadrature's diagonal mass, exact (fricfem.model.sem.element_mass)
        V = sem.element_mass(el.hx[sel], el.hy[sel], el.p, rho).reshape(-1, 1)
    R = cells.ravel()
    E = np.repeat(sel, cells.shape[1])
    keep = own[R]
    local = num.block_of_node[R[keep]]
    order = np.lexsort((E[keep], local))
    start, m = _sum_in_order(local[order][:, None], V[keep][order])
    mass = np.empty(num.n_owned)
    mass[local[order][start]] = m[:, 0]
    return np.repeat(mass, 2)


def petsc_matrix(num, rows: tuple, comm) -> PETSc.Mat:
    """K as a PETSc AIJ matrix with the canonical values (I-node kernels off:
    ~3× faster MatMult here), the layout of the displacement vector: the bare
    product the benchmarks compare against, and the eigenvalue estimate."""
    ptr, cols, vals = rows
    n = num.n_owned
    counts = np.diff(ptr)
    gcol = num.global_block[cols]
    # scalar rows 2I, 2I+1: columns (2J, 2J+1) of each block
    rp = np.concatenate([[0], np.cumsum(np.repeat(2 * counts, 2))]).astype(PETSc.IntType)
    jj = np.empty(4 * len(cols), dtype=PETSc.IntType)
    vv = np.empty(4 * len(cols))
    block_of = np.repeat(np.arange(n), counts)
    pos = 2 * ptr[block_of] * 2  # start of the block row's scalar rows in jj (row 2I starts at 4 ptr[I])
    k = np.arange(len(cols)) - ptr[block_of]
    c2 = 2 * counts[block_of]
    for r in range(2):
        base = pos + r * c2 + 2 * k
        jj[base] = 2 * gcol
        jj[base + 1] = 2 * gcol + 1
        vv[base] = vals[:, 2 * r]
        vv[base + 1] = vals[:, 2 * r + 1]
    rowid = np.repeat(np.arange(2 * n), np.diff(rp))
    order = np.lexsort((jj, rowid))  # PETSc wants each row's columns sorted
    jj, vv = jj[order], vv[order]
    K = PETSc.Mat().createAIJ(((2 * n, PETSc.DETERMINE), (2 * n, PETSc.DETERMINE)), csr=(rp, jj, vv), comm=comm)
    K.setOption(PETSc.Mat.Option.USE_INODES, False)
    K.assemble()
    return K


class Stiffness:
    """K as a PETSc matrix (:func:`petsc_matrix`), assembled when first used.

    A run steps with the fused rows (:mod:`fricfem.step.fused`) and takes λmax
    from the set-up cache, so it needs K's vector layout but not the matrix:
    :meth:`createVecRight` makes a vector of that layout without it (~75 ms
    of a 2-rank run's set-up on the reference mesh, and K's memory).  Anything else
    (``mult``, the Lanczos iteration, the benchmarks' bare MatMult) assembles it
    on first use and goes to the matrix; that first use is collective, as the
    product it serves."""

    def __init__(self, num, rows: tuple, comm):
        self._make = lambda: petsc_matrix(num, rows, comm)
        self._mat = None
        self.comm = comm
        self.n_local = 2 * num.n_owned

    @property
    def mat(self) -> PETSc.Mat:
        if self._mat is None:
            self._mat = self._make()
            self._make = None
        return self._mat

    def createVecRight(self) -> PETSc.Vec:  # noqa: N802 (PETSc's name)
        """A vector with K's column layout (the displacement's), as ``Mat.createVecRight``."""
        v = PETSc.Vec().create(comm=self.comm)
        v.setSizes((self.n_local, PETSc.DETERMINE))
        v.setType(PETSc.Vec.Type.STANDARD)
        return v

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.mat, name)


class SemStiffness:
    """K of the spectral elements, matrix-free (:func:`fricfem.kernels.sem.element_ku`):
    never assembled.  ``mult`` (the Lanczos iteration's) gathers the off-rank nodes
    the elements need and applies the kernel; :meth:`kernel_args` are what the
    fused step calls it with.  This rank's elements are every element that
    touches an owned node, in grid order (the sums' order: the same bits on any
    number of ranks).  One material."""

    def __init__(self, num, material: Material, comm):
        el = num.elements
        _, sel = _touching(num, el.nodes)
        nodes = el.nodes[sel]
        local = num.block_of_node[nodes]
        off = (local < 0) | (local >= num.n_owned)
        ghost_nodes = np.unique(nodes[off])  # grid order
        local[off] = num.n_owned + np.searchsorted(ghost_nodes, nodes[off])
        self.ghost = num.global_block[ghost_nodes]
        self.comm = comm
        self.n_local = 2 * num.n_owned
        self._args = (np.ascontiguousarray(local, dtype=np.int64), np.ascontiguousarray(el.hx[sel]),
                      np.ascontiguousarray(el.hy[sel]), float(material.lmbda), float(material.mu),
                      sem.derivative(el.p).copy(), sem.gll(el.p)[1].copy())
        for a in self._args:
            if isinstance(a, np.ndarray):
                a.setflags(write=False)
        self._gather = None

    def kernel_args(self) -> tuple:
        """(nodes as local indices, hx, hy, λ, μ, D, w) for :func:`fricfem.kernels.sem.element_ku`."""
        return self._args

    createVecRight = Stiffness.createVecRight  # noqa: N815 (PETSc's name): a vector of the displacement's layout

    def mult(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = K x (collective)."""
        # lazy: numba's kernels load only where a run needs them (start-up time)
        from ..kernels.sem import element_ku
        from ..step.fused import ghost_gather

        if self._gather is None:  # the fused step's gather of the off-rank nodes (collective)
            self._gather = ghost_gather(self.ghost, x, self.comm)
        scatter, vec = self._gather
        ug = np.zeros(0)
        if scatter is not None:
            scatter.scatter(x, vec, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
            ug = vec.array_r
        n1 = self._args[5].shape[0]  # p + 1; the kernel's work space is the caller's (a model holds no scratch)
        element_ku(*self._args, x.array_r, ug, self.n_local // 2, y.array, np.zeros((3, n1, n1, 2)))


def impact_dofs(V, facet_tags, names) -> np.ndarray:
    """Owned local x1-dof indices on the facets tagged with any of ``names``."""
    if not names:
        return np.zeros(0, dtype=np.int32)
    facets = np.sort(np.concatenate([facet_tags.indices[facet_tags.values == TAGS[n]] for n in names]))
    dofs = fem.locate_dofs_topological(V.sub(0), V.mesh.topology.dim - 1, facets)
    n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    return np.sort(dofs[dofs < n_owned]).astype(np.int32)


def edge_weights(num, names, dofs) -> np.ndarray:
    """A_i = ∫ N_i ds over the grid edges tagged ``names`` at the owned x1 dofs
    ``dofs`` [m per m] (:func:`node_weights`)."""
    return node_weights(num, names)[num.node_of_block[np.asarray(dofs) // 2]]


def node_weights(num, names) -> np.ndarray:
    """A_i = ∫ N_i ds over the grid edges tagged ``names`` at every grid node
    [m per m] (0 off them): each edge's share to each of its nodes (half its
    length; spectral elements: the GLL weights, :func:`_shares`), summed in
    grid-edge order."""
    tags = [TAGS[n] for n in names]
    on = np.isin(num.facet_tags, tags)
    edges = num.facets[on]
    R = edges.ravel()
    E = np.repeat(np.arange(len(edges)), 2)
    order = np.lexsort((E, R))
    start, w = _sum_in_order(R[order][:, None], _shares(num, on).ravel()[order][:, None])
    weight = np.zeros(len(num.x))
    weight[R[order][start]] = w[:, 0]
    return weight


def _shares(num, on) -> np.ndarray:
    """The facets ``on`` (a mask)'s shares of ∫ N_i ds for their two nodes,
    float64[n, 2] [m]: half of each edge's length (crossed triangles), or the
    GLL weights (spectral elements: ``num.facet_share``)."""
    if num.facet_share is not None:
        return num.facet_share[on]
    edges = num.facets[on]
    length = np.linalg.norm(num.x[edges[:, 1]] - num.x[edges[:, 0]], axis=1)
    return np.repeat(0.5 * length, 2).reshape(-1, 2)


def dashpots(num, names, material: Material) -> tuple:
    """Lysmer–Kuhlemeyer dashpots on the outer edges ``names`` (of
    :data:`fricfem.model.grid.OUTER`): the traction −ρ c_l v_n n − ρ c_s v_t t,
    lumped to the nodes as A_i ρ c per component (A_i half of each adjacent
    edge's length, summed in grid-edge order), normal component ρ c_l, the
    other ρ c_s.  Returns (owned local blocks int64[m], coefficients
    float64[m, 2] (x1, x2) [N·s/m², per m thickness])."""
    if not names:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2))
    rows, vals, order_e = [], [], []
    for name in names:
        on = num.facet_tags == TAGS[name]
        edges = num.facets[on]
        normal_x = name in ("left", "right")  # the others are the far edges, normal along x2
        cn, ct = material.rho * material.c_l, material.rho * material.c_s
        c = np.array([cn, ct] if normal_x else [ct, cn])
        rows.append(edges.ravel())
        vals.append(_shares(num, on).ravel()[:, None] * c[None, :])
        order_e.append(np.repeat(np.flatnonzero(num.facet_tags == TAGS[name]), 2))
    R, V, E = np.concatenate(rows), np.vstack(vals), np.concatenate(order_e)
    local = num.block_of_node[R]
    mine = (local >= 0) & (local < num.n_owned)
    R, V, E, local = R[mine], V[mine], E[mine], local[mine]
    order = np.lexsort((E, local))
    start, c = _sum_in_order(local[order][:, None], V[order])
    return local[order][start], c


def _coordinate_noise(num) -> np.ndarray:
    """A deterministic pseudo-random vector keyed on the grid coordinates of the
    owned dofs (identical on any number of ranks), to start the Lanczos iteration."""
    x = num.x[num.owned_nodes]
    h = np.sin(x[:, 0] * 12989.8 + x[:, 1] * 78233.0) * 43758.5453
    h = h - np.floor(h)
    return np.column_stack([h, 1.0 - h]).ravel() - 0.5


def ordered_sum(comm, local) -> np.ndarray:
    """The ranks' partial sums ``local`` (float64[k], one set a rank) added in
    rank order, 0, 1, 2, ...: the same bits on every rank and on every run
    with this number of ranks (an ``Allreduce`` may add in an order of the MPI
    library's choosing).  Collective on ``comm`` (mpi4py)."""
    local = np.ascontiguousarray(local, dtype=np.float64)
    parts = np.empty((comm.size, local.size))
    comm.Allgather(local, parts)
    total = parts[0].copy()
    for r in range(1, comm.size):
        total = total + parts[r]
    return total


#: the Lanczos iteration checks its largest Ritz value every this many steps, and stops when
#: it has not moved over WINDOW checks
CHECK_EVERY = 5
WINDOW = 8


def max_eigenvalue(K, mass, interface, num, iterations=600, rtol=1e-12) -> float:
    """λmax of M⁻¹(K + K_int), by the Lanczos iteration on the symmetric
    A = M^-½ (K + K_int) M^-½ from a deterministic start (:func:`_coordinate_noise`).

    The largest Ritz value (the largest eigenvalue of the Lanczos tridiagonal,
    :func:`fricfem.kernels.reduce.tridiagonal_max`, by bisection) rises to λmax from below and
    converges far faster than the power iteration's Rayleigh quotient, whose
    increments grew too small to notice while it still lay 8e-4 below λmax on
    the reference meshes (the stable step was overstated by 2e-4).  No
    reorthogonalisation: a lost orthogonality only repeats converged Ritz
    values, never raises the largest above λmax.  Stops when the largest Ritz
    value changes by less than ``rtol`` of itself over :data:`WINDOW` checks,
    :data:`CHECK_EVERY` steps apart.

    The dot products are fricfem's own sequential sums (:func:`fricfem.kernels.reduce.dot`),
    each rank's added in rank order (:func:`ordered_sum`), not a BLAS's, and the
    tridiagonal's eigenvalue is plain float arithmetic: λmax, and ``dt_crit_s``,
    are the same bits under any BLAS on any processor (for a given number of ranks)."""
    # lazy: start-up time (it loads numba)
    from ..kernels.reduce import dot, tridiagonal_max

    x = K.createVecRight()
    y = K.createVecRight()
    comm = x.getComm().tompi4py()
    scale = 1.0 / np.sqrt(np.ascontiguousarray(mass, dtype=np.float64))

    def norm(v):
        return math.sqrt(ordered_sum(comm, [dot(v, v)])[0])

    q = _coordinate_noise(num)
    q = q / norm(q)
    q_prev = np.zeros_like(q)
    alphas, betas = [], []
    beta = 0.0
    lam = 0.0
    ritz = []
    for k in range(iterations):  # noqa: B007 (k: the step count)
        x.array[:] = scale * q
        K.mult(x, y)
        interface.add_spring_action(x, y)
        w = scale * y.array_r
        alpha = ordered_sum(comm, [dot(q, w)])[0]
        w = w - alpha * q - beta * q_prev
        alphas.append(alpha)
        converged = False
        if k % CHECK_EVERY == CHECK_EVERY - 1:  # the Ritz value every few steps: its bisection is the cost
            lam = tridiagonal_max(np.array(alphas), np.array(betas))
            ritz.append(lam)
            # still over a window of WINDOW checks: a Ritz value can creep for tens of steps at a
            # near-degenerate top (degree 4 on 6 × 3 mm: 6.6e-9 below λmax from step 40 to 70)
            converged = len(ritz) > WINDOW and abs(lam - ritz[-1 - WINDOW]) <= rtol * lam
        beta = norm(w)
        if converged or beta <= 1e-300 * lam:
            break
        betas.append(beta)
        q_prev, q = q, w / beta
    return float(lam)


def round_down(x: float, digits: int = 3) -> float:
    """Round down to ``digits`` significant digits (makes dt reproducible across rank counts)."""
    e = math.floor(math.log10(x)) - digits + 1
    return math.floor(x / 10.0**e + 1e-9) * 10.0**e
