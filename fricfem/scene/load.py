"""Scene files: shipped scenes, inheritance (``base``), merging, ``--set`` overrides.

A scene is a TOML file; the paper's ship in ``fricfem/scenes/``.  A file may
start from another (``base = "case1"`` or a path, relative to the file) and
override keys; ``--set section.key=value`` overrides from the command line.
Tables merge key by key, except ``output.stations``, which a scene replaces
whole; lists (``output.fields``, ``friction.regions``, ``interface.patches``)
are replaced whole too.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

from .schema import SceneError

SCENE_DIR = Path(__file__).resolve().parents[1] / "scenes"


def shipped() -> dict:
    """Shipped scene name -> path."""
    return {p.stem: p for p in sorted(SCENE_DIR.glob("*.toml"))}


def _load_toml(path: Path) -> dict:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r} not found; shipped scenes: {', '.join(shipped())}") from None
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"scene file {str(path)!r} is not valid TOML: {err}") from None


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k != "stations":
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def resolve(ref: str | Path, _seen=()) -> dict:
    """The raw merged tables of a scene given by shipped name or file path (``base`` chains followed)."""
    ref = str(ref)
    path = shipped().get(ref) if not ref.endswith(".toml") else Path(ref)
    if path is None:
        raise SceneError(f"scene {ref!r}: no such shipped scene or .toml file; shipped: {', '.join(shipped())}")
    key = str(Path(path).resolve())
    if key in _seen:
        raise SceneError(f"base: scene {ref!r} inherits from itself")
    raw = _load_toml(Path(path))
    _anchor(raw, Path(path).parent)
    base = raw.get("base", "")
    if base:
        if not isinstance(base, str):
            raise SceneError(f"base = {base!r}: expected the name of a shipped scene or a .toml path")
        if base in shipped():
            bpath = base
        elif base.endswith(".toml"):
            bpath = base if Path(base).is_absolute() else str(Path(path).parent / base)
        else:
            raise SceneError(f"base = {base!r}: no such shipped scene or .toml file; shipped: "
                             f"{', '.join(shipped())}")
        parent = resolve(bpath, _seen + (key,))
        raw = _merge(parent, {k: v for k, v in raw.items() if k != "base"})
        raw.pop("base", None)
    if "name" not in raw:
        raw["name"] = Path(path).stem
    return raw


def _anchor(raw: dict, folder: Path) -> None:
    """A mesh file named by a relative path is relative to the scene file naming it."""
    mesh = raw.get("mesh")
    preset = mesh.get("preset") if isinstance(mesh, dict) else None
    if isinstance(preset, str) and preset.endswith(".toml") and not Path(preset).is_absolute():
        mesh["preset"] = str(folder / preset)


def parse_override(item: str) -> tuple:
    """``section.key=value`` -> (["section", "key"], value); value parsed as TOML, else a string."""
    key, sep, text = item.partition("=")
    if not sep or not key.strip():
        raise SceneError(f"--set {item!r}: expected <section.key>=<value>, e.g. loading.v_imp=10")
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        value = text
    return key.strip().split("."), value


def apply_overrides(raw: dict, items) -> dict:
    raw = copy.deepcopy(raw)
    for item in items or ():
        keys, value = parse_override(item)
        node = raw
        for k in keys[:-1]:
            node = node.setdefault(k, {})
            if not isinstance(node, dict):
                raise SceneError(f"--set {item!r}: {'.'.join(keys[:-1])} is not a table")
        node[keys[-1]] = value
    return raw
