"""Writes ``interface.h5`` as a run goes: interface snapshots, station histories,
energies (the format: :mod:`.quantities`).  Rank 0 writes; the others send.

Off the step's path.  A snapshot only copies this rank's interface values into
a local buffer, a station row is one numba call into another; a flush (every
:data:`fricfem.observe.FLUSH_ROWS` snapshots, or by wall time) gathers the
buffered rows to rank 0 in one message and writes each dataset's new rows with
one system call (:class:`RawRows`).  ``summary.json``'s ``loop_cost`` gives
what each part costs per step.

Crash safety.  The file is laid out whole before the run starts: every dataset
has the size of the full run (rows from the run's step count), contiguous,
allocated and filled with NaN when it is created, and all of its metadata is
written once, under a temporary name that is renamed to ``interface.h5`` only
when complete.  After that only raw data is written, in place, and never a
byte of HDF5 metadata: whatever instant a process is killed at, the file's
structure is the one it was created with.  A flush writes the pending rows'
values first and their times after them (each handed to the operating system
as it is written: :class:`RawRows`), so a row whose time is finite is complete: the
valid rows are the leading rows with a finite time (:mod:`.rundir`).  The row
counts of a run that reaches its end are laid out with the file, as the
attributes ``n_time`` (root) and ``n`` (per station, energy) that readers of
earlier formats use (readers take the smaller of a count and the rows with a
finite time): such a run's file is final as it stands.  A run stopped early
(by the tip, the watchdog, SIGTERM or SIGINT) is copied to a file of exactly
the rows it has, with their counts, renamed over the original: a finished run
holds no NaN rows.  Its pre-loop space check is the file's size; a copy that
does not fit keeps the laid-out file (and the run's summary says so).
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..kernels.watch import take_rows
from .directory import RunDirError
from .quantities import ENERGY, FORMAT, QUANTITIES, time_shift, unit
from .quantities import BY_NAME
from .regions import write_regions

#: rows written per block when a dataset is copied
_BLOCK_BYTES = 8 << 20


def planned_rows(n_steps: int, every: int, energy_every: int) -> dict:
    """Rows a run of ``n_steps`` steps writes: interface snapshots (after steps
    1, 1 + every, ...), station rows (every step), energy rows (at the start of
    steps 0, energy_every, ...)."""
    snaps = (n_steps - 1) // every + 1 if n_steps > 0 else 0
    energy = (n_steps - 1) // energy_every + 1 if n_steps > 0 and energy_every > 0 else 0
    return {"snapshots": snaps, "stations": n_steps, "energy": energy}


def _when_attrs(dataset, kind: str, name: str, dt: float) -> None:
    """The time a quantity's rows hold, on its dataset (:func:`fricfem.output.quantities.time_shift`)."""
    shift, where = time_shift(kind, name, dt)
    dataset.attrs["time_shift_s"] = shift
    dataset.attrs["defined_at"] = where


def _dataset(group, name: str, shape, dtype, unit_: str):
    """A contiguous dataset allocated and filled (NaN, or -1 for integers) at creation."""
    # lazy: start-up time (h5py only once a file is read or written)
    import h5py

    dtype = np.dtype(dtype)
    fill = np.array(np.nan if dtype.kind == "f" else -1, dtype=dtype)
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    dcpl.set_fill_time(h5py.h5d.FILL_TIME_ALLOC)
    dcpl.set_fill_value(fill)
    d = group.create_dataset(name, shape=shape, dtype=dtype, dcpl=dcpl)
    d.attrs["unit"] = unit_
    return d


class Recorder:
    """Interface snapshots, station histories and energies → ``interface.h5`` (rank 0 writes).

    ``rows``: :func:`planned_rows` of the run — the size every dataset is made
    with, so a file system too small for the run fails here, before the loop.
    Creating the file is collective: an error (no space, a read-only file
    system) is a :class:`~.directory.RunDirError` naming the path on every rank.
    """

    def __init__(self, path: Path, scene, model, speeds: dict, rows: dict, points):
        self.itf = model.interface
        self.points = points  # the run's interface points (fricfem.step.State.points), updated in place
        self.comm = model.comm
        self.law = self.itf.law
        self.path = Path(path)
        geom = self.itf.geometry
        x1_all = np.concatenate(self.comm.allgather(geom.x1))
        self.order = np.argsort(x1_all, kind="stable")
        self.x1 = x1_all[self.order]
        self.n_point = len(self.x1)
        self.rows = dict(rows)
        self.kind = scene.interface_kind  # when each quantity holds (quantities.time_shift)
        self.dt = float(model.dt)
        # stations: nearest Gauss point; its owner records every step
        self.stations = {}
        for name, xs in scene.output.stations.items():
            k = int(np.argmin(np.abs(self.x1 - xs)))
            xq = self.x1[k]
            local = np.flatnonzero(geom.x1 == xq)
            self.stations[name] = (xq, int(local[0]) if len(local) else -1)
        self.station_n = {name: 0 for name in self.stations}
        self._init_station_rows()
        self.snap_t: list = []  # rank 0: the times of the rows gathered so far
        self.n_local = len(geom.x1)
        self.n_local_all = self.comm.allgather(self.n_local)
        # this rank's rows since the last flush: block[row, quantity, local point], and their times
        self.block = np.empty((16, len(QUANTITIES) + len(self.law.state), self.n_local))
        self.n_block = 0
        self.local_t: list = []
        self.names = [q.name for q in QUANTITIES] + [f"state/{s}" for s in self.law.state]
        # rank 0: each flush's rows as (index of its first row, rows[quantity, row, point] in x1 order)
        self.blocks: list = []
        self.energy_rows: list = []
        self.written = {"snapshots": 0, "energy": 0}  # rows in the file
        self.h5 = None
        error = None
        if self.comm.rank == 0:
            need = _nbytes(self.rows, self.n_point, len(self.names), len(self.stations), len(ENERGY))
            try:
                # HDF5 cannot survive a failed write while it lays a file out (it crashes in close): the
                # space is checked first.  A run that reaches its end needs no copy (:meth:`close`); one
                # that stops early keeps its laid-out file when the copy of its rows does not fit
                check_space(self.path, need + _metadata_bytes(len(self.names), len(self.stations)),
                            "the interface file")
                self.h5 = self._create(scene, speeds)
            except OSError as err:
                error = f"{err.filename}: cannot write the run's interface file ({need / 1e6:.3g} MB): {err.strerror}"
        error = self.comm.bcast(error, root=0)
        if error is not None:
            raise RunDirError(error)

    def _create(self, scene, speeds):
        """Lay the file out whole under a temporary name, flush it, rename it (rank 0)."""
        # lazy: start-up time (h5py only once a file is read or written)
        import h5py

        tmp = self.path.with_name(f".{self.path.name}.part")
        tmp.unlink(missing_ok=True)
        try:  # without HDF5's own file lock (.fricfem.lock guards the directory), so this process can read it
            f = h5py.File(tmp, "w", locking=False)
        except (OSError, ValueError) as err:
            raise h5_error(err, tmp) from None
        try:
            f.attrs.update(scene=scene.name, sigma0=scene.sigma0, v_imp=scene.pulse.v_imp, law=scene.law,
                           units="SI", format=FORMAT, rows_planned=self.rows["snapshots"],
                           valid_rows="the leading rows whose time is finite (NaN: not computed)",
                           **{k: v for k, v in speeds.items()})
            f["x1"] = self.x1
            write_regions(f, scene.regions, self.x1)  # the friction.regions entry of each point
            f["regions/index"].attrs["unit"] = "1 (an index)"  # every dataset names its unit (none empty)
            f["x1"].attrs["unit"] = "m"
            n = self.rows["snapshots"]
            _dataset(f, "time", (n,), "f8", "s")
            for q in self.names:
                _dataset(f, q, (n, self.n_point), "i1" if q == "open" else "f8", unit(q))
                _when_attrs(f[q], self.kind, q, self.dt)
            for name, (xq, _) in self.stations.items():
                g = f.create_group(f"stations/{name}")
                g.attrs.update(x1=xq, x1_unit="m")
                for col in ["time", *(q.name for q in QUANTITIES)]:
                    _dataset(g, col, (self.rows["stations"],), "f8", "s" if col == "time" else unit(col))
                    if col != "time":
                        _when_attrs(g[col], self.kind, col, self.dt)
            g = f.create_group("energy")
            g.attrs["unit"] = "J/m (per unit thickness); time in s"
            for k in ENERGY:
                _dataset(g, k, (self.rows["energy"],), "f8", ENERGY[k])
            _count_attrs(f, self._planned())  # a run that reaches its end writes every row: nothing to copy
            names = ["time", *self.names, *(f"energy/{k}" for k in ENERGY),
                     *(f"stations/{s}/{c}" for s in self.stations for c in ["time", *(q.name for q in QUANTITIES)])]
            layout = {name: _place(f[name]) for name in names}
            f.close()  # the layout is final: no byte of HDF5 metadata is written after this
            os.replace(tmp, self.path)
            return RawRows(self.path, layout)
        except BaseException as err:
            try:
                f.close()
            except (OSError, ValueError, RuntimeError):
                pass
            tmp.unlink(missing_ok=True)
            if isinstance(err, (OSError, ValueError)):  # h5py reports a failed write as either
                raise h5_error(err, self.path) from None
            raise

    def snapshot(self, t: float) -> None:
        """Take every interface point's values now into this rank's buffer (local, no
        communication: :meth:`flush` gathers the buffered rows to rank 0 in one message)."""
        if self.n_block == len(self.block):  # more rows than usual between two flushes
            self.block = np.concatenate([self.block, np.empty_like(self.block)])
        p, row = self.points, self.block[self.n_block]
        for k, q in enumerate(QUANTITIES):
            row[k] = q.read(p)
        for k in range(len(self.law.state)):
            row[len(QUANTITIES) + k] = p.state[:, k]
        self.n_block += 1
        self.local_t.append(t)

    def _gather_rows(self) -> None:
        """The rows buffered since the last flush, from every rank, into rank 0's
        history (one Gatherv of the packed block; collective): one array
        [quantity, row, point] in x1 order, so that each quantity's new rows are
        one contiguous piece for the file."""
        n_new, nq = self.n_block, len(self.names)  # n_new: the same on every rank
        block = self.block[:n_new]
        times, self.local_t, self.n_block = self.local_t, [], 0
        if self.comm.size > 1:
            counts = [n_new * nq * m for m in self.n_local_all]
            recv = np.empty(sum(counts)) if self.comm.rank == 0 else None
            self.comm.Gatherv(block.reshape(-1), (recv, counts) if recv is not None else None, root=0)
            if self.comm.rank != 0 or n_new == 0:
                return
            parts = [a.reshape(n_new, nq, m) for a, m in zip(np.split(recv, np.cumsum(counts)[:-1]), self.n_local_all)]
        elif n_new == 0:
            return
        else:  # one rank: the buffer is reused, so the history keeps a copy (take makes one)
            parts = [block]
        full = np.take(np.concatenate([a.transpose(1, 0, 2) for a in parts], axis=2), self.order, axis=2)
        self.blocks.append((len(self.snap_t), full))
        self.snap_t.extend(times)

    def _init_station_rows(self) -> None:
        """The stations this rank owns, and their rows buffer: a row a step of the
        :class:`~fricfem.model.interface.Points` arrays the quantities read
        (:data:`.quantities.QUANTITIES` ``attr``; one call a step,
        :func:`fricfem.kernels.watch.take_rows`); the quantities computed from
        others (``mu_app``) are computed from the rows when they are written."""
        self.st_owned = [name for name, (_, q) in self.stations.items() if q >= 0]
        self.st_index = np.array([self.stations[name][1] for name in self.st_owned], dtype=np.int64)
        attrs = [q.attr for q in QUANTITIES if q.attr]
        points = self.points  # its arrays are updated in place for the whole run
        self.st_float = tuple(a for a in attrs if getattr(points, a).dtype == np.float64)
        self.st_other = tuple(a for a in attrs if a not in self.st_float)  # is_open (int8)
        self.st_columns = (tuple(getattr(points, a) for a in self.st_float),
                           tuple(getattr(points, a) for a in self.st_other))
        self.st_rows = np.empty((64, len(attrs), len(self.st_owned)))
        self.st_t = np.empty(64)
        self.st_k = 0

    def station_step(self, t: float) -> None:
        """Record the stations this rank owns (every step, local, no communication)."""
        if not self.st_owned:
            return
        k = self.st_k
        if k == len(self.st_t):  # more steps than usual between two flushes
            self.st_rows = np.concatenate([self.st_rows, np.empty_like(self.st_rows)])
            self.st_t = np.concatenate([self.st_t, np.empty_like(self.st_t)])
        floats, others = self.st_columns
        take_rows(floats, self.st_index, self.st_rows, k, 0)
        if others:
            take_rows(others, self.st_index, self.st_rows, k, len(floats))
        self.st_t[k] = t
        self.st_k = k + 1

    def _gather_stations(self) -> dict:
        """The station rows since the last flush, from every rank, on rank 0:
        {name: (times, {quantity: values})} (one gather; collective)."""
        k, self.st_k = self.st_k, 0
        mine = (self.st_owned, self.st_t[:k].copy(), self.st_rows[:k].copy())
        parts = self.comm.gather(mine, root=0)
        if self.comm.rank != 0:
            return {}
        attrs = self.st_float + self.st_other
        out = {}
        for name in self.stations:
            held = [(t, rows[:, :, names.index(name)]) for names, t, rows in parts if name in names]
            if not held or not sum(len(t) for t, _ in held):
                continue
            t = np.concatenate([t for t, _ in held])
            rows = np.concatenate([r for _, r in held])
            cols = SimpleNamespace(**{a: rows[:, j] for j, a in enumerate(attrs)})
            out[name] = (t, {q.name: np.asarray(q.read(cols), dtype=np.float64) for q in QUANTITIES})
        return out

    def energy(self, e: dict) -> None:
        if self.comm.rank == 0:
            self.energy_rows.append([e[k] for k in ENERGY])

    def flush(self) -> None:
        """Append everything pending to the file (collective): gather the buffered
        rows, then write the values of the new rows, then their times (a reader
        takes a row once its time is finite), each as plain bytes at its place
        (:class:`RawRows`)."""
        self._gather_rows()
        stations = self._gather_stations()
        if self.comm.rank != 0:
            return
        f = self.h5
        times = []  # (dataset, start, values): written after every value is in the file
        n0, n1 = self.written["snapshots"], len(self.snap_t)
        if n1 > n0:
            # the blocks not in the file yet: this flush's, and any whose write failed before
            for start, full in reversed(self.blocks):
                if start < n0:
                    break
                for q, rows in zip(self.names, full):
                    f.write(q, start, rows)
            times.append(("time", n0, np.array(self.snap_t[n0:n1])))
        for name, (t, values) in stations.items():
            m0 = self.station_n[name]
            for q in QUANTITIES:
                f.write(f"stations/{name}/{q.name}", m0, values[q.name])
            times.append((f"stations/{name}/time", m0, t))
            self.station_n[name] = m0 + len(t)
        k0, k1 = self.written["energy"], len(self.energy_rows)
        if k1 > k0:
            a = np.array(self.energy_rows[k0:k1])
            for j, k in enumerate(ENERGY):
                if k != "time":
                    f.write(f"energy/{k}", k0, a[:, j])
            times.append(("energy/time", k0, a[:, list(ENERGY).index("time")]))
        for name, start, values in times:
            f.write(name, start, values)
        self.written = {"snapshots": n1, "energy": k1}

    def resume(self, old: Path, rows: dict) -> None:
        """Continue a run from its checkpoint (collective): the first ``rows`` of the
        killed or stopped run's file ``old`` (``snapshots``, ``energy``, ``stations``
        {name: rows}) copied into this freshly laid-out file, every value before any
        time (a kill meanwhile leaves ``old`` whole and this file's valid rows a
        prefix), and into rank 0's history; the rows after them stay NaN until the
        run writes them again.  A :class:`~.directory.RunDirError` on every rank when
        ``old`` holds fewer rows than the checkpoint counts."""
        # lazy: start-up time (it loads h5py)
        from .rundir import _h5open, valid_rows

        self.station_n = {name: int(rows["stations"].get(name, 0)) for name in self.stations}
        error = None
        if self.comm.rank == 0:
            k, ke = int(rows["snapshots"]), int(rows["energy"])
            try:
                with _h5open(old) as f:
                    have = {"": valid_rows(f["time"]), "energy": valid_rows(f["energy/time"])}
                    have.update({name: valid_rows(f[f"stations/{name}/time"]) for name in self.stations})
                    need = {"": k, "energy": ke, **self.station_n}
                    short = [g or "snapshots" for g, n in need.items() if have[g] < n]
                    if short:
                        raise OSError(None, f"holds fewer rows than the checkpoint counts ({', '.join(short)}: "
                                      f"{[have[g] for g in need if have[g] < need[g]]} < "
                                      f"{[need[g] for g in need if have[g] < need[g]]})", str(old))
                    full = np.stack([np.asarray(f[q][:k], dtype=np.float64) for q in self.names]) if k else None
                    t = f["time"][:k]
                    energy = {e: f[f"energy/{e}"][:ke] for e in ENERGY}
                    stations = {name: {c: f[f"stations/{name}/{c}"][:n] for c in ["time", *(q.name for q in
                                                                                          QUANTITIES)]}
                                for name, n in self.station_n.items()}
                times = [("time", t)] + [("energy/time", energy["time"])]
                for q, a in zip(self.names, full if full is not None else []):
                    self.h5.write(q, 0, a)
                for e in ENERGY:
                    if e != "time":
                        self.h5.write(f"energy/{e}", 0, energy[e])
                for name, cols in stations.items():
                    for c, a in cols.items():
                        if c != "time":
                            self.h5.write(f"stations/{name}/{c}", 0, a)
                    times.append((f"stations/{name}/time", cols["time"]))
                for name, a in times:
                    self.h5.write(name, 0, a)
                self.blocks = [(0, full)] if k else []
                self.snap_t = [float(x) for x in t]
                self.energy_rows = np.column_stack([energy[e] for e in ENERGY]).tolist() if ke else []
                self.written = {"snapshots": k, "energy": ke}
            except (OSError, KeyError) as err:
                error = f"{old}: cannot resume from it: {err.strerror if isinstance(err, OSError) else err}"
        error = self.comm.bcast(error, root=0)
        if error is not None:
            raise RunDirError(error)

    def history(self):
        """(time, slip_rate[n_t, n_p]) recorded so far (rank 0; None elsewhere)."""
        if self.comm.rank != 0:
            return None
        k = self.names.index("slip_rate")
        return np.array(self.snap_t), (np.concatenate([full[k] for _, full in self.blocks]) if self.blocks
                                       else np.array([]))

    def _planned(self) -> dict:
        """The rows of every group when the run reaches its end (the counts laid out with the file)."""
        return {"": self.rows["snapshots"], "energy": self.rows["energy"],
                **{f"stations/{k}": self.rows["stations"] for k in self.stations}}

    def close(self) -> None:
        """Close the file; unless every planned row was written (its counts, laid out with
        it, are then right), replace it by a copy of its valid rows with their counts (rank
        0).  A copy that does not fit raises OSError and leaves the laid-out file, whole."""
        if self.h5 is None:
            return
        f, self.h5 = self.h5, None
        f.close()
        rows = {"": self.written["snapshots"], "energy": self.written["energy"],
                **{f"stations/{k}": n for k, n in self.station_n.items()}}
        if rows != self._planned():
            compact(self.path, rows)


def _place(dset) -> tuple:
    """Where a dataset's numbers are in its file: (byte offset, bytes per row, dtype);
    offset None for a dataset of no rows."""
    row = int(np.prod(dset.shape[1:], dtype=np.int64)) * dset.dtype.itemsize
    return (dset.id.get_offset() if dset.shape[0] else None, row, dset.dtype)


class RawRows:
    """Rows of the laid-out ``interface.h5`` written as plain bytes at their place in
    the file (``os.pwrite``): every dataset is contiguous and allocated when the file
    is made, so a row's bytes have a fixed offset, and the file's structure (HDF5's
    metadata, written once and closed) is never touched again.  One system call per
    dataset and flush, instead of HDF5's selection machinery per slice (~0.1–0.5 ms
    each); the operating system has the bytes as soon as the call returns, as after
    an HDF5 flush.  ``layout``: {dataset name: :func:`_place`}."""

    def __init__(self, path: Path, layout: dict):
        self.layout = layout
        self.fd = os.open(path, os.O_WRONLY)

    def write(self, name: str, start: int, values) -> None:
        """``values`` (rows of the dataset ``name``, converted to its dtype) at row ``start``."""
        offset, row, dtype = self.layout[name]
        data = memoryview(np.ascontiguousarray(values, dtype=dtype)).cast("B")
        if not len(data):
            return
        pos, done = offset + start * row, 0
        while done < len(data):
            done += os.pwrite(self.fd, data[done:], pos + done)

    def close(self) -> None:
        os.close(self.fd)


def compact(path: Path, rows: dict) -> None:
    """Replace ``path`` by a copy holding the first ``rows[group]`` rows of every
    dataset of each group ("" the root; ``x1`` whole), with the counts as the
    attributes ``n_time`` (root) and ``n`` (each other group), written under a
    temporary name and renamed over it."""
    # lazy: start-up time (h5py only once a file is read or written)
    import h5py

    path = Path(path)
    tmp = path.with_name(f".{path.name}.compact")
    # HDF5 crashes on a write that fails: the copy (at most the file's size) must fit first
    check_space(path, os.path.getsize(path) + (64 << 10), "the interface file's end-of-run copy")
    if _full(path, rows):  # nothing to trim (a run that reached its end): the bytes as they are
        try:
            shutil.copyfile(path, tmp)  # in the kernel (copy_file_range), not through HDF5
            with h5py.File(tmp, "r+") as dst:
                _count_attrs(dst, rows)
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return
    with h5py.File(path, "r") as src, h5py.File(tmp, "w") as dst:
        dst.attrs.update(dict(src.attrs))

        def copy(name, obj):
            if isinstance(obj, h5py.Group):
                dst.require_group(name).attrs.update(dict(obj.attrs))
                return
            group = _row_group(name)
            n = obj.shape[0] if name == "x1" else min(obj.shape[0], rows.get(group, obj.shape[0]))
            d = dst.create_dataset(name, shape=(n,) + obj.shape[1:], dtype=obj.dtype)
            d.attrs.update(dict(obj.attrs))
            step = max(1, _BLOCK_BYTES // max(1, obj.dtype.itemsize * int(np.prod(obj.shape[1:]))))
            for i in range(0, n, step):
                d[i:min(n, i + step)] = obj[i:min(n, i + step)]

        src.visititems(copy)
        _count_attrs(dst, rows)
    os.replace(tmp, path)


def _row_group(name: str) -> str:
    """The group whose row count a dataset follows ("" the root; ``state/*`` rows are the root's)."""
    group = name.rpartition("/")[0]
    return "" if group.startswith("state") else group


def _count_attrs(f, rows: dict) -> None:
    """The row counts as attributes: ``n_time`` on the root, ``n`` on each other group."""
    for group, n in rows.items():
        f.require_group(group or "/").attrs["n_time" if not group else "n"] = int(n)


def _full(path: Path, rows: dict) -> bool:
    """Whether every dataset of ``path`` has exactly the rows :func:`compact` would keep."""
    # lazy: start-up time (h5py only once a file is read or written)
    import h5py

    full = True

    def check(name, obj):
        nonlocal full
        if isinstance(obj, h5py.Dataset) and name != "x1" and obj.shape:
            full = full and obj.shape[0] == rows.get(_row_group(name), obj.shape[0])

    with h5py.File(path, "r") as f:
        f.visititems(check)
    return full


def _metadata_bytes(n_quantities: int, n_stations: int) -> int:
    """An upper bound of the interface file's HDF5 metadata [bytes] (measured: ~0.2 kB a dataset)."""
    return (64 << 10) + 2048 * (n_quantities + 1 + 11 * n_stations + len(ENERGY))


def free_bytes(folder) -> int:
    """The bytes an unprivileged process may still write on ``folder``'s file system."""
    st = os.statvfs(folder)
    return st.f_bavail * st.f_frsize


def check_space(path: Path, need: int, what: str) -> None:
    """Raise ``OSError(ENOSPC)`` naming ``path`` when its file system has fewer than ``need`` bytes free."""
    free = free_bytes(Path(path).parent)
    if free < need:
        raise OSError(errno.ENOSPC, f"No space left on device: {what} needs {need / 1e6:.3g} MB, the file system "
                      f"has {free / 1e6:.3g} MB free", str(path))


def _nbytes(rows: dict, n_point: int, n_quantities: int, n_stations: int, n_energy: int) -> int:
    """The size of the interface file's data [bytes]."""
    return 8 * (rows["snapshots"] * (1 + n_point * n_quantities) + rows["stations"] * n_stations * 10
                + rows["energy"] * n_energy)


def h5_error(err: Exception, path) -> OSError:
    """An OSError naming ``path`` with the operating system's reason and errno found in
    an h5py error message (h5py reports them in its text only)."""
    text, errno = str(err), getattr(err, "errno", None)
    if errno is None and "errno = " in text:
        digits = text.split("errno = ", 1)[1].split(",", 1)[0].strip()
        errno = int(digits) if digits.isdigit() else None
    if "error message = '" in text:
        reason = text.split("error message = '", 1)[1].split("'", 1)[0]
    elif errno:
        reason = os.strerror(errno)
    else:
        reason = text
    return OSError(errno, reason, str(path))


def interface_profile(interface, points, names=("slip_rate", "shear_traction")) -> dict:
    """All ranks' interface ``points`` (a state's, ``state.points``) now, sorted by x1:
    ``{"x1": ..., name: ...}`` for quantities of :data:`.quantities.QUANTITIES` and
    the law's state variables (collective)."""
    comm = interface.geometry.comm
    p = points
    x1 = np.concatenate(comm.allgather(interface.geometry.x1))
    order = np.argsort(x1, kind="stable")
    out = {"x1": x1[order]}
    for name in names:
        local = np.asarray(BY_NAME[name].read(p), dtype=np.float64)
        out[name] = np.concatenate(comm.allgather(local))[order]
    for k, sname in enumerate(interface.law.state):
        out[sname] = np.concatenate(comm.allgather(np.ascontiguousarray(p.state[:, k])))[order]
    return out

