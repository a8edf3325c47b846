"""Running a mode map (:mod:`fricfem.sweep`): :func:`sweep` makes and locks the
sweep directory, checks every path it writes, runs the points (one round, or
the adaptive map's rounds: :mod:`.adaptive`) and has rank 0 write the maps
(:mod:`.records`)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from mpi4py import MPI

from .. import batch
from ..output.directory import LOCK_FILE, Lock
from ..scene import SceneError
from .adaptive import run_adaptive
from .planning import VARIANTS, check_label
from .records import collect
from .rounds import on_root, run_round


class _Log:
    """Progress lines: every rank appends to ``sweep.log``; rank 0 also prints to stderr."""

    def __init__(self, path: Path, rank: int, quiet: bool):
        self.path, self.rank, self.quiet = path, rank, quiet

    def __call__(self, msg: str) -> None:
        line = f"{time.strftime('%H:%M:%S')} [rank {self.rank}] {msg}"
        try:
            with open(self.path, "a") as fh:
                fh.write(line + "\n")
        except OSError as err:  # the log is a record, not a collective: a failure never stops one rank alone
            if not getattr(self, "failed", False):
                self.failed = True
                print(f"fricfem sweep: warning: {self.path}: cannot append: {err.strerror or err}; progress "
                      f"continues without the log", file=sys.stderr, flush=True)
        if self.rank == 0 and not self.quiet:
            print(line, file=sys.stderr, flush=True)


#: The files rank 0 writes at the top of a map's directory (checked before any point runs).
MAP_FILES = ("modemap.json", "modemap.json.tmp", "modemap.png")
LOG_FILE = "sweep.log"


def _reason(err: OSError) -> str:
    return err.strerror or str(err)


def _writable_file(path: Path) -> None:
    """A file the sweep will write: not a directory or other non-regular file, and its
    folder writable (tried, not guessed: a read-only mount, a full quota)."""
    if path.is_symlink() or (path.exists() and not path.is_file()):
        what = "a directory" if path.is_dir() and not path.is_symlink() else \
            "a symbolic link" if path.is_symlink() else "not a regular file"
        raise SceneError(f"{str(path)!r}: is {what}, where the sweep writes its file {path.name}; remove it or "
                         f"choose another --out")


def _preflight(out: Path, variants: bool):
    """Rank 0, before any point runs: the sweep directory made, locked (as a run
    directory is: :class:`fricfem.output.directory.Lock`, so a second sweep into it
    stops at once), and every path the sweep writes usable — ``sweep.log``
    appendable, ``modemap.json``/``.png`` of every map and ``modemap_variants.png``
    not in the way.  Returns the lock; a :class:`SceneError` naming the path."""
    if out.is_symlink() and not out.exists():
        raise SceneError(f"--out {str(out)!r}: a dangling symbolic link (to {os.readlink(out)!r})")
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise SceneError(f"--out {str(out)!r}: cannot make the directory: {_reason(err)}") from None
    lock = Lock(out / LOCK_FILE)
    lock.acquire(out)  # a RunDirError (a SceneError) names the sweep that holds it
    try:
        dirs = [out] + ([out / name for name in VARIANTS] if variants else [])
        for d in dirs:
            if d.exists() and not d.is_dir():
                raise SceneError(f"{str(d)!r}: is not a directory, where the sweep writes a map")
            for name in MAP_FILES:
                _writable_file(d / name)
            if (d / "points").exists() and not (d / "points").is_dir():
                raise SceneError(f"{str(d / 'points')!r}: is not a directory, where the sweep runs its points")
        if variants:
            _writable_file(out / "modemap_variants.png")
        log = out / LOG_FILE
        _writable_file(log)
        for d in dirs:
            try:
                d.mkdir(parents=True, exist_ok=True)
                probe = d / f".modemap.json.{os.getpid()}.probe"
                probe.write_text("")
                probe.unlink()
                with open(log, "a"):
                    pass
            except OSError as err:
                raise SceneError(f"--out {str(out)!r}: cannot write there: {_reason(err)} "
                                 f"({err.filename or d})") from None
    except BaseException:
        lock.release()
        raise
    return lock


def sweep(base: str, sigma0_mpa, v_imp, out, sets=(), preset=None, label=None, variants=False,
          overwrite=False, quiet=False, comm=MPI.COMM_WORLD, ranks_per_scene: int = 1,
          adaptive: tuple | None = None, reuse: bool = True, planned=None,
          rerun_stopped: bool = False) -> dict | None:
    """Run (or resume) the map(s) (collective on ``comm``).

    ``adaptive``: (coarse Σ0 values, coarse V_imp values) to start an adaptive
    map from (:mod:`.adaptive`); None: every point of the grid.  ``reuse``:
    the points of a group share one model per mesh and interface
    (:mod:`fricfem.model.reuse`; False builds each afresh, for comparison).
    ``planned``: ``plan(...)`` of every point with these arguments, if done
    already (rank 0 uses it instead of loading every scene again).
    ``rerun_stopped``: also recompute the complete points the watchdog stopped
    (their inputs are the same, but the code that judged them may not be).
    Returns ``{"maps": {map name: modemap.json document}, "wall_s"}`` on every
    rank.  Raises :class:`SceneError` on every rank, before any
    run, when an input is bad or (without ``overwrite``) a complete point in
    ``out`` was computed with other inputs.
    """
    t0 = time.perf_counter()
    spec = {"base": base, "sigma0": tuple(sigma0_mpa), "v_imp": tuple(v_imp), "out": Path(out),
            "sets": list(sets or ()), "preset": preset, "variants": variants, "overwrite": overwrite,
            "rerun_stopped": rerun_stopped,
            "planned": planned if comm.rank == 0 else None}
    log = _Log(spec["out"] / LOG_FILE, comm.rank, quiet)
    held = []  # rank 0: the sweep directory's lock
    if label is not None:
        check_label(label)  # the same on every rank: the figures can draw it, before any point runs
    on_root(comm, lambda: held.append(_preflight(spec["out"], variants)), "preparing --out failed")
    try:
        with batch.Pool(comm, ranks_per_scene, reuse=reuse) as pool:
            if adaptive is None:
                maps, points, _, results = run_round(pool, spec, log)
                refined = None
            else:
                maps, points, results, refined = run_adaptive(pool, spec, log, adaptive)
        return on_root(comm, lambda: collect(maps, points, results, spec, label, comm.size, t0, refined),
                        "writing the map failed")
    finally:
        for lock in held:
            lock.release()
