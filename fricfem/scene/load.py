"""Scene files: shipped scenes, inheritance (``base``), merging, ``--set`` overrides.

A scene is a TOML file; the paper's ship in ``fricfem/scenes/``.  A file may
start from another (``base = "case1"`` or a path, relative to the file) and
override keys; ``--set section.key=value`` overrides from the command line.

Merge rules (docs/scenes.md): ``name`` is the file's own (its ``name`` key, else
the file's name), never the base's; tables merge key by key (``[loading]``,
``[friction.params]``, ...), except ``output.stations``, which a scene
replaces whole; lists (``output.fields``, ``friction.regions``,
``interface.patches``) are replaced whole too.  ``--set`` works on the merged
tables the same way (``--set output.stations.x20mm=0.02`` adds one station to
the merged ones, ``--set output.stations={...}`` replaces them).

A scene file is read only if it is a regular file of at most
:data:`MAX_BYTES`, UTF-8 text with at least one key; ``base`` chains are at
most :data:`MAX_DEPTH` deep.  Every problem is one :class:`SceneError` naming
the file.
"""

from __future__ import annotations

import copy
import errno
import os
import stat
import tomllib
from pathlib import Path

from .schema import SCHEMA, SceneError, shown

SCENE_DIR = Path(__file__).resolve().parents[1] / "scenes"

#: Largest scene or mesh file read [bytes] (the shipped ones are ~3 kB).
MAX_BYTES = 4 << 20
#: Longest ``base`` chain followed.
MAX_DEPTH = 32
#: Keys whose value is a table of free names (``--set`` may reach one level into them).
_OPEN_TABLES = {("friction", "params"), ("output", "stations"), ("output", "gauges")}


def shipped() -> dict:
    """Shipped scene name -> path."""
    return {p.stem: p for p in sorted(SCENE_DIR.glob("*.toml"))}


def read_text(path, what: str = "scene file") -> str:
    """The UTF-8 text of a regular file of at most :data:`MAX_BYTES`, or a SceneError
    naming it (missing, a directory, a FIFO or device, a symlink loop, too large,
    unreadable, not UTF-8).  Never blocks on a FIFO nor reads a device."""
    name = shown(str(path), 200)
    try:
        st = os.stat(path)  # follows symlinks; a loop is ELOOP
    except FileNotFoundError:
        raise SceneError(f"{what} {name} not found") from None
    except (OSError, ValueError) as err:  # ValueError: an embedded NUL byte
        if isinstance(err, OSError) and err.errno == errno.ELOOP:
            raise SceneError(f"{what} {name}: symbolic link loop") from None
        raise SceneError(f"{what} {name}: cannot read: {getattr(err, 'strerror', None) or err}") from None
    if stat.S_ISDIR(st.st_mode):
        raise SceneError(f"{what} {name} is a directory, not a .toml file")
    if not stat.S_ISREG(st.st_mode):
        kind = "a FIFO" if stat.S_ISFIFO(st.st_mode) else "a device" if (
            stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)) else "not a regular file"
        raise SceneError(f"{what} {name} is {kind}; expected a regular .toml file")
    if st.st_size > MAX_BYTES:
        raise SceneError(f"{what} {name}: {st.st_size} bytes; at most {MAX_BYTES >> 20} MB are read")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)  # the size may lie (procfs) or grow
    except OSError as err:
        raise SceneError(f"{what} {name}: cannot read: {err.strerror or err}") from None
    if len(data) > MAX_BYTES:
        raise SceneError(f"{what} {name}: larger than {MAX_BYTES >> 20} MB; not read")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SceneError(f"{what} {name} is not UTF-8 text (byte 0x{data[err.start]:02x} at offset "
                         f"{err.start})") from None


def read_toml(path, what: str = "scene file") -> dict:
    """The tables of a TOML file read by :func:`read_text`; an empty one (nothing but
    whitespace and comments) is an error."""
    text = read_text(path, what)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{what} {str(path)!r} is not valid TOML: {err}") from None
    except RecursionError:
        raise SceneError(f"{what} {str(path)!r}: nested too deeply") from None
    if not raw:
        raise SceneError(f"{what} {str(path)!r} has no keys (it is empty or holds only whitespace and comments)")
    _check_depth(raw, f"{what} {str(path)!r}")
    return raw


#: Deepest nesting of tables and lists accepted (a scene needs 4: friction.regions[i].params).
MAX_NESTING = 16


def _check_depth(value, where: str) -> None:
    """Refuse values nested deeper than :data:`MAX_NESTING` (checked without recursion)."""
    stack = [(value, 0)]
    while stack:
        v, d = stack.pop()
        if d > MAX_NESTING:
            raise SceneError(f"{where}: tables or lists nested deeper than {MAX_NESTING} levels")
        if isinstance(v, dict):
            stack.extend((x, d + 1) for x in v.values())
        elif isinstance(v, list):
            stack.extend((x, d + 1) for x in v)


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k != "stations":
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _locate(ref: str, folder: Path | None = None) -> Path:
    """The file of a shipped name or a .toml path (relative to ``folder`` if given); on the
    command line (no ``folder``) any existing path is a scene file too."""
    path = shipped().get(ref) if not ref.endswith(".toml") else Path(ref)
    if path is None and folder is None and ("/" in ref or os.path.lexists(ref)):
        path = Path(ref)
    if path is None:
        raise SceneError(f"scene {shown(ref)}: no such shipped scene or .toml file; shipped: {', '.join(shipped())}")
    if folder is not None and not path.is_absolute() and ref.endswith(".toml"):
        path = folder / path
    return path


def resolve(ref: str | Path, _seen=()) -> dict:
    """The raw merged tables of a scene given by shipped name or file path (``base`` chains followed)."""
    ref = str(ref)
    if not ref.strip():
        raise SceneError("scene '': empty; give a shipped scene name or a .toml path")
    return _resolve(_locate(ref), ref, _seen)


def _resolve(path: Path, ref: str, seen: tuple) -> dict:
    try:
        key = os.path.realpath(path)
    except (OSError, ValueError):
        key = str(path)
    if key in seen:
        raise SceneError(f"base: scene {ref!r} inherits from itself")
    if len(seen) >= MAX_DEPTH:
        raise SceneError(f"base: the chain of base scenes is deeper than {MAX_DEPTH} (at {ref!r})")
    raw = read_toml(path)
    _anchor(raw, path.parent)
    own_name = raw.get("name")
    base = raw.get("base", "")
    if base != "":
        if not isinstance(base, str) or not base.strip():
            raise SceneError(f"base = {shown(base)} (in {str(path)!r}): expected the name of a shipped scene or a "
                             f".toml path")
        if base not in shipped() and not base.endswith(".toml"):
            raise SceneError(f"base = {shown(base)}: no such shipped scene or .toml file; shipped: "
                             f"{', '.join(shipped())}")
        parent = _resolve(_locate(base, path.parent), base, seen + (key,))
        raw = _merge(parent, {k: v for k, v in raw.items() if k != "base"})
    raw.pop("base", None)
    raw["name"] = path.stem if own_name is None else own_name  # never the base's: its own run directory
    return raw


def _anchor(raw: dict, folder: Path) -> None:
    """A mesh file named by a relative path is relative to the scene file naming it."""
    mesh = raw.get("mesh")
    preset = mesh.get("preset") if isinstance(mesh, dict) else None
    if isinstance(preset, str) and preset.endswith(".toml") and not Path(preset).is_absolute():
        mesh["preset"] = str(folder / preset)


def parse_override(item: str) -> tuple:
    """``section.key=value`` -> (["section", "key"], value); value parsed as TOML, else a string.

    The key path must name a scene key: ``name`` or ``description`` at the top
    level, ``section.key`` of the schema, or one entry of ``friction.params`` /
    ``output.stations`` (``friction.params.mu_s``).  ``base`` cannot be set:
    it is followed when the file is read.
    """
    if not isinstance(item, str):
        raise SceneError(f"--set {shown(item)}: expected <section.key>=<value>, e.g. loading.v_imp=10")
    key, sep, text = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SceneError(f"--set {shown(item)}: expected <section.key>=<value>, e.g. loading.v_imp=10")
    keys = key.split(".")
    if any(not k.strip() for k in keys):
        raise SceneError(f"--set {shown(item)}: the key path {key!r} has an empty part; expected <section.key>, "
                         f"e.g. loading.v_imp")
    keys = [k.strip() for k in keys]
    _check_path(item, keys)
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        value = text
    _check_depth(value, f"--set {key}")
    return keys, value


def _check_path(item: str, keys: list) -> None:
    """The key path of a ``--set`` names a scene key (else one SceneError)."""
    head = keys[0]
    if head == "base":
        raise SceneError(f"--set {shown(item)}: base cannot be overridden (it is followed when the scene file is "
                         f"read); write a scene file with base = ... instead")
    sections = [s for s in SCHEMA if s]
    if head in SCHEMA[""]:
        if len(keys) > 1:
            raise SceneError(f"--set {shown(item)}: {head} is a top-level key, not a table")
        return
    if head not in SCHEMA:
        raise SceneError(f"--set {shown(item)}: unknown key {head!r}; allowed: "
                         f"{', '.join(k for k in SCHEMA[''] if k != 'base')}"
                         f" or <section>.<key> with a section of {', '.join(sections)}")
    if len(keys) == 1:
        raise SceneError(f"--set {shown(item)}: {head} is a section; expected {head}.<key>, one of "
                         f"{', '.join(SCHEMA[head])}")
    if keys[1] not in SCHEMA[head]:
        raise SceneError(f"--set {shown(item)}: {head}.{keys[1]}: unknown key; allowed in [{head}]: "
                         f"{', '.join(SCHEMA[head])}")
    if len(keys) > 2 and ((head, keys[1]) not in _OPEN_TABLES or len(keys) > 3):
        raise SceneError(f"--set {shown(item)}: {'.'.join(keys[:2])} has no key {'.'.join(keys[2:])!r}"
                         + ("" if (head, keys[1]) in _OPEN_TABLES else " (it is not a table)"))


def apply_overrides(raw: dict, items) -> dict:
    raw = copy.deepcopy(raw)
    for item in items or ():
        keys, value = parse_override(item)
        node = raw
        for k in keys[:-1]:
            node = node.setdefault(k, {})
            if not isinstance(node, dict):
                raise SceneError(f"--set {shown(item)}: {'.'.join(keys[:-1])} is not a table in the scene")
        node[keys[-1]] = value
    return raw
