"""Checkpoint and restart: the whole run state in one file, so that a killed or
stopped run continues where it was and gives the same bits as a run never stopped.

What is in it (``checkpoint.fricfem`` in the run directory):

- the State: u^n, v^{n-1/2}, t, n, the struck dofs' last displacement and load,
  the dashpots' memory, which rows are awake, and each rank's running external
  work and absorbed energy;
- every interface point's evolving arrays (the law's state and memo, tractions,
  jumps, slip, slip rate, work, dissipation, open flag, sub-steps);
- the observers' accumulators (their ``snapshot()``): the tip's history,
  initiation, the last energies, the slip-rate spikes, the watchdog's verdicts
  and a user law's watch (per point, in grid order);
- how far each output file had got: interface rows, station rows, energy rows,
  field snapshots, gauge rows.

Every per-dof and per-point array is stored in the grid's order (a dof by its
grid node and component, :mod:`fricfem.model.numbering`; an elastic interface
point by 4 x segment + Gauss point, a rigid one by its node pair), gathered to
rank 0: a checkpoint written on 2 ranks restores on 1 or 3.  Only the energy
shares of the ranks are per rank: restored as they were on the same rank
count, summed onto rank 0 on another (the energies then differ in the last
bits, as between rank counts anyway).

The file: a magic line, one line of JSON (the header: format number, the code
version, the scene key, the step, the payload's length and SHA-256), then the
payload (an ``.npz``).  Rank 0 writes it to a temporary name in the run
directory, fsyncs it and renames it over the last one (:func:`write_file`), so
a kill leaves the previous checkpoint or the new one, whole.  :func:`read_header`
refuses, in one line naming the file and what differs, a file of another
format, of another version of fricfem's code (a hash of its sources, as
:mod:`fricfem.kernels.cache` does for numba), of another scene (a hash of the
resolved input that determines the run, output-only keys left out, and the
rank-independent model key, :func:`fricfem.model.reuse.model_key`), or a file
that is truncated or damaged — before any mesh is built.

A checkpoint is taken right after a flush (so no row is pending anywhere),
every ``output.checkpoint_every`` simulated seconds and/or every
``output.checkpoint_wall`` wall-clock seconds (decided on rank 0 and carried
by the step's existing reduction), and when SIGTERM/SIGINT stops the run.
``fricfem run --resume DIR`` continues from it (:func:`fricfem.runner.run_scene`).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .directory import RunDirError
from .record import read_summary

#: the checkpoint's file name in the run directory
CHECKPOINT_FILE = "checkpoint.fricfem"
#: the file format's number (a file of another number is refused)
FORMAT = 1
MAGIC = b"FRICFEM CHECKPOINT\n"
#: scene keys that do not change what a run computes or writes: left out of the scene key
OUTPUT_ONLY = {"": ("description",), "output": ("checkpoint_every", "checkpoint_wall", "flush_every")}

_ROOT = Path(__file__).resolve().parents[1]
_code = None


class CheckpointError(RunDirError):
    """A checkpoint that cannot be used (one line naming the file and why; on every rank)."""


def code_version() -> str:
    """SHA-256 of fricfem's Python sources (every ``fricfem/**/*.py``, by relative path)."""
    global _code
    if _code is None:
        h = hashlib.sha256()
        for p in sorted(_ROOT.rglob("*.py")):
            h.update(str(p.relative_to(_ROOT)).encode())
            h.update(b"\0")
            h.update(p.read_bytes())
        _code = h.hexdigest()
    return _code


def scene_key(scene) -> str:
    """SHA-256 of what determines a run: the resolved input without :data:`OUTPUT_ONLY`
    keys, and :func:`fricfem.model.reuse.model_key` (the mesh, material, interface...)."""
    from ..model.reuse import model_key  # here: it loads dolfinx, which reading a header does not need

    raw = {}
    for sec, value in scene.raw.items():
        if isinstance(value, dict):
            skip = OUTPUT_ONLY.get(sec, ())
            raw[sec] = {k: v for k, v in value.items() if k not in skip}
        elif sec not in OUTPUT_ONLY[""]:
            raw[sec] = value
    text = json.dumps(raw, sort_keys=True, default=str) + "\n" + repr(model_key(scene))
    return hashlib.sha256(text.encode()).hexdigest()


def enabled(scene) -> bool:
    """Whether the scene asks for checkpoints."""
    out = scene.output
    return bool(out.get("checkpoint_every", 0.0) or out.get("checkpoint_wall", 0.0))


def check_scene(scene) -> None:
    """Refuse, before heavy work, a checkpoint cadence that would never write one."""
    every = float(scene.output.get("checkpoint_every", 0.0) or 0.0)
    if every >= scene.t_end:
        raise CheckpointError(f"output.checkpoint_every = {every:g} s: not below time.end = {scene.t_end:g} s, so "
                              "no checkpoint would be written; use a shorter interval, or 0 for none")


# ---------------------------------------------------------------------------------------------------------------
# the file


def write_file(path: Path, header: dict, arrays: dict) -> int:
    """Write the checkpoint atomically (rank 0): a temporary file in the same folder,
    fsync, rename over ``path``, fsync the folder.  Returns its size [bytes]."""
    path = Path(path)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    payload = buf.getvalue()
    header = {**header, "format": FORMAT, "payload_bytes": len(payload),
              "payload_sha256": hashlib.sha256(payload).hexdigest()}
    text = json.dumps(header, default=str).encode()
    tmp = path.with_name(f".{path.name}.part")
    try:
        with open(tmp, "wb") as f:
            f.write(MAGIC)
            f.write(text + b"\n")
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    try:
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        pass  # a file system that cannot fsync a folder: the rename is still atomic
    return len(MAGIC) + len(text) + 1 + len(payload)


def read_header(path: Path, scene=None, check_code: bool = True) -> dict:
    """The checkpoint's header, checked: magic, format, code version (unless
    ``check_code`` is False), payload length and SHA-256, and (``scene`` given) the
    scene key; :class:`CheckpointError` in one line naming the file and what differs.
    Reads the whole file (its hash), builds nothing."""
    path = Path(path)
    name = str(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise CheckpointError(f"{name}: no checkpoint there (the run wrote none: set output.checkpoint_every "
                              "or output.checkpoint_wall)") from None
    except OSError as err:
        raise CheckpointError(f"{name}: cannot read the checkpoint: {err.strerror}") from None
    if not data.startswith(MAGIC):
        raise CheckpointError(f"{name}: not a fricfem checkpoint (damaged: its first line is not "
                              f"{MAGIC.decode().strip()!r})")
    end = data.find(b"\n", len(MAGIC))
    try:
        header = json.loads(data[len(MAGIC):end]) if end > 0 else None
    except ValueError:
        header = None
    if not isinstance(header, dict):
        raise CheckpointError(f"{name}: damaged checkpoint (its header is not readable JSON)")
    if header.get("format") != FORMAT:
        raise CheckpointError(f"{name}: checkpoint format {header.get('format')!r}, this fricfem reads format "
                              f"{FORMAT}")
    if check_code and header.get("code") != code_version():
        raise CheckpointError(f"{name}: written by another version of fricfem's code (sources "
                              f"{str(header.get('code'))[:12]}, this code {code_version()[:12]}); a restart "
                              "must run the code that wrote it")
    payload = data[end + 1:]
    if len(payload) != header.get("payload_bytes"):
        raise CheckpointError(f"{name}: truncated or damaged checkpoint ({len(payload)} bytes of data, its header "
                              f"says {header.get('payload_bytes')})")
    if hashlib.sha256(payload).hexdigest() != header.get("payload_sha256"):
        raise CheckpointError(f"{name}: damaged checkpoint (its data's SHA-256 differs from its header's)")
    if scene is not None and header.get("scene_key") != scene_key(scene):
        raise CheckpointError(f"{name}: the checkpoint of another scene or other inputs (scene "
                              f"{header.get('scene')!r} key {str(header.get('scene_key'))[:12]}; this run: scene "
                              f"{scene.name!r} key {scene_key(scene)[:12]})")
    header["_payload_offset"] = end + 1
    return header


def read_arrays(path: Path, header: dict) -> dict:
    """The payload's arrays (every rank may call it; the header was checked on rank 0)."""
    with open(path, "rb") as f:
        f.seek(header["_payload_offset"])
        payload = f.read()
    with np.load(io.BytesIO(payload), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def check_resume(out: Path, comm, scene=None) -> dict:
    """Rank 0 reads and checks the checkpoint of ``out`` (:func:`read_header`) and
    whether there is anything to resume (a complete run is refused); every rank
    gets the header or the same :class:`CheckpointError` (collective)."""
    header = problem = None
    if comm.rank == 0:
        try:
            summary = read_summary(out) if (Path(out) / "summary.json").is_file() else {}
            if summary.get("complete"):
                raise CheckpointError(f"--resume {str(out)!r}: the run there is complete (t = "
                                      f"{summary.get('t_s', 0) * 1e6:.6g} µs of time.end = "
                                      f"{summary.get('t_end_s', 0) * 1e6:.6g} µs): nothing to resume")
            if summary.get("watchdog"):
                raise CheckpointError(f"--resume {str(out)!r}: the watchdog stopped the run there ("
                                      f"{' '.join(str(summary['watchdog']).split())[:200]}): it is finished, and "
                                      "would diverge again; run it anew (--overwrite) with other settings")
            header = read_header(Path(out) / CHECKPOINT_FILE, scene)
        except CheckpointError as err:
            problem = str(err)
    header, problem = comm.bcast((header, problem), root=0)
    if problem:
        raise CheckpointError(problem)
    return header


# ---------------------------------------------------------------------------------------------------------------
# the state in the grid's order


def _ids(model) -> dict:
    """Each per-rank array's grid-global indices on this rank, and the global sizes."""
    num, itf = model.num, model.interface
    owned = num.owned_nodes
    dofs = np.asarray(model.impact.dofs, dtype=np.int64)
    geom = itf.geometry
    if hasattr(geom, "segments"):  # elastic: 4 Gauss points a segment (spectral elements: 1, at the node)
        ng = len(geom.shape)
        points = (ng * np.asarray(geom.segments, dtype=np.int64)[:, None] + np.arange(ng)[None, :]).ravel()
        n_points = geom.n_points
    else:  # rigid: one point a node pair
        points = np.asarray(geom.pairs, dtype=np.int64)
        n_points = len(geom.x1_nodes)
    n_grid = len(num.x)
    contact = getattr(itf, "contact", None)  # the experiment's projectile against its buffer: node pairs
    ids = {} if contact is None else {"contact": (np.asarray(contact.geometry.pairs, dtype=np.int64),
                                                  len(contact.geometry.x1_nodes))}
    return {**ids,
        "dof": ((2 * owned[:, None] + np.arange(2)[None, :]).ravel(), 2 * n_grid),
        "node": (owned, n_grid),
        "struck": (2 * num.node_of_block[dofs // 2] + dofs % 2, 2 * n_grid),
        "damped": (num.node_of_block[np.asarray(model.bulk.damped_nodes, dtype=np.int64)], n_grid),
        "point": (points, n_points),
    }


def _gather(comm, ids, values, n):
    """``values`` (rows by ``ids``) of every rank into one array of ``n`` rows in grid
    order on rank 0 (None elsewhere; collective)."""
    values = np.ascontiguousarray(values)
    parts = comm.gather((ids, values), root=0)
    if comm.rank != 0:
        return None
    full = np.zeros((n,) + values.shape[1:], dtype=values.dtype)
    seen = np.zeros(n, dtype=bool)
    for i, v in parts:
        full[i] = v
        seen[i] = True
    return full, seen


#: what kind of index each of a state's per-rank arrays has (:func:`_ids`), by name or prefix
_KINDS = {"u": "dof", "v": "dof", "u_imp_prev": "struck", "react_prev": "struck", "damp_prev": "damped",
          "act": "node", "points.": "point", "contact.": "contact"}
#: a state's scalars: the same on every rank, and each rank's own share (an energy)
_GLOBAL, _SHARES = ("t", "t_interface", "n"), ("work_ext", "absorbed", "viscous")


def _kind(name: str) -> str:
    for key, kind in _KINDS.items():
        if name == key or (key.endswith(".") and name.startswith(key)):
            return kind
    raise CheckpointError(f"the state's {name!r} has no place in a checkpoint")


def snapshot(model, state, watchers: dict) -> tuple | None:
    """The run's state as (header fields, arrays) on rank 0, None elsewhere (collective).
    ``watchers``: the accumulators of the run's observers (:func:`observed`: JSON-able
    scalars under ``"meta"``, arrays under ``"arrays"``, per-point arrays under ``"points"``)."""
    comm = model.comm
    ids = _ids(model)
    parts = state.snapshot()  # this rank's part of everything a step changes (fricfem.step.State)
    items = [(k, v) for k, v in parts.items() if k not in _GLOBAL + _SHARES]
    items += [(f"points.watch.{k}", v) for k, v in watchers["points"].items()]
    arrays = {}
    for name, values in items:
        i, n = ids[_kind(name)]
        got = _gather(comm, i, np.asarray(values), n)
        if got is not None:
            arrays[name] = got[0]
    shares = comm.gather(tuple(float(parts[k]) for k in _SHARES), root=0)
    if comm.rank != 0:
        return None
    for j, k in enumerate(_SHARES):
        arrays[f"rank.{k}"] = np.array([s[j] for s in shares])
    for k, v in watchers["arrays"].items():
        arrays[f"arrays/{k}"] = np.asarray(v)
    meta = {**{k: parts[k] for k in _GLOBAL}, "ranks": comm.size, "dt": model.dt, "watchers": watchers["meta"]}
    meta["n"] = int(meta["n"])
    return meta, arrays


def restore(model, state, arrays: dict, header: dict) -> dict:
    """Set ``state`` (its interface points too) from a checkpoint's ``arrays``; returns
    this rank's observer arrays per point (``<name>``) for :func:`restore_observed`."""
    comm = model.comm
    meta = header["state"]
    if meta["dt"] != model.dt:
        raise CheckpointError(f"the checkpoint's step dt = {meta['dt']!r} s, this model's {model.dt!r} s (another "
                              "machine's or library's lambda_max): refusing to continue with another step")
    ids = _ids(model)
    mine = state.snapshot()
    d = {}
    for name, now in mine.items():
        if name in _GLOBAL:
            d[name] = type(now)(meta[name])
        elif name in _SHARES:
            shares = arrays[f"rank.{name}"]
            if len(shares) == comm.size:
                d[name] = float(shares[comm.rank])
            else:  # another rank count: the shares' sum on rank 0 (the energies differ in the last bits)
                d[name] = float(shares.sum()) if comm.rank == 0 else 0.0
        else:
            value = arrays[name][ids[_kind(name)][0]]
            if name == "act":  # awake then: awake now; the rows this partition treats specially wake as at t = 0
                value = np.maximum(value, model.bulk.activity(at_rest=True))
            d[name] = np.ascontiguousarray(value, dtype=np.asarray(now).dtype)
    state.restore(d)
    i = ids["point"][0]
    return {k[len("points.watch."):]: v[i] for k, v in arrays.items() if k.startswith("points.watch.")}


class Checkpoints:
    """When to take a checkpoint, and taking it (the run's loop calls :meth:`due` after
    each step's watchers, :meth:`take` when due).  ``every`` [s] simulated time
    (0: never), ``wall`` [s] wall-clock time (0: never; rank 0 decides, the loop's
    reduction tells every rank: :meth:`wall_due`)."""

    def __init__(self, out: Path, scene, model):
        self.path = Path(out) / CHECKPOINT_FILE
        self.scene = scene
        self.model = model
        every = float(scene.output.get("checkpoint_every", 0.0) or 0.0)
        self.every = max(1, int(round(every / model.dt))) if every > 0 else 0  # steps
        self.wall = float(scene.output.get("checkpoint_wall", 0.0) or 0.0)
        self.last_wall = time.perf_counter()
        self.taken = 0
        self.seconds = 0.0  # wall time spent taking checkpoints [s]
        self.bytes = 0
        self.key = scene_key(scene)
        self.n_end = int(math.floor(scene.t_end / model.dt + 1e-9))  # as fricfem.step.evolve counts

    def wall_due(self, now: float) -> bool:
        """Rank 0: whether the wall-clock interval has passed."""
        return self.wall > 0 and now - self.last_wall >= self.wall

    def due(self, n: int, stop, wall_flag: bool) -> bool:
        """After step ``n`` and its watchers (``stop``: why the run stops, or None): a
        checkpoint by simulated time or by the reduced wall flag, and when a signal
        stops the run; none at the run's last step or when it stops for good."""
        if stop == "signal":
            return True
        if stop or n >= self.n_end:
            return False
        return (self.every > 0 and n % self.every == 0) or bool(wall_flag)

    def take(self, state, watchers: dict) -> None:
        """Write the checkpoint of ``state`` and ``watchers`` (collective; rank 0 writes)."""
        t0 = time.perf_counter()
        snap = snapshot(self.model, state, watchers)
        error = None
        if snap is not None:
            meta, arrays = snap
            header = {"code": code_version(), "scene": self.scene.name, "scene_key": self.key,
                      "input": self.scene.raw, "step": state.n, "t_s": state.t, "ranks": self.model.comm.size,
                      "written": time.strftime("%Y-%m-%d %H:%M:%S"), "state": meta}
            try:
                self.bytes = write_file(self.path, header, arrays)
            except OSError as err:
                error = f"{err.filename or self.path}: cannot write the checkpoint: {err.strerror}"
        error = self.model.comm.bcast(error, root=0)
        if error is not None:
            raise OSError(error)
        self.taken += 1
        self.last_wall = time.perf_counter()
        self.seconds += self.last_wall - t0


# ---------------------------------------------------------------------------------------------------------------
# resuming a run


#: the files a resumed run sets aside before its writers make them again: the row files (laid out
#: again, their first rows copied back) and the field snapshots' mesh (put back if its order differs)
ASIDE_FILES = ("interface.h5", "gauges.h5", "fields/mesh.h5")


def set_aside(out: Path, comm) -> dict:
    """Rank 0 renames each of :data:`ASIDE_FILES` in ``out`` to ``.<name>.resume``
    beside it (unless an earlier resume, killed, left it there: that one is the
    original); {name: path or None} on every rank.  The run then makes its files
    afresh and takes back from these what the checkpoint counts."""
    found = None
    if comm.rank == 0:
        found = {}
        for name in ASIDE_FILES:
            path = Path(out) / name
            aside = path.with_name(f".{path.name}.resume")
            if not aside.exists() and path.exists():
                os.replace(path, aside)
            found[name] = str(aside) if aside.exists() else None
        # a checkpoint the kill interrupted (the last whole one is in place)
        (Path(out) / f".{CHECKPOINT_FILE}.part").unlink(missing_ok=True)
    return comm.bcast(found, root=0)


# ---------------------------------------------------------------------------------------------------------------
# the observers of the one loop (fricfem.observe): what they accumulate, and the checkpoint as an observer


class Watched(NamedTuple):
    """The observers and writers whose accumulators a checkpoint holds (:mod:`fricfem.observe`)."""

    tip: object  # observe.Tip: tip_t, tip_x, initiation
    spikes: object  # observe.Spikes: peak, x1, time, first, steps_above
    watchdog: object  # observe.Watchdog: diverged; its law_watch (a user's law) per point
    energies: object  # observe.Energies: last, end
    flusher: object  # observe.Flusher: flush() before a checkpoint
    rec: object  # output.recorder.Recorder: rows written
    writer: object  # output.fields.FieldWriter or None: snapshots written
    gauges: object  # output.gauges.GaugeWriter or None: rows written


#: the observers of :class:`Watched` whose own ``snapshot()`` / ``restore()`` a checkpoint holds
_OBSERVERS = ("tip", "spikes", "watchdog", "energies")


def _pack(value, name: str, arrays: dict, points: dict):
    """An observer's snapshot as JSON, its lists (histories) and arrays (this rank's points)
    replaced by references to ``arrays`` and ``points`` (kept in the npz, the points in grid order)."""
    if isinstance(value, dict):
        return {k: _pack(v, f"{name}.{k}", arrays, points) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        points[name] = value
        return {"__points__": name}
    if isinstance(value, list):
        arrays[name] = np.asarray(value, dtype=np.float64)
        return {"__array__": name}
    return value


def _unpack(value, arrays: dict, points: dict):
    """:func:`_pack` undone (on every rank: ``points`` this rank's part)."""
    if isinstance(value, dict):
        if set(value) == {"__points__"}:
            return points[value["__points__"]]
        if set(value) == {"__array__"}:
            return arrays[f"arrays/{value['__array__']}"].tolist()
        return {k: _unpack(v, arrays, points) for k, v in value.items()}
    return value


def observed(w: Watched) -> dict:
    """The accumulators of the observers ``w`` (their ``snapshot()``) and how far each
    output got (this rank's view; rank 0's is the one written): {"meta", "arrays",
    "points"} as :func:`snapshot` takes."""
    arrays, points = {}, {}
    meta = {
        "observers": {k: _pack(getattr(w, k).snapshot(), k, arrays, points) for k in _OBSERVERS},
        "rows": {"snapshots": w.rec.written["snapshots"], "energy": w.rec.written["energy"],
                 "stations": dict(w.rec.station_n)},
        "field_grids": list(w.writer.grids) if w.writer is not None else None,
        "gauge_rows": w.gauges.written if w.gauges is not None else None,
    }
    return {"meta": meta, "arrays": arrays, "points": points}


def restore_observed(w: Watched, header: dict, arrays: dict, point_arrays: dict) -> None:
    """Put the observers' accumulators back from a checkpoint (every rank: their ``restore()``)."""
    packed = header["state"]["watchers"]["observers"]
    for k in _OBSERVERS:
        getattr(w, k).restore(_unpack(packed[k], arrays, point_arrays))


class Checkpointer:
    """The checkpoint as an observer of the loop (:mod:`fricfem.observe`'s contract),
    placed after the flusher and the signals: after a step on the simulated-time
    cadence (``output.checkpoint_every``), when rank 0 says the wall-clock interval
    (``output.checkpoint_wall``) has passed (slot ``checkpoint`` of the loop's one
    reduction), or when a signal stops the run (``signals``' slot), it flushes every
    output and writes the checkpoint (:class:`Checkpoints`).  Never at the run's last step."""

    slots = ("checkpoint",)
    part = "flush"

    def __init__(self, out: Path, scene, model, watched: Watched, signals):
        self.checkpoints = Checkpoints(out, scene, model)
        self.watched = watched
        self.signals = signals
        self.rank0 = model.comm.rank == 0

    def bind(self, reduction) -> None:
        self.red = reduction
        self.i = reduction.slot("checkpoint")

    def contribute(self, state, energy) -> None:
        due = self.rank0 and self.checkpoints.wall_due(time.perf_counter())
        self.red.local[self.i] = 1.0 if due else 0.0

    def observe(self, state, energy) -> None:
        signal = self.signals.red.glob[self.signals.i] > 0
        if self.checkpoints.due(state.n, "signal" if signal else None, self.red.glob[self.i] > 0):
            self.watched.flusher.flush(state)
            self.checkpoints.take(state, observed(self.watched))


def resume_observed(out: Path, header: dict, aside: dict, model, state, w: Watched) -> None:
    """Put the checkpoint of ``out`` back into ``state`` and the observers ``w`` (collective;
    as :func:`resume`)."""
    arrays = read_arrays(Path(out) / CHECKPOINT_FILE, header)
    point_arrays = restore(model, state, arrays, header)
    restore_observed(w, header, arrays, point_arrays)
    _reopen_files(out, header, aside, model.comm, w.rec, w.writer, w.gauges)
    if model.comm.rank == 0:
        sys.stderr.write(f"fricfem: {str(out)!r} goes on from its checkpoint at step {state.n} (t = "
                         f"{state.t * 1e6:.6g} µs; written on {header['ranks']} rank(s), {header.get('written')})\n")


def _reopen_files(out: Path, header: dict, aside: dict, comm, rec, writer, gauges) -> None:
    """interface.h5 and gauges.h5 laid out again with their rows up to the checkpoint
    copied back, the field snapshots after it dropped; the set-aside files removed."""
    meta = header["state"]["watchers"]
    for name, w in (("interface.h5", rec), ("gauges.h5", gauges)):
        if w is None:
            continue
        if aside.get(name) is None:
            raise CheckpointError(f"{Path(out) / name}: missing, so the run cannot continue from "
                                  f"{Path(out) / CHECKPOINT_FILE}")
        w.resume(Path(aside[name]), meta["rows"] if name == "interface.h5" else meta["gauge_rows"] or 0)
    if writer is not None:  # collective
        writer.resume(meta["field_grids"] or [], aside.get("fields/mesh.h5"))
    comm.Barrier()
    if comm.rank == 0:
        for path in aside.values():
            if path is not None:
                Path(path).unlink(missing_ok=True)
