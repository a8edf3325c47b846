"""Checking a scene: every value against the schema (:mod:`.schema`), then the
rules that tie keys together, before any heavy work — into a :class:`Scene`.

Every problem is one :class:`~.schema.SceneError` naming the key, the value
and what is allowed.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from typing import NamedTuple

from .. import friction
from ..keys import NUM, Key
from ..model import mesh as mesh_mod
from ..model.grid import estimate_quads
from ..model.loading import ImpactPulse
from ..model.material import Material
from .schema import SCHEMA, SceneError

#: Largest mesh accepted, in quadrilaterals.
MAX_QUADS = 5_000_000


class Scene(NamedTuple):
    """A validated scene (plain data; everything a run needs)."""

    name: str
    description: str
    mesh: mesh_mod.MeshSpec
    material: Material
    pulse: ImpactPulse
    sigma0: float
    symmetric: bool
    Cn: float
    Cs: float
    tau0: float
    tau0_patches: tuple
    law: str
    params: dict
    regions: tuple
    t_end: float
    dt_safety: float
    dt: float | None
    stop_at_tip: float
    allow_unstable_dt: bool
    skip_quiet: bool
    output: dict
    watchdog: dict
    raw: dict  # the merged TOML tables, for the record


def check_value(where: str, k: Key, v):
    """``v`` if it fits key ``k`` (type, finiteness, range, choices), else a SceneError."""
    if k.kind == NUM:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{where} = {v!r}: expected a number [{k.unit}] ({k.doc})")
        if not math.isfinite(v):
            raise SceneError(f"{where} = {v!r}: must be finite")
    elif k.kind is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{where} = {v!r}: expected a whole number [{k.unit}] ({k.doc})")
    elif not isinstance(v, k.kind):
        names = {str: "a string", bool: "true or false", list: "a list", dict: "a table"}
        raise SceneError(f"{where} = {v!r}: expected {names.get(k.kind, k.kind)} ({k.doc})")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        lo_bad = k.low is not None and (v <= k.low if k.open_low else v < k.low)
        hi_bad = k.high is not None and (v >= k.high if k.open_high else v > k.high)
        if lo_bad or hi_bad:
            raise SceneError(f"{where} = {v!r} {k.unit}: must lie in {k.range_text()} {k.unit} ({k.doc})"
                             .replace("  ", " "))
    if k.choices and v not in k.choices:
        sep = " or " if len(k.choices) == 2 else ", "
        raise SceneError(f"{where} = {v!r}: allowed {sep.join(map(repr, k.choices))}")
    return v


def _section(raw: dict, name: str) -> dict:
    """Checked values of one section, defaults filled in."""
    schema = SCHEMA[name]
    table = raw if name == "" else raw.get(name, {})
    if not isinstance(table, dict):
        raise SceneError(f"[{name}]: expected a table, got {table!r}")
    out = {}
    for key, value in table.items():
        if name == "" and key in SCHEMA:
            continue
        where = f"{name}.{key}" if name else key
        if key not in schema:
            raise SceneError(f"{where}: unknown key; allowed in [{name or 'top level'}]: "
                             f"{', '.join(k for k in schema)}" + (f", [{'], ['.join(s for s in SCHEMA if s)}]"
                                                                 if name == "" else ""))
        out[key] = check_value(where, schema[key], value)
    for key, k in schema.items():
        out.setdefault(key, copy.deepcopy(k.default))
    return out


def _x1_ranges(where: str, items, length: float, keys: tuple) -> tuple:
    out = []
    for i, item in enumerate(items):
        w = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise SceneError(f"{w} = {item!r}: expected a table with {', '.join(keys)}")
        for k in item:
            if k not in keys:
                raise SceneError(f"{w}.{k}: unknown key; allowed: {', '.join(keys)}")
        for k in ("x1_min", "x1_max"):
            if k not in item:
                raise SceneError(f"{w}.{k}: missing (m)")
            check_value(f"{w}.{k}", Key(NUM, 0.0, "m", 0.0, length, "position along the interface"), item[k])
        if not item["x1_min"] < item["x1_max"]:
            raise SceneError(f"{w}: x1_min = {item['x1_min']!r} m must be < x1_max = {item['x1_max']!r} m")
        out.append(dict(item))
    return tuple(out)


def mesh_spec(m: dict) -> mesh_mod.MeshSpec:
    """The MeshSpec of a checked ``[mesh]`` section: the preset, its fields
    overridden, and the rules between fields."""
    try:
        spec = mesh_mod.preset(m["preset"])
    except ValueError as err:
        raise SceneError(str(err)) from None
    spec = dataclasses.replace(spec, **{k: float(v) for k, v in m.items() if k != "preset" and v is not None})
    if not spec.fine_x0 < spec.fine_x1 <= spec.length:
        raise SceneError(f"mesh.fine_x0 = {spec.fine_x0!r} m, mesh.fine_x1 = {spec.fine_x1!r} m: the fine "
                         f"region must satisfy 0 <= fine_x0 < fine_x1 <= length = {spec.length!r} m")
    for name in ("fine_height", "impact_b"):
        if getattr(spec, name) > spec.height:
            raise SceneError(f"mesh.{name} = {getattr(spec, name)!r} m: must not exceed the plate height "
                             f"{spec.height!r} m")
    for name, h, span in (("dx", spec.dx, spec.fine_x1 - spec.fine_x0), ("dy", spec.dy, spec.fine_height)):
        if h > span:
            raise SceneError(f"mesh.{name} = {h!r} m: larger than the fine region it meshes ({span!r} m)")
    if spec.max_size < max(spec.dx, spec.dy):
        raise SceneError(f"mesh.max_size = {spec.max_size!r} m: must be >= dx and dy")
    quads = estimate_quads(spec)
    if quads > MAX_QUADS:
        raise SceneError(f"mesh: about {quads:.3g} quadrilaterals requested; at most {MAX_QUADS / 1e6:g}e6 are allowed")
    return spec


def _friction(fr: dict, length: float) -> tuple:
    """(law name, parameters, regions) of a checked ``[friction]`` section."""
    try:
        law = friction.get_law(fr["law"])
        params = friction.validate(law, fr["params"], where="friction.params")
    except ValueError as err:
        raise SceneError(str(err)) from None
    regions = _x1_ranges("friction.regions", fr["regions"], length, ("x1_min", "x1_max", "params"))
    for i, reg in enumerate(regions):
        try:
            friction.validate(law, {**params, **reg.get("params", {})}, where=f"friction.regions[{i}].params")
        except ValueError as err:
            raise SceneError(str(err)) from None
    return fr["law"], params, regions


def validate(raw: dict) -> Scene:
    """Check every key and value of the merged tables; return a :class:`Scene`."""
    for key in raw:
        if key not in SCHEMA[""] and key not in SCHEMA:
            raise SceneError(f"{key}: unknown key or section; allowed: {', '.join(SCHEMA[''])}, "
                             f"[{'], ['.join(s for s in SCHEMA if s)}]")
    top = _section(raw, "")
    sec = {name: _section(raw, name) for name in SCHEMA if name}
    spec = mesh_spec(sec["mesh"])
    mat = Material(**{k: (float(v) if k != "plane" else v) for k, v in sec["material"].items()})
    ld = sec["loading"]
    if not ld["t_hold_end"] >= ld["t_rise"]:
        raise SceneError(f"loading.t_hold_end = {ld['t_hold_end']!r} s: must be >= t_rise = {ld['t_rise']!r} s")
    pulse = ImpactPulse(float(ld["v_imp"]), float(ld["t_rise"]), float(ld["t_hold_end"]), float(ld["t_fall"]),
                        ld["direction"], ld["kind"], float(ld["impedance"]))
    law, params, regions = _friction(sec["friction"], spec.length)
    itf = sec["interface"]
    patches = _x1_ranges("interface.patches", itf["patches"], spec.length, ("x1_min", "x1_max", "tau0"))
    for i, p in enumerate(patches):
        check_value(f"interface.patches[{i}].tau0", SCHEMA["interface"]["tau0"], p.get("tau0", 0.0))
    tm = sec["time"]
    out = sec["output"]
    for i, t in enumerate(out["fields"]):
        check_value(f"output.fields[{i}]", Key(NUM, 0.0, "s", 0.0, tm["end"], "snapshot time"), t)
    for name, x in out["stations"].items():
        check_value(f"output.stations.{name}", Key(NUM, 0.0, "m", 0.0, spec.length,
                                                   "station position along the interface"), x)
    return Scene(
        name=top["name"], description=top["description"], mesh=spec, material=mat, pulse=pulse,
        sigma0=float(ld["sigma0"]), symmetric=ld["symmetric"], Cn=float(itf["Cn"]), Cs=float(itf["Cs"]),
        tau0=float(itf["tau0"]), tau0_patches=patches, law=law, params=params, regions=regions,
        t_end=float(tm["end"]), dt_safety=float(tm["dt_safety"]), dt=float(tm["dt"]) or None,
        stop_at_tip=float(tm["stop_at_tip"]), allow_unstable_dt=tm["allow_unstable_dt"],
        skip_quiet=tm["skip_quiet"], output=out, watchdog=sec["watchdog"], raw=raw,
    )
