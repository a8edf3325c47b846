"""Scenes: TOML files describing one run, with inheritance, overrides and validation.

A scene names a mesh (preset + overrides), the material, the loading, the
interface, the friction law (with parameters varying along x1 by regions), the
end time and the outputs.  All values are SI (Pa, m, s, m/s, Pa/m).  The
paper's scenes ship in ``fricfem/scenes/``; a scene file may start from one
(``base = "case1"``) and override keys, and ``--set section.key=value``
overrides from the command line.

Every problem is reported before any heavy work as one ``SceneError`` naming
the key, the value and what is allowed.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from pathlib import Path
from typing import Any, NamedTuple

from . import friction, mesh
from .loading import ImpactPulse
from .material import Material

SCENE_DIR = Path(__file__).parent / "scenes"


class SceneError(ValueError):
    """A scene is malformed; the message names the key, the value and what is allowed."""


class Field(NamedTuple):
    """One scene key: type, default, unit, allowed range (closed unless marked open), meaning."""

    kind: type | tuple
    default: Any
    unit: str = ""
    low: float | None = None
    high: float | None = None
    doc: str = ""
    open_low: bool = False
    open_high: bool = False


NUM = (int, float)

#: The schema: section -> key -> Field.  ``mesh`` keys also accept every MeshSpec field.
SCHEMA = {
    "": {
        "name": Field(str, "scene", doc="scene name"),
        "description": Field(str, "", doc="one line on what the scene shows"),
        "base": Field(str, "", doc="shipped scene or file this one starts from"),
    },
    "mesh": {
        "preset": Field(str, "reference", doc="coarse, reference, half or fine"),
        **{
            f.name: Field(NUM, None, "m" if f.name != "grading" else "", 0.0, None, f"mesh {f.name}",
                          open_low=f.name != "fine_x0")
            for f in dataclasses.fields(mesh.MeshSpec)
        },
    },
    "material": {
        "E": Field(NUM, 5.2e9, "Pa", 0.0, None, "Young's modulus", open_low=True),
        "nu": Field(NUM, 0.34, "", -1.0, 0.5, "Poisson's ratio", open_low=True, open_high=True),
        "rho": Field(NUM, 1230.0, "kg/m^3", 0.0, None, "density", open_low=True),
        "plane": Field(str, "stress", doc="'stress' or 'strain'"),
    },
    "loading": {
        "sigma0": Field(NUM, 6e6, "Pa", 0.0, 1e9, "initial compression Σ0"),
        "v_imp": Field(NUM, 2.0, "m/s", 0.0, 1e3, "impact velocity V_imp"),
        "t_rise": Field(NUM, 10e-6, "s", 0.0, 1.0, "rise time t_r", open_low=True),
        "t_hold_end": Field(NUM, 60e-6, "s", 0.0, 1.0, "end of the plateau t_p", open_low=True),
        "t_fall": Field(NUM, 10e-6, "s", 0.0, 1.0, "step-down time t_s", open_low=True),
        "symmetric": Field(bool, False, doc="strike both plates (|x2| <= b)"),
        "direction": Field(str, "push", doc="'push' (edge moves into the specimen) or 'pull'"),
        "kind": Field(str, "velocity", doc="how V(t) acts: 'velocity' (edge velocity, the paper), 'traction' "
                                           "(normal traction ρ c_l V) or 'projectile' (impedance Z, traction "
                                           "Z (V − v_edge))"),
        "impedance": Field(NUM, 4.6e7, "Pa·s/m", 0.0, None, "projectile impedance ρc (kind = 'projectile'; "
                                                           "steel ≈ 4.6e7)", open_low=True),
    },
    "interface": {
        "Cn": Field(NUM, 3e11, "Pa/m", 0.0, None, "normal stiffness C_n", open_low=True),
        "Cs": Field(NUM, 1e11, "Pa/m", 0.0, None, "shear stiffness C_s", open_low=True),
        "tau0": Field(NUM, 0.0, "Pa", None, None, "initial shear traction"),
        "patches": Field(list, [], doc="[{x1_min, x1_max, tau0}] initial shear traction patches"),
    },
    "friction": {
        "law": Field(str, "povirk_needleman", doc="friction law name"),
        "params": Field(dict, {}, doc="law parameters"),
        "regions": Field(list, [], doc="[{x1_min, x1_max, params}] piecewise-constant overrides"),
    },
    "time": {
        "end": Field(NUM, 40e-6, "s", 0.0, 1.0, "end time", open_low=True),
        "dt_safety": Field(NUM, 0.9, "", 0.0, 1.0, "fraction of the stable step", open_low=True,
                           open_high=True),
        "dt": Field(NUM, 0.0, "s", 0.0, 1e-3, "fixed step (0: from dt_safety)"),
        "allow_unstable_dt": Field(bool, False, doc="accept a time.dt above the stable step (stability "
                                                    "experiments; the watchdog guards the run)"),
        "stop_at_tip": Field(NUM, 0.0, "m", 0.0, None,
                             "end the run once the sliding tip passes this x1 (0: never), e.g. the fine region's end"),
        "skip_quiet": Field(bool, True, doc="skip the rows the motion has not reached yet (bit-identical "
                                            "to computing every row; false: compute every row)"),
    },
    "watchdog": {
        "enabled": Field(bool, True, doc="stop a diverging run with a message"),
        "max_slip_rate": Field(NUM, 0.0, "m/s", 0.0, None,
                               "slip rates beyond this are taken as divergence (0: the material's c_l)"),
        "energy_factor": Field(NUM, 1.5, "", 1.0, None, "stop when stored energy exceeds this × the input work",
                               open_low=True),
    },
    "output": {
        "fields": Field(list, [], "s", doc="times of field snapshots (displacement, velocity, σ1 − σ2)"),
        "interface_every": Field(NUM, 0.2e-6, "s", 0.0, 1.0, "cadence of interface snapshots",
                                 open_low=True),
        "stations": Field(dict, {"x16.1mm": 16.1e-3}, "m", doc="station name -> x1 (histories every step)"),
        "energy_every": Field(int, 50, "steps", 0, None, "energy evaluation cadence (0: never)"),
        "flush_every": Field(NUM, 2.0, "s", 0.0, None, "wall-clock seconds between flushes", open_low=True),
        "diagnostics": Field(bool, True, doc="tip, fronts and mode classification in summary.json"),
    },
}


def describe_keys() -> str:
    """Every scene key, one line each: ``section.key = default [unit] range: meaning``
    (friction parameters: see the law, e.g. docs/friction.md)."""
    lines = []
    for section, fields in SCHEMA.items():
        for key, f in fields.items():
            name = f"{section}.{key}" if section else key
            if f.low is None and f.high is None:
                rng = ""
            else:
                lo = "(" if f.open_low else "["
                hi = ")" if f.open_high else "]"
                rng = f" {lo}{'-inf' if f.low is None else f'{f.low:g}'}, {'inf' if f.high is None else f'{f.high:g}'}{hi}"
            unit = f" {f.unit}" if f.unit else ""
            lines.append(f"{name} = {f.default!r}{unit}{rng}: {f.doc}")
    lines.append("friction.params.<parameter>: the law's parameters, with units and ranges, in docs/friction.md")
    return "\n".join(lines)


class Scene(NamedTuple):
    """A validated scene (plain data; everything a run needs)."""

    name: str
    description: str
    mesh: mesh.MeshSpec
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


def _check_value(where: str, f: Field, v):
    if f.kind == NUM:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{where} = {v!r}: expected a number [{f.unit}] ({f.doc})")
        if not math.isfinite(v):
            raise SceneError(f"{where} = {v!r}: must be finite")
    elif f.kind is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{where} = {v!r}: expected a whole number [{f.unit}] ({f.doc})")
    elif not isinstance(v, f.kind):
        names = {str: "a string", bool: "true or false", list: "a list", dict: "a table"}
        raise SceneError(f"{where} = {v!r}: expected {names.get(f.kind, f.kind)} ({f.doc})")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        lo_bad = f.low is not None and (v <= f.low if f.open_low else v < f.low)
        hi_bad = f.high is not None and (v >= f.high if f.open_high else v > f.high)
        if lo_bad or hi_bad:
            lo = "-inf" if f.low is None else f"{f.low:g}"
            hi = "inf" if f.high is None else f"{f.high:g}"
            rng = f"{'(' if f.open_low or f.low is None else '['}{lo}, {hi}{')' if f.open_high or f.high is None else ']'}"
            raise SceneError(f"{where} = {v!r} {f.unit}: must lie in {rng} {f.unit} ({f.doc})".replace("  ", " "))
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
        out[key] = _check_value(where, schema[key], value)
    for key, f in schema.items():
        out.setdefault(key, copy.deepcopy(f.default))
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
            _check_value(f"{w}.{k}", Field(NUM, 0.0, "m", 0.0, length, "position along the interface"), item[k])
        if not item["x1_min"] < item["x1_max"]:
            raise SceneError(f"{w}: x1_min = {item['x1_min']!r} m must be < x1_max = {item['x1_max']!r} m")
        out.append(dict(item))
    return tuple(out)


def validate(raw: dict) -> Scene:
    """Check every key and value of the merged tables; return a :class:`Scene`."""
    for key in raw:
        if key not in SCHEMA[""] and key not in SCHEMA:
            raise SceneError(f"{key}: unknown key or section; allowed: {', '.join(SCHEMA[''])}, "
                             f"[{'], ['.join(s for s in SCHEMA if s)}]")
    top = _section(raw, "")
    sec = {name: _section(raw, name) for name in SCHEMA if name}

    m = sec["mesh"]
    spec = mesh.preset(m["preset"]) if m["preset"] in mesh.PRESETS else None
    if spec is None:
        raise SceneError(f"mesh.preset = {m['preset']!r}: unknown; allowed: {', '.join(mesh.PRESETS)}")
    spec = dataclasses.replace(spec, **{k: float(v) for k, v in m.items() if k != "preset" and v is not None})
    try:
        spec.check()
    except ValueError as err:
        raise SceneError(str(err)) from None

    mat = Material(**{k: (float(v) if k != "plane" else v) for k, v in sec["material"].items()})
    try:
        mat.check()
    except ValueError as err:
        raise SceneError(str(err)) from None

    ld = sec["loading"]
    pulse = ImpactPulse(float(ld["v_imp"]), float(ld["t_rise"]), float(ld["t_hold_end"]), float(ld["t_fall"]),
                        ld["direction"], ld["kind"], float(ld["impedance"]))
    try:
        pulse.check()
    except ValueError as err:
        raise SceneError(str(err)) from None

    fr = sec["friction"]
    try:
        law = friction.get_law(fr["law"])
        params = friction.validate(law, fr["params"], where="friction.params")
    except ValueError as err:
        raise SceneError(str(err)) from None
    regions = _x1_ranges("friction.regions", fr["regions"], spec.length, ("x1_min", "x1_max", "params"))
    for i, reg in enumerate(regions):
        try:
            friction.validate(law, {**params, **reg.get("params", {})}, where=f"friction.regions[{i}].params")
        except ValueError as err:
            raise SceneError(str(err)) from None

    itf = sec["interface"]
    patches = _x1_ranges("interface.patches", itf["patches"], spec.length, ("x1_min", "x1_max", "tau0"))
    for i, p in enumerate(patches):
        _check_value(f"interface.patches[{i}].tau0", SCHEMA["interface"]["tau0"], p.get("tau0", 0.0))

    tm = sec["time"]
    out = sec["output"]
    for i, t in enumerate(out["fields"]):
        _check_value(f"output.fields[{i}]", Field(NUM, 0.0, "s", 0.0, tm["end"], "snapshot time"), t)
    for name, x in out["stations"].items():
        _check_value(f"output.stations.{name}", Field(NUM, 0.0, "m", 0.0, spec.length,
                                                      "station position along the interface"), x)
    return Scene(
        name=top["name"], description=top["description"], mesh=spec, material=mat, pulse=pulse,
        sigma0=float(ld["sigma0"]), symmetric=ld["symmetric"], Cn=float(itf["Cn"]), Cs=float(itf["Cs"]),
        tau0=float(itf["tau0"]), tau0_patches=patches, law=fr["law"], params=params, regions=regions,
        t_end=float(tm["end"]), dt_safety=float(tm["dt_safety"]), dt=float(tm["dt"]) or None,
        stop_at_tip=float(tm["stop_at_tip"]), allow_unstable_dt=tm["allow_unstable_dt"],
        skip_quiet=tm["skip_quiet"],
        output=out, watchdog=sec["watchdog"], raw=raw,
    )


def load(ref: str | Path, overrides=()) -> Scene:
    """Resolve, override and validate a scene (shipped name or .toml path)."""
    return validate(apply_overrides(resolve(ref), overrides))


def point_params(scene: Scene, x1):
    """Packed friction parameters per interface point, float64[n, n_params], regions applied."""
    import numpy as np

    law = friction.get_law(scene.law)
    base = friction.pack(law, scene.params)
    out = np.tile(base, (len(x1), 1))
    for reg in scene.regions:
        sel = (x1 >= reg["x1_min"]) & (x1 <= reg["x1_max"])
        out[sel] = friction.pack(law, {**scene.params, **reg.get("params", {})})
    return out


def point_tau0(scene: Scene, x1):
    """Initial shear traction per interface point [Pa] (uniform + patches)."""
    import numpy as np

    out = np.full(len(x1), scene.tau0)
    for p in scene.tau0_patches:
        out[(x1 >= p["x1_min"]) & (x1 <= p["x1_max"])] = p.get("tau0", scene.tau0)
    return out
