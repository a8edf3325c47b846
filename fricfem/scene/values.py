"""One scene value against its key (:class:`fricfem.keys.Key`: type, finiteness,
range, choices), and identifiers (scene, station and gauge names): the checks
every rule of :mod:`.validate` and :mod:`.output_keys` is made of.  Each
problem is one :class:`~.schema.SceneError` naming the key, the value and what
is allowed."""

from __future__ import annotations

import math
import re

from ..keys import NUM, Key
from .schema import SceneError, shown

#: An identifier: scene names (run directories) and station names (HDF5 paths).
_IDENT = re.compile(r"[A-Za-z0-9_.\-]+")


def check_identifier(where: str, v, max_len: int) -> str:
    """``v`` if it is an identifier: 1–``max_len`` characters among letters, digits,
    ``_ - .``, and not ``.`` or ``..`` (safe as a file name and an HDF5 path)."""
    if not isinstance(v, str):
        raise SceneError(f"{where} = {shown(v)}: expected a string")
    if not v or len(v) > max_len or not _IDENT.fullmatch(v) or v in (".", ".."):
        raise SceneError(f"{where} = {shown(v)}: must be 1–{max_len} letters, digits, '_', '-' or '.', and not "
                         f"'.' or '..'")
    return v


def check_value(where: str, k: Key, v):
    """``v`` if it fits key ``k`` (type, finiteness, range, choices), else a SceneError."""
    if k.kind == NUM:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{where} = {shown(v)}: expected a number [{k.unit}] ({k.doc})")
        if not math.isfinite(v):
            raise SceneError(f"{where} = {v!r}: must be finite")
    elif k.kind is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{where} = {shown(v)}: expected a whole number [{k.unit}] ({k.doc})")
    elif not isinstance(v, k.kind):
        names = {str: "a string", bool: "true or false", list: "a list", dict: "a table"}
        kinds = k.kind if isinstance(k.kind, tuple) else (k.kind,)
        raise SceneError(f"{where} = {shown(v)}: expected {' or '.join(names.get(t, str(t)) for t in kinds)} "
                         f"({k.doc})")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        lo_bad = k.low is not None and (v <= k.low if k.open_low else v < k.low)
        hi_bad = k.high is not None and (v >= k.high if k.open_high else v > k.high)
        if lo_bad or hi_bad:
            raise SceneError(f"{where} = {v!r} {k.unit}: must lie in {k.range_text()} {k.unit} ({k.doc})"
                             .replace("  ", " "))
    if k.choices and v not in k.choices:
        sep = " or " if len(k.choices) == 2 else ", "
        raise SceneError(f"{where} = {shown(v)}: allowed {sep.join(map(repr, k.choices))}")
    return v
