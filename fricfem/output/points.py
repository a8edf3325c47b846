"""Points in the grid: the triangle of the grid that holds a point, its linear
shape functions there (:func:`locate`, :func:`shape_gradients`), and the values
of given grid nodes gathered onto rank 0 with one exact reduction
(:class:`NodeValues`).  The gauges (:mod:`.gauges`, :mod:`.line_gauges`) and the
field output's stress (:mod:`.fields`) are built on them.

Everything here works on the grid every rank rebuilds (``model.num``: node
coordinates ``x``, triangles ``cells``, each node's block on this rank), so the
results are the same on every rank and on any number of ranks.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Located:
    """Where the gauges are in the grid (the same on every rank).

    triangle  int64[n, 3]      grid nodes of the triangle holding each gauge
    weights   float64[n, 3]    N_i(x) of those nodes at the gauge (sum 1)
    grads     float64[n, 3, 2] ∇N_i [1/m]
    vertices  float64[n, 3, 2] the triangle's vertices [m]
    """

    triangle: np.ndarray
    weights: np.ndarray
    grads: np.ndarray
    vertices: np.ndarray


def inverse_2x2(jac: np.ndarray) -> np.ndarray:
    """J⁻¹ of each 2×2 matrix of float64[n, 2, 2], with the very operations of
    reference LAPACK's ``dgesv`` on B = I (what ``np.linalg.inv`` calls):
    partial pivoting (the row with the larger |J_i0|, the first on a tie),
    l = J_10 · (1/J_00), u_11 = J_11 − l J_01, forward then back substitution.
    So it gives the bits ``np.linalg.inv`` gives with reference LAPACK (the
    goldens' fields), but under any LAPACK on any processor: OpenBLAS's
    ``dgesv`` rounds differently on 58 % of random matrices, and differently
    again by processor kernel.  Singular matrices give inf/nan, as there."""
    a00, a01, a10, a11 = jac[:, 0, 0], jac[:, 0, 1], jac[:, 1, 0], jac[:, 1, 1]
    swap = np.abs(a10) > np.abs(a00)
    p00, p01 = np.where(swap, a10, a00), np.where(swap, a11, a01)  # the pivot row
    q10, q11 = np.where(swap, a00, a10), np.where(swap, a01, a11)
    l10 = q10 * (1.0 / p00)
    u11 = q11 - l10 * p01
    out = np.empty(jac.shape)
    one, zero = np.ones(len(jac)), np.zeros(len(jac))
    for j, (e0, e1) in enumerate(((one, zero), (zero, one))):  # the identity's columns, rows as pivoted
        b0, b1 = np.where(swap, e1, e0), np.where(swap, e0, e1)
        x1 = (b1 - b0 * l10) / u11
        out[:, 1, j] = x1
        out[:, 0, j] = (b0 - x1 * p01) / p00
    return out


def shape_gradients(p: np.ndarray) -> np.ndarray:
    """∂N_a/∂x_j [1/m] of the linear shape functions of each triangle:
    float64[n, 3, 2], from its vertices ``p`` float64[n, 3, 2] [m].  With
    J = [p1 − p0, p2 − p0] (columns), ∇N_1, ∇N_2 are the rows of J⁻¹, so
    ``[:, 1:]`` is J⁻¹ itself (the gauges' barycentric coordinates use it)."""
    jac = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)  # J[c, i, k] = ∂x_i/∂ξ_k
    inv = inverse_2x2(jac)  # ∇N_k = row k of J⁻¹ (k = 1, 2)
    grad = np.empty((len(p), 3, 2))
    grad[:, 1:] = inv
    grad[:, 0] = -inv[:, 0] - inv[:, 1]
    return grad


def locate(x: np.ndarray, cells: np.ndarray, points: np.ndarray) -> Located:
    """The triangle of ``cells`` (grid nodes ``x``) holding each point [m], in the
    plate of the point's x2 sign (the interface's two node rows coincide, so a
    triangle of the other plate may touch it); the lowest-numbered triangle
    when a point lies on an edge.  Raises ValueError for a point on no plate.
    Setup only: one vectorized pass over the triangles per point."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    p = x[cells]  # [n_cells, 3, 2]
    lo, hi = p.min(axis=1), p.max(axis=1)
    upper = p[:, :, 1].mean(axis=1) > 0.0
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    found = np.zeros(len(points), dtype=np.int64)
    for k, (px, py) in enumerate(points):  # setup: once per gauge
        tol = 1e-9 * max(abs(px), abs(py), 1e-3)
        cand = np.flatnonzero((lo[:, 0] <= px + tol) & (hi[:, 0] >= px - tol) & (lo[:, 1] <= py + tol)
                              & (hi[:, 1] >= py - tol) & (upper == (py > 0.0)))
        d = np.array([px, py]) - p[cand, 0]
        l1 = (d[:, 0] * e2[cand, 1] - d[:, 1] * e2[cand, 0]) / det[cand]
        l2 = (e1[cand, 0] * d[:, 1] - e1[cand, 1] * d[:, 0]) / det[cand]
        inside = np.flatnonzero(np.minimum(np.minimum(l1, l2), 1.0 - l1 - l2) >= -1e-9)
        if not len(inside):
            raise ValueError(f"gauge at ({px:g}, {py:g}) m lies on no plate of the mesh")
        found[k] = cand[inside[0]]
    tri = cells[found]
    v = x[tri]
    grads = shape_gradients(v)  # ∇λ0, ∇λ1, ∇λ2; the last two are J⁻¹'s rows, J = [p1 − p0, p2 − p0]
    lam = np.einsum("nij,nj->ni", grads[:, 1:], points - v[:, 0])  # (λ1, λ2) = J⁻¹ (x − p0)
    weights = np.column_stack([1.0 - lam.sum(axis=1), lam])
    return Located(tri, weights, grads, v)

class NodeValues:
    """Gathers (u1, u2, v1, v2) of given grid nodes onto rank 0 with one reduction,
    the core of every gauge here.  ``nodes`` int64 grid nodes of any shape S (a
    node may repeat); ``extra`` values per sample that each rank adds its own share
    of (summed by the same reduction).  Each rank writes the values of the nodes
    it owns into a send buffer [S, 4] (zeros elsewhere): every entry has exactly
    one owner, so the sum is exact and the values bit-identical on any number of
    ranks."""

    def __init__(self, num, comm, nodes: np.ndarray, extra: int = 0):
        self.comm = comm
        self.shape = np.shape(nodes)
        blk = num.block_of_node[np.asarray(nodes, dtype=np.int64)].ravel()  # this rank's block of each, or −1
        owned = (blk >= 0) & (blk < num.n_owned)
        slots = np.flatnonzero(owned)  # the entries this rank supplies, flat
        self.dofs = (2 * blk[owned, None] + np.arange(2)).ravel()  # their (x1, x2) dofs in the owned arrays
        self.to_u = (4 * slots[:, None] + np.arange(2)).ravel()  # where u1, u2 go in the flat send buffer
        self.to_v = self.to_u + 2  # v1, v2
        self.n = 4 * len(blk)
        self.send = np.zeros(self.n + extra)
        self.recv = np.zeros_like(self.send) if comm.rank == 0 else None

    def gather(self, state, extra=()) -> np.ndarray | None:
        """The nodes' values float64[S, 4] on rank 0, a copy (the summed ``extra``:
        :attr:`extra_sum`); None elsewhere.  Collective."""
        self.send[self.to_u] = state.u.array_r[self.dofs]  # 1-D fancy indexing: ~1 µs for 100 gauges
        self.send[self.to_v] = state.v.array_r[self.dofs]
        self.send[self.n:] = extra
        self.comm.Reduce(self.send, self.recv, root=0)  # op: MPI.SUM  # one owner per node entry: exact
        if self.comm.rank != 0:
            return None
        return self.recv[: self.n].reshape(*self.shape, 4).copy()

    @property
    def extra_sum(self) -> np.ndarray:
        """The ``extra`` of the last :meth:`gather`, summed over ranks (rank 0)."""
        return self.recv[self.n:].copy()
