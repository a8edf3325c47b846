"""``fricfem show SCENE``: a scene resolved through its ``base`` chain and its
``--set`` overrides, written as TOML that ``fricfem run`` accepts back.

The TOML is written here (no writer ships with Python): the top-level keys,
then one ``[section]`` per table, nested tables and lists of tables inline.
Floats are written with ``repr`` (shortest round-trip form), so the file loads
back to the same numbers and the same :class:`~fricfem.scene.Scene`.
"""

from __future__ import annotations

import json
import math
import re

from . import scene as scene_mod
from .scene.load import MAX_DEPTH, _locate, read_toml

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    # JSON's escapes are TOML basic-string escapes; TOML also wants DEL escaped
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007F")


def value(v) -> str:
    """One TOML value (inline form for tables and arrays)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(str(k))} = {value(x)}" for k, x in v.items()) + " }" if v else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    raise TypeError(f"{type(v).__name__} {v!r}: no TOML form")


def dumps(raw: dict, header: str = "") -> str:
    """TOML text of a scene's raw tables (top-level keys, then one table per section)."""
    lines = [f"# {line}" for line in header.splitlines()]
    top = {k: v for k, v in raw.items() if not isinstance(v, dict)}
    lines += [f"{_key(k)} = {value(v)}" for k, v in top.items()]
    for section, table in raw.items():
        if not isinstance(table, dict):
            continue
        lines += ["", f"[{_key(section)}]"]
        lines += [f"{_key(str(k))} = {value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def chain(ref: str) -> list:
    """The files of a scene's base chain, the scene's own first."""
    out, path = [], _locate(str(ref))
    while path is not None and len(out) <= MAX_DEPTH:
        out.append(str(path))
        base = read_toml(path).get("base", "")
        path = _locate(base, path.parent) if isinstance(base, str) and base.strip() else None
    return out


def show(ref: str, overrides=()) -> str:
    """The TOML of scene ``ref`` with ``overrides`` (validated first: a bad scene is one SceneError)."""
    scene_mod.load(ref, overrides)  # the same checks as `fricfem run`
    raw = scene_mod.apply_overrides(scene_mod.resolve(ref), overrides)
    files = chain(ref)
    header = "\n".join([
        f"fricfem show {ref}" + "".join(f" --set {o}" for o in overrides or ()),
        "resolved from " + " <- ".join(files) if len(files) > 1 else f"from {files[0]}",
        "every key the files set (defaults not shown: `fricfem scenes --keys`); `fricfem run THIS.toml` runs it",
    ])
    return dumps(raw, header)
