"""Keeping numba's on-disk cache honest.

numba keys a cached function on its own source file only.  fricfem's kernels
inline code from other modules (a law's kernel is
:func:`fricfem.kernels.interface.advance_points` with the law's ``advance``
inlined, which calls its equations module), so after an edit of one of those a cached
kernel would load the old code without a word.  :func:`ensure_fresh` hashes
every module that numba compiles (``fricfem/kernels``, ``fricfem/friction``)
and, when the hash differs from the one stamped beside the cache, removes
fricfem's cached numba files first.  Called once per process before the first
kernel runs (building a model, driving a point).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_ROOT = Path(__file__).resolve().parents[1]
_DIRS = ("kernels", "friction")
_STAMP = "fricfem-numba-sources.sha256"
_done = False


def _sources_hash() -> str:
    h = hashlib.sha256()
    for d in _DIRS:
        for p in sorted((_ROOT / d).glob("*.py")):
            h.update(p.name.encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def _cache_dirs() -> list:
    """Where numba keeps fricfem's cache: NUMBA_CACHE_DIR, else each package's __pycache__."""
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:  # numba's folder for a source folder: its name and a hash of its absolute path
        # lazy: numba's caching internals, only once a kernel is cached
        from numba.core.caching import _CacheLocator

        return [Path(base) / _CacheLocator.get_suitable_cache_subpath(str(_ROOT / d / "__init__.py"))
                for d in _DIRS]
    return [_ROOT / d / "__pycache__" for d in _DIRS]


def ensure_fresh() -> None:
    """Remove fricfem's cached numba files if any numba source changed since they
    were written (once per process; cheap when nothing changed).  Not collective:
    each rank checks, the first to see a change clears (removal tolerates races)."""
    global _done
    if _done:
        return
    _done = True
    digest = _sources_hash()
    for d in _cache_dirs():
        stamp = d / _STAMP
        try:
            if stamp.read_text().strip() == digest:
                continue
        except OSError:
            pass
        if d.is_dir():
            for f in list(d.glob("*.nbi")) + list(d.glob("*.nbc")):
                try:
                    f.unlink()
                except OSError:
                    pass  # another rank removed it, or a read-only install: numba then recompiles
        try:
            d.mkdir(parents=True, exist_ok=True)
            stamp.write_text(digest + "\n")
        except OSError:
            pass  # a read-only cache location: nothing to keep honest
