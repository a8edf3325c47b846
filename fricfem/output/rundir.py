"""Reading a run directory (and writing its summary): the one place that knows
where things are in ``interface.h5``, ``summary.json`` and ``fields.xdmf``.

The layout is :mod:`.quantities`'s.  Readers take only the valid rows — the
leading rows whose time is finite (:mod:`.recorder` lays the file out whole
with NaN and writes a row's time after its values), or the root attribute
``n_time`` (per station ``n``) of files written before that — so a run that
is still going or was killed reads as far as it was flushed.  Files are opened
read-only without HDF5's file lock, so a live run can be read.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

from .quantities import ENERGY, INTERFACE_FILE, unit
from .record import jsonable, read_evidence, read_summary, write_summary  # noqa: F401 (the readers' API)

log = logging.getLogger("fricfem.output")


def time_tag(t: float) -> str:
    """File-name tag of a time [s]: ``32us``, ``44.6us``."""
    return f"{round(t * 1e6, 1):g}us"


@dataclasses.dataclass(frozen=True)
class RunInfo:
    """What a figure title needs: scene, Σ0 [Pa], V_imp [m/s], wave speeds [m/s], mode."""

    scene: str = ""
    sigma0: float | None = None
    v_imp: float | None = None
    speeds: dict = dataclasses.field(default_factory=dict)
    mode: str | None = None
    projectile: float | None = None  # the experiment's projectile speed [m/s] (its edge has no V_imp)

    def title(self) -> str:
        parts = [self.scene] if self.scene else []
        load = []
        if self.sigma0 is not None:
            load.append(rf"$\Sigma_0$ = {self.sigma0 / 1e6:.3g} MPa")
        if self.projectile:
            load.append(f"projectile {self.projectile:.3g} m/s on the steel buffer")
        if self.v_imp is not None and not (self.projectile and self.v_imp == 0):
            load.append(rf"$V_{{\rm imp}}$ = {self.v_imp:.3g} m/s")
        if load:
            parts.append(", ".join(load))
        return " — ".join(parts)


def _attr(attrs, key, default=None):
    value = attrs.get(key, default)
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, np.generic):
        value = value.item()
    return value


def run_info(rundir=None, interface=None, summary=None) -> RunInfo:
    """Metadata from interface.h5 root attributes, completed by summary.json."""
    summary = summary if summary is not None else (read_summary(rundir) if rundir else {})
    attrs = dict(interface.attrs) if interface is not None else {}
    speeds = {k: float(v) for k, v in (summary.get("speeds") or {}).items() if _is_number(v)}
    for key in ("c_l", "c_s", "c_R"):
        if _is_number(attrs.get(key)):
            speeds[key] = float(attrs[key])
    if "c_s" in speeds:
        speeds.setdefault("sqrt2_c_s", math.sqrt(2.0) * speeds["c_s"])
    scene = _attr(attrs, "scene") or summary.get("scene") or (Path(rundir).name if rundir else "")
    sigma0 = _attr(attrs, "sigma0", summary.get("sigma0"))
    v_imp = _attr(attrs, "v_imp", summary.get("v_imp"))
    mode = (summary.get("mode") or {}).get("label") if isinstance(summary.get("mode"), dict) else None
    experiment = (summary.get("input") or {}).get("experiment") or {}
    projectile = experiment.get("projectile_speed") if isinstance(experiment, dict) else None
    return RunInfo(
        scene=str(scene),
        sigma0=float(sigma0) if _is_number(sigma0) else None,
        v_imp=float(v_imp) if _is_number(v_imp) else None,
        speeds=speeds,
        mode=mode,
        projectile=float(projectile) if _is_number(projectile) and projectile > 0 else None,
    )


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(float(v))


def valid_rows(time, n_attr=None) -> int:
    """How many leading rows of a ``time`` dataset are valid: those with a finite,
    increasing time, and at most ``n_attr`` (the count files written before the
    NaN layout kept) when given."""
    t = np.asarray(time[...], dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(t))
    n = int(bad[0]) if len(bad) else len(t)
    back = np.flatnonzero(np.diff(t[:n]) <= 0)
    n = int(back[0]) + 1 if len(back) else n
    return n if n_attr is None else max(0, min(n, int(n_attr)))


@dataclasses.dataclass
class Station:
    """Histories at one interface point: ``data[name]`` float64[n] against ``time`` [s]
    (the step's t^n); ``shift[name]`` [s]: a quantity that holds at another time
    (:meth:`time_of`)."""

    name: str
    x1: float
    time: np.ndarray
    data: dict
    shift: dict = dataclasses.field(default_factory=dict)

    def time_of(self, name: str) -> np.ndarray:
        """The times [s] at which ``data[name]`` holds (``time`` + its shift: the
        rigid kind's slip rate at t^{n+½}, its slip at t^{n+1}; docs/outputs.md)."""
        return self.time + self.shift.get(name, 0.0)


class InterfaceFile:
    """The valid rows of an open ``interface.h5`` (read lazily, row by row or whole).

    ``x1`` float64[n_point] [m], ``time`` float64[n_time] [s], ``n_time`` the
    number of valid rows (:func:`valid_rows`).
    """

    def __init__(self, f: h5py.File):
        self.file = f
        self.attrs = f.attrs
        self.x1 = f["x1"][...]
        self.n_time = valid_rows(f["time"], _attr(f.attrs, "n_time"))
        self.time = f["time"][: self.n_time]

    def has(self, name: str) -> bool:
        return name in self.file

    def time_of(self, name: str) -> np.ndarray:
        """The times [s] at which the rows of quantity ``name`` hold: ``time`` plus
        the dataset's ``time_shift_s`` (0 in files written before it was)."""
        return self.time + float(_attr(self.file[name].attrs, "time_shift_s", 0.0))

    def rows(self, name: str, idx) -> np.ndarray:
        """float64[len(idx), n_point] of quantity ``name`` at valid rows ``idx``."""
        idx = np.asarray(idx, dtype=int)
        if np.any(idx >= self.n_time) or np.any(idx < 0):
            raise IndexError(f"{name}: rows {idx} outside the {self.n_time} valid rows")
        order = np.argsort(idx)
        uniq, inverse = np.unique(idx[order], return_inverse=True)
        data = self.file[name][uniq.tolist()] if len(uniq) else np.empty((0, len(self.x1)))
        out = np.empty((len(idx), data.shape[1]), dtype=np.float64)
        out[order] = data[inverse]
        return out

    def all(self, name: str) -> np.ndarray:
        """float64[n_time, n_point] of quantity ``name`` (valid rows only)."""
        return np.asarray(self.file[name][: self.n_time], dtype=np.float64)

    def nearest(self, times) -> np.ndarray:
        """Indices of the valid rows nearest to ``times`` [s] (sorted, unique)."""
        if self.n_time == 0:
            return np.zeros(0, dtype=int)
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        idx = np.abs(self.time[None, :] - t[:, None]).argmin(axis=1)
        return np.unique(idx)

    def stations(self) -> dict:
        """{name: :class:`Station`} of the valid rows of every station."""
        out = {}
        for name, g in (self.file.get("stations") or {}).items():
            n = valid_rows(g["time"], _attr(g.attrs, "n"))
            data = {k: np.asarray(g[k][:n], dtype=np.float64) for k in g if k != "time" and g[k].ndim == 1}
            shift = {k: float(_attr(g[k].attrs, "time_shift_s", 0.0)) for k in data}
            out[name] = Station(name, float(_attr(g.attrs, "x1", np.nan)), g["time"][:n], data,
                                {k: v for k, v in shift.items() if v})
        return out


@contextlib.contextmanager
def open_interface(src):
    """Yield an :class:`InterfaceFile` of ``src``: a run directory, an ``interface.h5``
    path, an open ``h5py.File`` or an :class:`InterfaceFile` (left open)."""
    if isinstance(src, InterfaceFile):
        yield src
        return
    if isinstance(src, h5py.File):
        yield InterfaceFile(src)
        return
    path = Path(src)
    if path.is_dir():
        path = path / INTERFACE_FILE
    with _h5open(path) as f:
        yield InterfaceFile(f)


def sliding_sign(itf: InterfaceFile, rows=None) -> float:
    """+1 or −1: the sign of T_s where it slides, sgn(Σ Δu̇_slip T_s) over ``rows``
    (all valid rows by default); the sign of Σ T_s if nothing slides."""
    if itf.n_time == 0 or not itf.has("shear_traction"):
        return 1.0
    rows = np.arange(itf.n_time) if rows is None else np.asarray(rows)
    ts = itf.rows("shear_traction", rows)
    w = itf.rows("slip_rate", rows) if itf.has("slip_rate") else np.zeros_like(ts)
    s = float(np.sum(w * ts))
    if s == 0.0:
        s = float(np.sum(ts))
    return -1.0 if s < 0 else 1.0


def default_times(itf: InterfaceFile, n: int = 3) -> np.ndarray:
    """``n`` evenly spaced times plus the last valid one [s]."""
    if itf.n_time == 0:
        return np.zeros(0)
    t0, t1 = float(itf.time[0]), float(itf.time[-1])
    return np.linspace(t0, t1, n + 2)[1:]


@contextlib.contextmanager
def _h5open(path):
    """Open an HDF5 file read-only without taking HDF5's file lock (a run may be
    writing it); HDF5 builds without the option are opened normally."""
    try:
        try:
            f = h5py.File(path, "r", locking=False)
        except TypeError:
            f = h5py.File(path, "r")
        except OSError as err:
            if "locking flag" not in str(err):
                raise
            # this process already holds the file open with HDF5's lock (a user's h5py.File): HDF5 shares
            # an open file within a process only with the same locking setting
            f = h5py.File(path, "r")
    except (OSError, ValueError) as err:
        raise unreadable(path, err) from None
    with f:
        yield f


def unreadable(path, err: Exception) -> OSError:
    """An OSError naming ``path`` for an HDF5 file that cannot be opened (h5py's own names no file)."""
    text = " ".join(str(err).split())
    if "signature" in text or "truncated" in text or "bad object header" in text or "not an HDF5" in text:
        reason = f"damaged or not an HDF5 file ({text})"
    else:
        reason = f"cannot be read ({text})"
    return OSError(getattr(err, "errno", None), reason, str(path))


def pyvista_module():
    """pyvista set up for off-screen rendering, or None if it is not installed."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        # lazy: pyvista is optional and slow to import
        import pyvista
    except ImportError:
        return None
    return pyvista


#: XDMF topology type -> (VTK cell type, nodes per cell) for the cells dolfinx writes in 2D.
_XDMF_CELLS = {"Triangle": (5, 3), "Quadrilateral": (9, 4)}


class FieldReader:
    """Snapshots of one function of a ``fields.xdmf`` (+ its HDF5 files).

    Reads fricfem's layout (one temporal collection, a grid per snapshot holding
    every function; :mod:`.fields`) and dolfinx's own (a collection per
    function).  The XML is parsed here and the arrays are read with h5py; VTK's
    own XDMF reader is not used because, in a process that has loaded dolfinx
    (and with it the system libhdf5), VTK's bundled HDF5 binds to the wrong
    symbols and returns a mesh with all points at the origin.

    ``times`` float64[n] [s] (empty: no snapshot written yet); :meth:`grid`
    returns a pyvista UnstructuredGrid with the function as cell data
    (cell-centred functions) or point data (nodal ones), named ``name``.
    """

    def __init__(self, path, name: str = "stress_difference"):
        self.path = Path(path)
        self.name = name
        try:
            root = ET.parse(self.path).getroot()
        except ET.ParseError as err:
            raise ValueError(f"{self.path}: not readable as XDMF ({err})") from None
        grids = list(root.iter("Grid"))
        mesh = next((g for g in grids if g.find("Topology") is not None
                     and g.find("Topology").find("DataItem") is not None), None)
        timed = [g for g in grids if g.find("Time") is not None and g.find("Attribute") is not None]
        steps = []
        for g in timed:
            for att in g.findall("Attribute"):
                if att.get("Name") == name:
                    steps.append((float(g.find("Time").get("Value")), att.get("Center", "Node"),
                                  att.find("DataItem").text.strip()))
        if timed and not steps:
            names = sorted({a.get("Name") for g in timed for a in g.findall("Attribute")})
            raise KeyError(f"{self.path}: no function {name!r} (has {names})")
        if steps and mesh is None:
            raise ValueError(f"{self.path}: no mesh grid")
        self.cell_type = None
        if mesh is not None:
            topo = mesh.find("Topology")
            kind = topo.get("TopologyType")
            if kind not in _XDMF_CELLS:
                raise ValueError(f"{self.path}: cells {kind!r} not supported (allowed {sorted(_XDMF_CELLS)})")
            self.cell_type = _XDMF_CELLS[kind][0]
            self._topology = topo.find("DataItem").text.strip()
            self._geometry = mesh.find("Geometry").find("DataItem").text.strip()
        steps.sort(key=lambda s: s[0])
        self.times = np.array([s[0] for s in steps])
        self._steps = steps
        self._mesh = None

    def _read(self, item: str) -> np.ndarray:
        """The array of an XDMF ``file.h5:/path`` data item (file relative to the .xdmf)."""
        fname, _, dset = item.partition(":")
        with _h5open(self.path.parent / fname) as f:
            return f[dset][...]

    def nearest(self, times=None) -> np.ndarray:
        """Indices of the written times nearest to ``times`` [s] (all if None)."""
        if times is None:
            return np.arange(len(self.times))
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        return np.unique(np.abs(self.times[None, :] - t[:, None]).argmin(axis=1))

    def values(self, index: int) -> np.ndarray:
        """The function's values at written time ``index`` (cells or nodes, as written)."""
        _, _, item = self._steps[index]
        values = self._read(item)
        return values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values

    def grid(self, index: int):
        """pyvista UnstructuredGrid of the mesh with the function at written time ``index``."""
        pv = pyvista_module()
        if pv is None:
            raise ImportError("pyvista is not installed")
        if self._mesh is None:  # the mesh is written once; read it once
            cells = self._read(self._topology).astype(np.int64)
            x = self._read(self._geometry).astype(np.float64)
            if x.shape[1] == 2:
                x = np.column_stack([x, np.zeros(len(x))])
            self._mesh = pv.UnstructuredGrid({self.cell_type: cells}, x)
        grid = self._mesh.copy(deep=False)
        grid.clear_data()
        _, center, item = self._steps[index]
        values = self._read(item)
        values = values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values
        (grid.cell_data if center == "Cell" else grid.point_data)[self.name] = values
        return grid


class Run:
    """A run directory's results as arrays, SI units (``fricfem.open_run``).

    ``t`` [s] and ``x1`` [m] of the interface rows; every interface quantity
    as an attribute, float64[n_t, n_p] over the valid rows (``slip_rate``,
    ``shear_traction``, ... and ``state/<θ>`` through :meth:`quantity`), read
    on first use; ``stations`` {name: {"x1", "time", quantity: array}};
    ``energy`` {name: array}; ``summary`` (summary.json with evidence.json merged
    in: :func:`read_summary`); ``units`` {name: unit, as the file's ``unit`` attributes}.
    """

    def __init__(self, rundir):
        self.dir = Path(rundir)
        self.summary = read_summary(self.dir)
        path = self.dir / INTERFACE_FILE
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no interface.h5 (not a run directory, or the run wrote nothing yet)")
        try:
            self._read(path)
        except (KeyError, ValueError, TypeError, IndexError) as err:  # h5py's errors name no file
            raise OSError(None, f"not an interface file fricfem wrote, or damaged ({type(err).__name__}: "
                          f"{' '.join(str(err).split())})", str(path)) from None
        self._cache = {}

    def _read(self, path: Path) -> None:
        with open_interface(path) as itf:
            self.t = np.asarray(itf.time, dtype=np.float64)
            self.x1 = np.asarray(itf.x1, dtype=np.float64)
            self.names = tuple(name for name in itf.file if isinstance(itf.file[name], h5py.Dataset)
                               and itf.file[name].ndim == 2) + tuple(f"state/{s}" for s in itf.file.get("state", {}))
            self.stations = {name: {"x1": st.x1, "time": np.asarray(st.time), **st.data}
                             for name, st in itf.stations().items()}
            g = itf.file.get("energy")
            n = valid_rows(g["time"], _attr(g.attrs, "n")) if g is not None and "time" in g else 0
            self.energy = {k: np.asarray(g[k][:n], dtype=np.float64) for k in g} if g else {}
            stored = {name: _attr(itf.file[name].attrs, "unit") for name in self.names}
        self.units = {"t": "s", "x1": "m", **{name: stored[name] if stored[name] is not None else unit(name)
                                               for name in self.names}, **ENERGY}

    def quantity(self, name: str) -> np.ndarray:
        """float64[n_t, n_p] of interface quantity ``name`` (valid rows)."""
        if name not in self._cache:
            if name not in self.names:
                raise KeyError(f"{self.dir}: no interface quantity {name!r}; has {', '.join(self.names)}")
            with open_interface(self.dir / INTERFACE_FILE) as itf:
                self._cache[name] = itf.all(name)
        return self._cache[name]

    def __getattr__(self, name):
        if name.startswith("_") or name not in self.__dict__.get("names", ()):
            raise AttributeError(name)
        return self.quantity(name)

    def at(self, t: float) -> int:
        """Index of the stored row nearest to ``t`` [s]; a run with no row yet (still
        starting, or killed before its first flush) raises :class:`LookupError` saying so."""
        if not len(self.t):
            state = "complete" if self.summary.get("complete") else "still going or stopped"
            raise LookupError(f"{self.dir}: no interface row written yet (the run is {state}, "
                              f"{self.summary.get('steps', 0)} steps in summary.json): nothing at t = {t:.6g} s")
        return int(np.argmin(np.abs(self.t - t)))

    def profile(self, name: str, t: float) -> np.ndarray:
        """Quantity ``name`` along x1 in the stored row nearest to ``t`` [s]."""
        return self.quantity(name)[self.at(t)]

    def tip(self, t: float) -> float:
        """x1 [m] of the leading sliding tip in the row nearest to ``t`` (nan: no sliding)."""
        s = self.profile("slip_rate", t) > 0
        return float(self.x1[s].max()) if s.any() else math.nan


def open_run(rundir) -> Run:
    """The results of a run directory as arrays with units (:class:`Run`); a run
    still going or killed reads as far as it was flushed."""
    return Run(rundir)
