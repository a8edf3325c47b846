"""Gauges: point histories inside the plates (``output.gauges``) → ``gauges.h5``,
written (:class:`GaugeWriter`) and read (:class:`GaugeFile`, :func:`open_gauges`)
here.  The gauges' quantities, units and components are the run directory's
table (:data:`fricfem.output.quantities.GAUGE_QUANTITIES`); the grid nodes'
values come to rank 0 through :class:`.points.NodeValues`.

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
weights N_i(x) and gradients ∇N_i are found once (:func:`.points.locate`, on the
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

import h5py
import numpy as np

from ..scene.output_keys import check_gauges
from .directory import RunDirError
from .points import Located, NodeValues, locate
from .quantities import GAUGE_QUANTITIES, GAUGES_FILE
from .recorder import check_space, compact, h5_error
from .rundir import _h5open, valid_rows


def evaluate(nodal: np.ndarray, loc: Located, mu: float, lmbda: float, sigma0: float, tau0: float) -> dict:
    """Gauge values from the nodal values ``nodal`` float64[..., n, 3, 4] (u1, u2, v1, v2
    of each gauge's three nodes, for any leading sample axes): {quantity of
    :data:`GAUGE_QUANTITIES`: float64[..., n(, components)]}.  ``mu``, ``lmbda``: the
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
        table = check_gauges(scene.output.gauges, scene.mesh)
        self.names = tuple(table)
        self.points = np.array([table[n] for n in self.names], dtype=np.float64).reshape(-1, 2)
        self.every = scene.output.gauges_every
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
        tmp = self.path.with_name(f".{self.path.name}.part")
        tmp.unlink(missing_ok=True)
        # HDF5 crashes on a write that fails while it lays a file out: the file must fit (a run that reaches
        # its end needs no copy of it; one stopped early keeps it as laid out if its copy does not fit)
        values = 2 + len(self.names) * sum(max(1, len(comps)) for _, comps, _ in GAUGE_QUANTITIES.values())
        check_space(self.path, 8 * self.planned * values + (64 << 10) + 2048 * len(GAUGE_QUANTITIES), "the gauges file")
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
            for q, (unit, comps, doc) in GAUGE_QUANTITIES.items():
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

    def resume(self, old: Path, rows: int) -> None:
        """Continue a run from its checkpoint (collective): the first ``rows`` rows of the
        killed or stopped run's file ``old`` into this freshly laid-out file, values
        before times (as :meth:`fricfem.output.recorder.Recorder.resume`)."""
        error = None
        if self.comm.rank == 0:
            try:
                with _h5open(old) as f:
                    have = valid_rows(f["time"])
                    if have < rows:
                        raise OSError(None, f"holds {have} rows, the checkpoint counts {rows}", str(old))
                    if rows:
                        for q in (*GAUGE_QUANTITIES, "velocity_time"):
                            self.h5[q][:rows] = f[q][:rows]
                        self.h5.flush()
                        self.h5["time"][:rows] = f["time"][:rows]
                        self.h5.flush()
                self.written = rows
                self.pending.clear()  # the row at t = 0 taken when the run was set up: in the file already
            except (OSError, KeyError) as err:
                error = f"{old}: cannot resume from it: {err.strerror if isinstance(err, OSError) else err}"
        error = self.comm.bcast(error, root=0)
        if error is not None:
            raise RunDirError(error)

    def close(self) -> None:
        """Flush and close (rank 0); a file with fewer rows than planned (the run ended
        early) is replaced by a copy of its valid rows."""
        self.flush()
        if self.h5 is None:
            return
        self.h5.close()
        self.h5 = None
        if self.written < self.planned:
            compact(self.path, {"": self.written})


def _allocated(f, name: str, shape, unit: str, doc: str):
    """A contiguous float64 dataset allocated and filled with NaN at creation."""
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    dcpl.set_fill_time(h5py.h5d.FILL_TIME_ALLOC)
    dcpl.set_fill_value(np.array(np.nan))
    d = f.create_dataset(name, shape=shape, dtype="f8", dcpl=dcpl)
    d.attrs.update(unit=unit, meaning=doc)
    return d


@dataclasses.dataclass
class Gauge:
    """One gauge's histories, SI (see :data:`GAUGE_QUANTITIES`): ``velocity`` float64[n_t, 2]
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
        self.path = Path(path)
        try:
            self._read()
        except (KeyError, ValueError, TypeError, IndexError) as err:  # h5py's errors name no file
            raise OSError(None, f"not a gauges file fricfem wrote, or damaged ({type(err).__name__}: "
                          f"{' '.join(str(err).split())})", str(self.path)) from None

    def _read(self) -> None:
        with _h5open(self.path) as f:
            n = valid_rows(f["time"])
            g = f["gauge"]
            self.names = tuple(s.decode() if isinstance(s, bytes) else str(s) for s in g["name"][...])
            self.position = g["position"][...]
            self.triangle = g["triangle"][...]
            self.time = f["time"][:n]
            self.velocity_time = f["velocity_time"][:n]
            self.data = {q: f[q][:n] for q in GAUGE_QUANTITIES}
            self.components = {q: tuple(c for c in str(f[q].attrs.get("components", "")).split(",") if c)
                               for q in GAUGE_QUANTITIES}
        self.units = {"time": "s", "velocity_time": "s", "position": "m",
                      **{q: unit for q, (unit, _, _) in GAUGE_QUANTITIES.items()}}

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name) -> bool:
        return name in self.names

    def __getitem__(self, name: str) -> Gauge:
        if name not in self.names:
            raise KeyError(f"{self.path}: no gauge {name!r}; has {', '.join(self.names)}")
        k = self.names.index(name)
        return Gauge(name, float(self.position[k, 0]), float(self.position[k, 1]), self.time, self.velocity_time,
                     **{q: self.data[q][:, k] for q in GAUGE_QUANTITIES})


def open_gauges(rundir) -> GaugeFile | None:
    """The gauges of a run directory (or a ``gauges.h5`` path); None if it wrote none."""
    path = Path(rundir)
    path = path / GAUGES_FILE if path.is_dir() else path
    return GaugeFile(path) if path.is_file() else None
