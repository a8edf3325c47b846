"""Gauges: point histories inside the plates (``output.gauges``) → ``gauges.h5``,
and line gauges kept in memory (:class:`LineGauges`: the experiment's strain
gauges, struck-edge velocities and projectile).  Both gather the values of
their nodes onto rank 0 the same way (:class:`NodeValues`).

A gauge at (x1, x2) records, every ``output.gauges_every`` steps, what a
strain gauge, a vibrometer or a photoelastic reading there would see:

- ``displacement`` [m] and ``velocity`` [m/s] (x1, x2 components), the linear
  interpolation of the nodal values in the triangle that holds the point;
- ``strain`` (ε11, ε22, ε12; ε12 the tensor component) and ``stress`` [Pa]
  (σ11, σ22, σ12, the prestress S22 = −Σ0, S12 = τ0 included) of that
  triangle (piecewise constant in linear triangles);
- ``stress_difference`` σ1 − σ2 [Pa], as in the field output.

Displacement, strain and stress hold at ``time`` (t^n); the central-difference
velocity is v^{n−½}, at ``velocity_time`` = time − dt/2.

How it is computed.  Each gauge's triangle, its three grid nodes, their linear
weights N_i(x) and gradients ∇N_i are found once (:func:`locate`, on the
grid every rank rebuilds).  At a sample each rank copies the values of the
nodes it owns into a small array [gauges, 3, 4] (zeros elsewhere) and one
reduction brings it to rank 0 — every entry has exactly one owner, so the
sum is exact; rank 0 keeps it, and evaluates the samples of a flush together,
vectorized over samples and gauges.  So the histories are bit-identical on
any number of ranks, and there is no Python loop over gauges in the time
loop.

File layout (``gauges.h5``, SI, every dataset with a ``unit`` attribute):
``gauge/name`` [n_g], ``gauge/position`` [n_g, 2] (as asked) and
``gauge/triangle`` [n_g, 3, 2] (the triangle's vertices); ``time`` and
``velocity_time`` [n_t]; ``displacement``, ``velocity`` [n_t, n_g, 2];
``strain``, ``stress`` [n_t, n_g, 3]; ``stress_difference`` [n_t, n_g].  The
valid rows are the leading rows whose time is finite (:class:`GaugeWriter`
says how the file survives a kill).
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np

from ..kernels.reduce import dot

GAUGES_FILE = "gauges.h5"

#: dataset -> (unit, component names, meaning); per-gauge histories, in file order.
QUANTITIES = {
    "displacement": ("m", ("u1", "u2"), "displacement u at time"),
    "velocity": ("m/s", ("v1", "v2"), "velocity v at velocity_time = time - dt/2 (central differences)"),
    "strain": ("", ("e11", "e22", "e12"), "infinitesimal strain of the triangle holding the gauge, at time"),
    "stress": ("Pa", ("s11", "s22", "s12"), "in-plane stress of that triangle, prestress included, at time"),
    "stress_difference": ("Pa", (), "sigma1 - sigma2 (prestress included), at time"),
}


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


def evaluate(nodal: np.ndarray, loc: Located, mu: float, lmbda: float, sigma0: float, tau0: float) -> dict:
    """Gauge values from the nodal values ``nodal`` float64[..., n, 3, 4] (u1, u2, v1, v2
    of each gauge's three nodes, for any leading sample axes): {quantity of
    :data:`QUANTITIES`: float64[..., n(, components)]}.  ``mu``, ``lmbda``: the
    in-plane Lamé constants [Pa] (plane stress or strain)."""
    u, v = nodal[..., 0:2], nodal[..., 2:4]
    grad = np.einsum("...nkc,nkd->...ncd", u, loc.grads)  # ∂u_c/∂x_d
    e11, e22 = grad[..., 0, 0], grad[..., 1, 1]
    e12 = 0.5 * (grad[..., 0, 1] + grad[..., 1, 0])
    tr = e11 + e22
    s11 = 2.0 * mu * e11 + lmbda * tr
    s22 = 2.0 * mu * e22 + lmbda * tr - sigma0
    s12 = 2.0 * mu * e12 + tau0
    return {
        "displacement": np.einsum("nk,...nkc->...nc", loc.weights, u),
        "velocity": np.einsum("nk,...nkc->...nc", loc.weights, v),
        "strain": np.stack([e11, e22, e12], axis=-1),
        "stress": np.stack([s11, s22, s12], axis=-1),
        "stress_difference": 2.0 * np.sqrt((0.5 * (s11 - s22)) ** 2 + s12 ** 2),
    }


class NodeValues:
    """Gathers (u1, u2, v1, v2) of given grid nodes onto rank 0 with one reduction,
    the core of every gauge here.  ``nodes`` int64 grid nodes of any shape S (a
    node may repeat); ``extra`` values per sample that each rank adds its own share
    of (summed by the same reduction).  Each rank writes the values of the nodes
    it owns into a send buffer [S, 4] (zeros elsewhere): every entry has exactly
    one owner, so the sum is exact and the values bit-identical on any number of
    ranks."""

    def __init__(self, num, comm, nodes: np.ndarray, extra: int = 0):
        from mpi4py import MPI  # here, so that reading gauges.h5 needs no MPI

        self.comm, self.sum = comm, MPI.SUM
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
        self.comm.Reduce(self.send, self.recv, op=self.sum, root=0)  # one owner per node entry: exact
        if self.comm.rank != 0:
            return None
        return self.recv[: self.n].reshape(*self.shape, 4).copy()

    @property
    def extra_sum(self) -> np.ndarray:
        """The ``extra`` of the last :meth:`gather`, summed over ranks (rank 0)."""
        return self.recv[self.n:].copy()


class GaugeWriter:
    """Samples the scene's gauges every ``output.gauges_every`` steps into ``gauges.h5``
    (:meth:`observe` is collective; rank 0 writes).

    Crash safety, as ``interface.h5`` (:mod:`.recorder`): the file is laid out whole
    before the run (every dataset the size of the full run, allocated and filled
    with NaN, all metadata written once) under a temporary name renamed when
    complete; a flush writes the new rows' values, flushes, then their times and
    flushes again, so the valid rows are the leading rows with a finite time.  A
    run that ends early is compacted to the rows it has.  Creating the file is
    collective: an error is raised as OSError on every rank.
    """

    def __init__(self, path: Path, scene, model):
        from ..scene.output_keys import check_gauges

        table = check_gauges(scene.output["gauges"], scene.mesh)
        self.names = tuple(table)
        self.points = np.array([table[n] for n in self.names], dtype=np.float64).reshape(-1, 2)
        self.every = int(scene.output["gauges_every"])
        self.comm = model.comm
        self.dt = model.dt
        self.planned = int(math.floor(scene.t_end / model.dt + 1e-9)) // self.every + 1  # rows, t = 0 included
        self.path = Path(path)
        mat = scene.material
        self.constants = (mat.mu, mat.lmbda, scene.sigma0, scene.tau0)
        num = model.num
        self.loc = locate(num.x, num.cells, self.points)
        self.nodal = NodeValues(num, self.comm, self.loc.triangle)
        self.pending = []  # (t, nodal values [n_g, 3, 4]) gathered on rank 0, evaluated at the flush
        self.written = 0
        self.h5 = error = None
        if self.comm.rank == 0:
            try:
                self.h5 = self._create(scene)
            except OSError as err:
                error = err
        error = self.comm.bcast(error, root=0)
        if error is not None:
            raise error

    def _create(self, scene):
        """Lay the file out whole under a temporary name, flush it, rename it (rank 0)."""
        import h5py

        from .recorder import check_space, h5_error

        tmp = self.path.with_name(f".{self.path.name}.part")
        tmp.unlink(missing_ok=True)
        # HDF5 crashes on a write that fails while it lays a file out: the file must fit (a run that reaches
        # its end needs no copy of it; one stopped early keeps it as laid out if its copy does not fit)
        values = 2 + len(self.names) * sum(max(1, len(comps)) for _, comps, _ in QUANTITIES.values())
        check_space(self.path, 8 * self.planned * values + (64 << 10) + 2048 * len(QUANTITIES), "the gauges file")
        try:
            f = h5py.File(tmp, "w")
        except OSError as err:
            raise h5_error(err, tmp) from None
        try:
            n, rows = len(self.names), self.planned
            f.attrs.update(scene=scene.name, units="SI", every_steps=self.every, dt=self.dt, rows_planned=rows,
                           sigma0=scene.sigma0, tau0=scene.tau0, plane=scene.material.plane,
                           valid_rows="the leading rows whose time is finite (NaN: not computed)")
            g = f.create_group("gauge")
            g.create_dataset("name", data=np.array(self.names, dtype=object), dtype=h5py.string_dtype())
            for name, data in (("position", self.points), ("triangle", self.loc.vertices)):
                g.create_dataset(name, data=data).attrs["unit"] = "m"
            for name in ("time", "velocity_time"):
                _allocated(f, name, (rows,), "s", "")
            for q, (unit, comps, doc) in QUANTITIES.items():
                d = _allocated(f, q, (rows, n, len(comps)) if comps else (rows, n), unit, doc)
                d.attrs["components"] = ",".join(comps)
            f.flush()
            os.replace(tmp, self.path)
        except BaseException as err:
            f.close()
            tmp.unlink(missing_ok=True)
            if isinstance(err, OSError):
                raise h5_error(err, self.path) from None
            raise
        return f

    def observe(self, state) -> None:
        """Sample the gauges if step ``state.n`` is due (collective then)."""
        if state.n % self.every:
            return
        values = self.nodal.gather(state)
        if values is not None:
            self.pending.append((state.t, values))

    def flush(self) -> None:
        """Write the pending rows (rank 0; no communication): values, an HDF5 flush,
        then their times, another flush."""
        f = self.h5
        if f is None:
            return
        n0 = self.written
        n1 = min(n0 + len(self.pending), self.planned)
        if n1 > n0:
            rows = self.pending[: n1 - n0]
            t = np.array([r[0] for r in rows])
            values = evaluate(np.stack([r[1] for r in rows]), self.loc, *self.constants)  # all rows at once
            for q, a in values.items():
                f[q][n0:n1] = a
            f["velocity_time"][n0:n1] = t - 0.5 * self.dt
            f.flush()
            f["time"][n0:n1] = t
            self.pending.clear()
            self.written = n1
        f.flush()

    def close(self) -> None:
        """Flush and close (rank 0); a file with fewer rows than planned (the run ended
        early) is replaced by a copy of its valid rows."""
        self.flush()
        if self.h5 is None:
            return
        self.h5.close()
        self.h5 = None
        if self.written < self.planned:
            from .recorder import compact

            compact(self.path, {"": self.written})


def _allocated(f, name: str, shape, unit: str, doc: str):
    """A contiguous float64 dataset allocated and filled with NaN at creation."""
    import h5py

    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    dcpl.set_fill_time(h5py.h5d.FILL_TIME_ALLOC)
    dcpl.set_fill_value(np.array(np.nan))
    d = f.create_dataset(name, shape=shape, dtype="f8", dcpl=dcpl)
    d.attrs.update(unit=unit, meaning=doc)
    return d


@dataclasses.dataclass
class Gauge:
    """One gauge's histories, SI (see :data:`QUANTITIES`): ``velocity`` float64[n_t, 2]
    at ``velocity_time``; ``displacement`` [n_t, 2], ``strain``, ``stress`` [n_t, 3]
    (11, 22, 12) and ``stress_difference`` [n_t] at ``time``."""

    name: str
    x1: float
    x2: float
    time: np.ndarray
    velocity_time: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    strain: np.ndarray
    stress: np.ndarray
    stress_difference: np.ndarray


class GaugeFile:
    """The valid rows of a run's ``gauges.h5`` (those with a finite time: a run still
    going or killed reads as far as it was flushed): ``names``, ``position``
    [n_g, 2] and ``triangle`` [n_g, 3, 2] [m], ``time``, ``velocity_time`` [s],
    ``data[quantity]``, ``units``; ``gauges[name]`` -> :class:`Gauge`."""

    def __init__(self, path):
        from .rundir import _h5open, valid_rows

        self.path = Path(path)
        try:
            self._read(_h5open, valid_rows)
        except (KeyError, ValueError, TypeError, IndexError) as err:  # h5py's errors name no file
            raise OSError(None, f"not a gauges file fricfem wrote, or damaged ({type(err).__name__}: "
                          f"{' '.join(str(err).split())})", str(self.path)) from None

    def _read(self, _h5open, valid_rows) -> None:
        with _h5open(self.path) as f:
            n = valid_rows(f["time"])
            g = f["gauge"]
            self.names = tuple(s.decode() if isinstance(s, bytes) else str(s) for s in g["name"][...])
            self.position = g["position"][...]
            self.triangle = g["triangle"][...]
            self.time = f["time"][:n]
            self.velocity_time = f["velocity_time"][:n]
            self.data = {q: f[q][:n] for q in QUANTITIES}
            self.components = {q: tuple(c for c in str(f[q].attrs.get("components", "")).split(",") if c)
                               for q in QUANTITIES}
        self.units = {"time": "s", "velocity_time": "s", "position": "m", **{q: QUANTITIES[q][0] for q in QUANTITIES}}

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name) -> bool:
        return name in self.names

    def __getitem__(self, name: str) -> Gauge:
        if name not in self.names:
            raise KeyError(f"{self.path}: no gauge {name!r}; has {', '.join(self.names)}")
        k = self.names.index(name)
        return Gauge(name, float(self.position[k, 0]), float(self.position[k, 1]), self.time, self.velocity_time,
                     **{q: self.data[q][:, k] for q in QUANTITIES})


def open_gauges(rundir) -> GaugeFile | None:
    """The gauges of a run directory (or a ``gauges.h5`` path); None if it wrote none."""
    path = Path(rundir)
    path = path / GAUGES_FILE if path.is_dir() else path
    return GaugeFile(path) if path.is_file() else None


def _lower_nodes(num) -> np.ndarray:
    """bool[n_grid]: grid nodes of cells whose centroid lies below the interface."""
    below = num.x[num.cells].mean(axis=1)[:, 1] < 0.0
    mark = np.zeros(len(num.x), dtype=bool)
    mark[np.unique(num.cells[below])] = True
    return mark


def line_nodes(num, lower: np.ndarray, X: float, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The nodes of ``lower`` on the node line x1 = X with a ≤ x2 ≤ b and their
    weights ∫N_i ds along it [m] (nodes at one position share its weight)."""
    idx = np.flatnonzero(lower & (num.x[:, 0] == X) & (num.x[:, 1] >= a) & (num.x[:, 1] <= b))
    ys, at = np.unique(num.x[idx, 1], return_inverse=True)
    w = np.zeros(len(ys))
    d = np.diff(ys)
    w[:-1] += 0.5 * d
    w[1:] += 0.5 * d
    return idx, w[at]


class LineGauges:
    """Gauges along segments of the lower plate, the buffer and the projectile,
    recorded after every step (a runner's ``on_step``) and kept in memory: what a
    strain gauge or a velocity probe on the specimen would record, and, for a
    model with the experiment's bodies (:mod:`fricfem.model.bodies`), the
    projectile's mean velocity and contact force.

    ``lines`` {name: (X, x2_min, x2_max, h)} [m]: the segment x1 = X (the nearest
    node line), x2_min ≤ x2 ≤ x2_max, gives ``name.v1``, the mean x1 velocity over
    its nodes, each weighted by its share of the segment (∫N_i ds), and
    ``name.eps11`` = (ū1(X + h) − ū1(X − h))/(2h), the same means of u1 on the
    neighbouring node lines (a strain gauge of length 2h across the segment).
    With bodies: ``projectile.v1`` = Σ M v1 / Σ M and ``contact_force`` [N/m],
    the force the contact presses it with, at the interface time t^n.
    Velocities are v^{n+½} (``t_v``), displacements u^{n+1} (``t_u``).  Only
    nodes of cells below the interface count, so the upper plate's interface
    node is never mixed in.  The nodes' values come to rank 0 through
    :class:`NodeValues` (exact, the same on any number of ranks)."""

    def __init__(self, model, lines: dict):
        self.model = model
        num = model.num
        lower = _lower_nodes(num)
        xs = np.unique(num.x[lower, 0])  # the node lines x1 = const below the interface
        nodes, weights, self.names, self.dx = [], [], tuple(lines), []
        self.positions = {}  # name: the node lines' x1 (X, X + h, X − h) [m]
        for name, (X, a, b, h) in lines.items():
            at = []
            for off in (0.0, h, -h):
                near = xs[np.argmin(np.abs(xs - (X + off)))]
                idx, w = line_nodes(num, lower, near, a, b)
                if not len(idx):
                    raise ValueError(f"line gauge {name}: no node on x1 = {near:g} m within x2 = [{a:g}, {b:g}] m")
                nodes.append(idx)
                weights.append(w)
                at.append(near)
            self.dx.append(at[1] - at[2])
            self.positions[name] = tuple(at)
        self.starts = np.cumsum([0] + [len(i) for i in nodes[:-1]])
        self.w = np.concatenate(weights)
        self.wsum = np.add.reduceat(self.w, self.starts)
        bodies = model.bodies
        self.nodal = NodeValues(num, model.comm, np.concatenate(nodes), extra=3 if bodies is not None else 0)
        if bodies is not None:
            self.dofs = 2 * bodies.nodes
            self.m = model.mass[self.dofs]
        self.rows = []

    def record(self, state) -> None:
        """Add this step's values (collective)."""
        extra = ()
        b = self.model.bodies
        if b is not None:
            p, geo = b.contact.points, b.contact.geometry
            extra = (dot(self.m, state.v.array_r[self.dofs]), self.m.sum(), dot(p.Tn, geo.wq))  # not BLAS's order
        nodal = self.nodal.gather(state, extra)
        if nodal is None:
            return
        mean = np.add.reduceat(self.w[:, None] * nodal[:, [2, 0]], self.starts) / self.wsum[:, None]
        mean = mean.reshape(-1, 3, 2)  # [line, (X, X + h, X − h), (v1, u1)]
        row = [state.t - 0.5 * self.model.dt, state.t]
        row += np.column_stack([mean[:, 0, 0], (mean[:, 1, 1] - mean[:, 2, 1]) / self.dx]).ravel().tolist()
        if b is not None:
            s = self.nodal.extra_sum
            row += [s[0] / s[1], s[2]]
        self.rows.append(row)

    def result(self) -> dict | None:
        """{quantity: float64[n_steps]} on rank 0 (None elsewhere): ``t_v``, ``t_u``,
        ``name.v1``, ``name.eps11`` per line, then ``projectile.v1`` and
        ``contact_force`` with bodies."""
        if self.model.comm.rank != 0:
            return None
        keys = ["t_v", "t_u"] + [f"{n}.{q}" for n in self.names for q in ("v1", "eps11")]
        keys += ["projectile.v1", "contact_force"] if self.model.bodies is not None else []
        if not self.rows:
            return {}
        return dict(zip(keys, np.array(self.rows).T.copy()))
