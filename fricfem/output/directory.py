"""The run directory as a place: made, locked, owned, replaced.

Before a run writes anything (rank 0; :func:`prepare`):

- the directory itself must not be a symbolic link (a dangling one included):
  fricfem writes where it is told, not where a link points;
- it is made (with its parents); an error of the file system (read-only, no
  permission, a parent that is a regular file, a name too long, no space) is
  one line naming the path;
- ``.fricfem.lock`` is created exclusively and holds the pid, host, start
  time and command of the run.  A second run into the same directory fails at
  once naming the first; a lock left by a run that was killed (its pid gone,
  or another process under that pid) is stale and taken over;
- a non-empty directory is refused without ``overwrite``; with it, only what
  fricfem wrote there is removed — the files listed in ``.fricfem-manifest.json``
  (written before any output), its temporary files and the figures of
  ``fricfem plot`` — each unlinked, never followed if it is a symbolic link.
  Anything else in the way of a file fricfem writes (a directory named
  ``interface.h5``, a file fricfem did not write) is refused with its name.
"""

from __future__ import annotations

import errno as errno_mod
import json
import os
import re
import socket
import sys
import time
from pathlib import Path

from ..scene.schema import SceneError

LOCK_FILE = ".fricfem.lock"
MANIFEST_FILE = ".fricfem-manifest.json"
#: what a run writes at the top of its directory, and the folder of its field files
RUN_FILES = ("interface.h5", "fields.xdmf", "summary.json", "evidence.json", "gauges.h5", "checkpoint.fricfem")
RUN_DIRS = {"fields": re.compile(r"(mesh|t\d{4,})\.h5|\.mesh\.(h5|xdmf)(\.resume)?|\..*\.part(\.h5|\.xdmf)?"),
            "plots": re.compile(r"(interface_.*|tip_speed|station_.*|spacetime|isochromatic.*)\.png")}
#: files of runs made before the manifest existed (recognised by their summary.json)
LEGACY_FILES = ("interface.h5", "fields.xdmf", "fields.h5", "summary.json")
#: temporary files (written, then renamed over their final name)
_TEMPORARY = re.compile(r"\.(interface\.h5|summary\.json|evidence\.json|fields\.xdmf|gauges\.h5|fricfem-manifest\.json"
                        r"|checkpoint\.fricfem)\..*(part|compact|resume)")
STALE_EMPTY_LOCK_S = 5.0


class RunDirError(SceneError):
    """A run directory that cannot be used (raised on every rank, before heavy work;
    a :class:`~fricfem.scene.SceneError`, as every other input that cannot be run)."""


def _reason(err: OSError) -> str:
    return err.strerror or os.strerror(err.errno) if err.errno else str(err)


def _stat(pid: int):
    """The fields of ``/proc/PID/stat`` after the command's name (Linux), or None."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except OSError:
        return None


def _start_ticks(pid: int):
    """The start time of process ``pid`` in clock ticks since boot (Linux), or None."""
    stat = _stat(pid)
    return None if stat is None else int(stat[19])


def _alive(info: dict) -> bool:
    """Whether the process a lock names still runs (False only when certain it does not)."""
    if info.get("host") != socket.gethostname():
        return True  # another machine's run: cannot tell
    pid = info.get("pid")
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    stat = _stat(pid)
    if stat is not None and stat[0] in ("Z", "X"):  # killed, not yet reaped: it writes nothing any more
        return False
    ticks = None if stat is None else int(stat[19])
    return ticks is None or info.get("start_ticks") in (None, ticks)


class Lock:
    """The exclusive lock of a run directory (rank 0 holds it)."""

    def __init__(self, path: Path):
        self.path = path
        self.info = {"pid": os.getpid(), "host": socket.gethostname(), "start_ticks": _start_ticks(os.getpid()),
                     "started": time.strftime("%Y-%m-%d %H:%M:%S"), "command": " ".join(sys.argv)[:500]}

    def acquire(self, out: Path) -> None:
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY | os.O_NOFOLLOW, 0o644)
            except FileExistsError:
                held = self._holder()
                if held is None:  # stale: taken over
                    self.path.unlink(missing_ok=True)
                    continue
                raise RunDirError(f"--out {str(out)!r}: another fricfem run is writing there ({held}); wait "
                                  f"for it, or remove {str(self.path)!r} if that run is gone") from None
            except OSError as err:
                raise RunDirError(f"--out {str(out)!r}: cannot write there: {_reason(err)}") from None
            try:
                os.write(fd, json.dumps(self.info).encode())
            except OSError as err:
                os.close(fd)
                self.path.unlink(missing_ok=True)
                raise RunDirError(f"{str(self.path)!r}: cannot write: {_reason(err)}") from None
            os.close(fd)
            return
        raise RunDirError(f"--out {str(out)!r}: another fricfem run took the lock {str(self.path)!r} at the "
                          "same moment")

    def _holder(self) -> str | None:
        """Who holds the lock (a description), or None if the lock is stale."""
        try:
            text = self.path.read_text()
            age = time.time() - self.path.lstat().st_mtime
        except FileNotFoundError:
            return None
        except OSError as err:
            return f"lock {str(self.path)!r} unreadable: {_reason(err)}"
        try:
            info = json.loads(text)
        except ValueError:
            # being written this instant by another run, or left empty by a killed one
            return None if age > STALE_EMPTY_LOCK_S else "a run that is starting"
        if not isinstance(info, dict) or not _alive(info):
            return None
        return f"pid {info.get('pid')} on {info.get('host')}, since {info.get('started')}: {info.get('command')}"

    def release(self) -> None:
        """Remove the lock if it is still this process's."""
        try:
            if json.loads(self.path.read_text()).get("pid") == self.info["pid"]:
                self.path.unlink()
        except (OSError, ValueError):
            pass


def _owned(out: Path) -> tuple[set, bool]:
    """(names fricfem wrote at the top of ``out``, whether a manifest says so)."""
    try:
        doc = json.loads((out / MANIFEST_FILE).read_text())
        files = doc.get("files") if isinstance(doc, dict) else None
        if isinstance(files, list):
            return {f for f in files if isinstance(f, str) and "/" not in f and f not in (".", "..")}, True
    except (OSError, ValueError):
        pass
    try:  # a run directory from before the manifest: its summary.json says so
        summary = out / "summary.json"
        doc = json.loads(summary.read_text()) if summary.is_file() and not summary.is_symlink() else None
        if isinstance(doc, dict) and "scene" in doc and "input" in doc:
            return set(LEGACY_FILES), False
    except (OSError, ValueError):
        pass
    return set(), False


def _remove(path: Path, name: str) -> None:
    """Unlink one entry fricfem wrote (a link itself, never its target); a directory
    where fricfem wrote a file is refused."""
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.is_dir():
        raise RunDirError(f"{str(path)!r}: is a directory, not the file {name} fricfem wrote; remove it yourself "
                          "or choose another --out")


def _clear(out: Path) -> None:
    """Remove what fricfem wrote in ``out`` (``--overwrite``)."""
    owned, _ = _owned(out)
    for entry in sorted(os.listdir(out)):
        path = out / entry
        if entry in RUN_DIRS and path.is_dir() and not path.is_symlink():
            for inner in os.listdir(path):
                if RUN_DIRS[entry].fullmatch(inner) and not (path / inner).is_dir():
                    (path / inner).unlink()
            if not os.listdir(path):
                path.rmdir()
        elif entry in owned or _TEMPORARY.fullmatch(entry) or entry == MANIFEST_FILE:
            _remove(path, entry)
    for name in (*RUN_FILES, *RUN_DIRS):
        path = out / name
        if path.exists() or path.is_symlink():
            if name in RUN_DIRS and path.is_dir() and not path.is_symlink():
                continue  # holds something else too: fricfem's own files in it are gone
            raise RunDirError(f"{str(path)!r}: in the way of the run's {name}, and not written by fricfem here "
                              f"(no {MANIFEST_FILE} lists it); remove it yourself or choose another --out")


def prepare(out: Path, overwrite: bool) -> Lock:
    """Make, lock and (with ``overwrite``) clear the run directory ``out`` (rank 0);
    a :class:`RunDirError` with one line naming the path when it cannot be used."""
    out = Path(out)
    try:
        if out.is_symlink():
            raise RunDirError(f"--out {str(out)!r}: is a symbolic link (to {os.readlink(out)!r}); give the "
                              "directory itself")
        if out.exists() and not out.is_dir():
            raise RunDirError(f"--out {str(out)!r}: exists and is not a directory")
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        what = "a parent is not a directory" if err.errno == errno_mod.ENOTDIR else _reason(err)
        raise RunDirError(f"--out {str(out)!r}: cannot make the directory: {what}") from None
    lock = Lock(out / LOCK_FILE)
    lock.acquire(out)
    try:
        others = [e for e in os.listdir(out) if e != LOCK_FILE]
        if others and not overwrite:
            raise RunDirError(f"--out {str(out)!r}: directory is not empty; pass --overwrite to replace its run")
        if others:
            _clear(out)
        manifest = {"written_by": "fricfem", "files": [*RUN_FILES, MANIFEST_FILE],
                    "dirs": {k: v.pattern for k, v in RUN_DIRS.items()}}
        tmp = out / f".{MANIFEST_FILE}.part"
        tmp.write_text(json.dumps(manifest, indent=1))
        os.replace(tmp, out / MANIFEST_FILE)
    except OSError as err:
        lock.release()
        raise RunDirError(f"{str(err.filename or out)!r}: {_reason(err)}") from None
    except BaseException:
        lock.release()
        raise
    return lock


def reopen(out: Path) -> Lock:
    """Lock the run directory ``out`` of a run to be resumed, keeping what is in it (rank 0;
    ``fricfem run --resume``): it must be a directory fricfem wrote (its manifest), not a
    symbolic link; a lock left by the killed run is stale and taken over, one held by a
    live run is refused."""
    out = Path(out)
    if out.is_symlink():
        raise RunDirError(f"--resume {str(out)!r}: is a symbolic link (to {os.readlink(out)!r}); give the "
                          "directory itself")
    if not out.is_dir():
        raise RunDirError(f"--resume {str(out)!r}: no such run directory")
    if not (out / MANIFEST_FILE).is_file():
        raise RunDirError(f"--resume {str(out)!r}: not a fricfem run directory (no {MANIFEST_FILE})")
    lock = Lock(out / LOCK_FILE)
    lock.acquire(out)
    return lock
