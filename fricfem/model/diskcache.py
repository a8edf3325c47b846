"""An on-disk cache of the costly, deterministic parts of a model's set-up, so
that a new process running a scene already run skips them.

What is kept, per key (a SHA-256 of everything the value depends on):

    lam-<key>.json   λmax of M⁻¹(K + K_int) (:func:`.assembly.max_eigenvalue`),
                     stored exactly (``float.hex``); one entry for all ranks,
                     written by rank 0
    rows-<key>.npz   this rank's rows of K (:func:`.assembly.canonical_rows`),
                     one entry a rank (compressed), with a SHA-256 of its arrays

The key holds the cache's :data:`FORMAT`, a digest of the source text of the
modules whose code computes the values (:data:`SOURCES`), the versions of
numpy, PETSc and dolfinx and the processor model, the mesh definition and
the material, the number of ranks (λmax's reductions sum in an order that
depends on it), and the partition (each rank's grid nodes); λmax's key
adds the interface kind, the per-point stiffnesses C_n, C_s of every rank,
the struck edges, whether the load is prescribed and the absorbing edges;
the rows' key adds the rank.  A hit therefore gives the bits the same
computation would give: a run with the cache is bit for bit a run without
it.  A model with the experiment's bodies is not cached.

Each entry holds its key and a SHA-256 of key and value, checked when it is
read: an entry copied under another key, edited, or not a regular file (a
FIFO is never opened for a blocking read) is a miss, named in one line on
stderr, and is computed anew.

Where: ``$FRICFEM_CACHE``, else ``$XDG_CACHE_HOME/fricfem``, else
``~/.cache/fricfem``; ``FRICFEM_CACHE=off`` (or empty) turns it off.  Writes
are atomic (a temporary file, then ``os.replace``); an unreadable, corrupted
or foreign entry is ignored and written anew; a directory that cannot be
made or written only means no cache.  The directory is kept under
:data:`MAX_BYTES` (oldest entries removed first).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import stat
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

#: format of the entries (a change makes every older entry a miss)
FORMAT = 1
#: modules (relative to the package) whose code computes a cached value
SOURCES = ("model/assembly.py", "model/grid.py", "model/mesh.py", "model/numbering.py", "model/interface.py",
           "model/material.py", "model/diskcache.py", "model/sem.py", "step/interface.py", "kernels/interface.py",
           "kernels/reduce.py", "kernels/sem.py")
#: the cache directory's size cap [bytes]
MAX_BYTES = 256 * 2**20
_OFF = ("", "off", "0", "no", "false", "none")


def cache_dir() -> Path | None:
    """The cache directory, or None when the cache is off (``FRICFEM_CACHE``)."""
    value = os.environ.get("FRICFEM_CACHE")
    if value is not None:
        return None if value.strip().lower() in _OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or "~/.cache"
    return Path(base).expanduser() / "fricfem"


@functools.lru_cache(maxsize=None)
def code_version() -> str:
    """SHA-256 of the :data:`SOURCES` and of the numerical libraries' versions."""
    # lazy: start-up time (dolfinx/petsc4py are slow to import)
    import dolfinx
    import petsc4py

    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256(f"{FORMAT} {np.__version__} {petsc4py.__version__} {dolfinx.__version__} "
                       f"{_processor()}".encode())
    for rel in SOURCES:
        path = root / rel
        h.update(rel.encode() + b"\0" + (path.read_bytes() if path.is_file() else b"(none)") + b"\0")
    return h.hexdigest()


def _processor() -> str:
    """The machine and processor model (a BLAS may pick its kernels, and so its
    rounding, by processor: a cache shared between machines keeps their λmax apart)."""
    try:
        with open("/proc/cpuinfo") as fh:
            model = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), "")
    except OSError:
        model = ""
    return f"{platform.machine()} {model or platform.processor()}"


def _digest(*parts) -> str:
    """SHA-256 of ``parts``: arrays by dtype, shape and bytes, anything else by repr."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"array {a.dtype.str} {a.shape}".encode())
            h.update(a.data)
        else:
            h.update(f"{type(p).__name__} {p!r}".encode())
        h.update(b"\0")
    return h.hexdigest()


def _model_parts(spec, material, num, comm) -> tuple:
    return (code_version(), spec, material, comm.size, num.n_owned, num.node_of_block)


def rows_key(spec, material, num, comm) -> str:
    """The key of this rank's rows of K."""
    return _digest("rows", *_model_parts(spec, material, num, comm), comm.rank)


def lam_key(spec, material, num, comm, interface, interface_kind, impact_tags, prescribed, absorbing) -> str:
    """The key of λmax, the same on every rank (collective: one allgather of a digest)."""
    mine = _digest(*_model_parts(spec, material, num, comm), interface.initial.Cn, interface.initial.Cs)
    ranks = comm.allgather(mine)
    return _digest("lam", ranks, interface_kind, tuple(impact_tags), bool(prescribed), tuple(absorbing))


# --- entries on disk

def _write(path: Path, write) -> None:
    """Write an entry atomically with ``write(file)``; any failure means no entry."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.replace(tmp, path)
        tmp = None
        _prune(path.parent)
    except Exception:  # a cache that cannot be written is no cache
        pass
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def _prune(folder: Path, limit: int = MAX_BYTES) -> None:
    """Remove the oldest entries until the folder holds at most ``limit`` bytes."""
    entries = []
    for e in os.scandir(folder):
        if e.is_file() and (e.name.startswith("lam-") or e.name.startswith("rows-")):
            st = e.stat()
            entries.append((st.st_mtime, st.st_size, e.path))
    total = sum(s for _, s, _ in entries)
    for _, size, path in sorted(entries):
        if total <= limit:
            break
        try:
            os.unlink(path)
        except OSError:
            pass
        total -= size


def _rows_digest(key: str, ptr, cols, vals) -> np.ndarray:
    """The checksum of a rows entry: its key and its arrays."""
    return np.frombuffer(bytes.fromhex(_digest(key, ptr, cols, vals)), dtype=np.uint8)


def _lam_digest(key: str, lam_hex: str) -> str:
    """The checksum of a λmax entry: its key and its value."""
    return _digest("lam entry", key, lam_hex)


class Forged(Exception):
    """An entry that is not what its name says: another key inside, a checksum that
    does not match its contents, or not a regular file (a miss, with a notice)."""


def _open_regular(path: Path):
    """``path`` opened for reading if it is a regular file (a FIFO or a device is never
    opened for a blocking read: ``O_NONBLOCK``, then ``fstat``); raises :class:`Forged` if not."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise Forged("not a regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _read(name: str, parse):
    """``parse(file)`` of the entry ``name`` (opened only if a regular file), or None:
    no usable cache, or the entry missing, truncated, corrupted or forged (any error is
    a miss; the twin of :func:`_write`).  A forged entry (:class:`Forged`) is named in
    one line on stderr: it is computed anew and replaced."""
    root = cache_dir()
    if root is None:
        return None
    path = root / name
    try:
        with _open_regular(path) as fh:
            return parse(fh)
    except Forged as why:
        _notice(path, str(why))
        return None
    except Exception:  # missing, truncated, corrupted: a miss
        return None


def _notice(path: Path, why: str) -> None:
    try:
        sys.stderr.write(f"fricfem: notice: set-up cache entry {path} ignored ({why}); computing it anew\n")
    except (OSError, ValueError):
        pass


def load_rows(key: str, n_owned: int):
    """The cached rows ``(ptr, cols, vals)`` of ``key``, or None (missing or bad)."""

    def parse(fh):
        with np.load(fh, allow_pickle=False) as z:
            ptr, cols, vals, check = z["ptr"], z["cols"], z["vals"], z["digest"]
            stored = bytes(z["key"]).decode("ascii", "replace") if "key" in z.files else None
        if stored != key:
            raise Forged("it holds the rows of another model: the key inside differs from its name")
        ok = (ptr.dtype == np.int64 and cols.dtype == np.int64 and vals.dtype == np.float64
              and ptr.shape == (n_owned + 1,) and vals.shape == (len(cols), 4) and int(ptr[-1]) == len(cols))
        if not ok:
            return None
        if not np.array_equal(check, _rows_digest(key, ptr, cols, vals)):
            raise Forged("its checksum does not match its contents")
        return ptr, cols, vals

    return _read(f"rows-{key}.npz", parse)


def save_rows(key: str, rows: tuple) -> None:
    """Keep this rank's rows under ``key`` (silently nothing without a usable cache),
    with the key and a checksum of key and arrays inside."""
    root = cache_dir()
    if root is None:
        return
    ptr, cols, vals = rows
    arrays = {"ptr": ptr, "cols": cols, "vals": vals, "key": np.frombuffer(key.encode("ascii"), dtype=np.uint8),
              "digest": _rows_digest(key, ptr, cols, vals)}
    _write(root / f"rows-{key}.npz", lambda fh: _savez_fast(fh, arrays))


def _savez_fast(fh, arrays: dict) -> None:
    """``np.savez_compressed`` at zlib level 1 (a third of the time of its level 6, ~1.4× the bytes)."""
    with zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for name, a in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(a), allow_pickle=False)


def cached_rows(spec, material, num, comm, compute) -> tuple:
    """This rank's rows of K: from the cache, else ``compute()`` (then kept).  Not collective."""
    if cache_dir() is None:
        return compute()
    key = rows_key(spec, material, num, comm)
    rows = load_rows(key, num.n_owned)
    if rows is None:
        rows = compute()
        save_rows(key, rows)
    return rows


def load_lam(key: str):
    """The cached λmax of ``key`` (a float), or None."""

    def parse(fh):
        entry = json.loads(fh.read().decode())
        if entry.get("format") != FORMAT:
            return None
        if entry.get("key") != key:
            raise Forged("it holds the λmax of another model: the key inside differs from its name")
        if entry.get("digest") != _lam_digest(key, entry["lam"]):
            raise Forged("its checksum does not match its contents")
        lam = float.fromhex(entry["lam"])
        return lam if np.isfinite(lam) and lam > 0 else None

    return _read(f"lam-{key}.json", parse)


def save_lam(key: str, lam: float) -> None:
    root = cache_dir()
    if root is None:
        return
    text = json.dumps({"format": FORMAT, "key": key, "lam": float(lam).hex(), "value": repr(float(lam)),
                       "digest": _lam_digest(key, float(lam).hex())})
    _write(root / f"lam-{key}.json", lambda fh: fh.write(text.encode()))


def cached_lam(key_parts: tuple, comm, compute) -> float:
    """λmax: from the cache (read on rank 0, broadcast), else ``compute()`` on
    every rank (then kept by rank 0).  Collective.  ``key_parts``: the
    arguments of :func:`lam_key` after ``comm``."""
    if cache_dir() is None:  # the same environment on every rank
        return compute()
    spec, material, num, *rest = key_parts
    key = lam_key(spec, material, num, comm, *rest)
    lam = comm.bcast(load_lam(key) if comm.rank == 0 else None, root=0)
    if lam is None:
        lam = compute()
        if comm.rank == 0:
            save_lam(key, lam)
    return lam
