"""Checking a scene: every value against the schema (:mod:`.schema`), then the
rules that tie keys together, before any heavy work — into a :class:`Scene`.

Every problem is one :class:`~.schema.SceneError` naming the key, the value
and what is allowed.  The rules between keys (docs/scenes.md):

* names: ``name`` and station names are identifiers (:func:`check_identifier`),
  station names unique ignoring case;
* mesh: the fine region inside the plate, cells no larger than it, at most
  :data:`fricfem.scene.cost.HARD` quadrilaterals (the budget, lifted by
  ``--force``, is :func:`fricfem.scene.cost.check`'s);
* friction: μs > 0 and μs >= μd, C + D > 0 (laws with those parameters), every
  slip distance shorter than the plate; ``friction.regions`` and
  ``interface.patches`` do not overlap and each holds an interface Gauss point;
  ``friction.profiles``: knots sorted on the plate, values in range, the rules
  above at every knot, a profiled parameter not also in a region;
* time: at least one step before ``time.end``; a fixed ``time.dt`` not above
  the stable step unless ``time.allow_unstable_dt``; ``time.stop_at_tip`` on
  the plate;
* output: field times in (0, time.end], distinct, none less than half a step;
  stations on the interface.

Scale checks that do not make a scene meaningless give warnings instead
(:attr:`Scene.warnings`; the command prints them on stderr).
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from .. import friction
from ..keys import NUM, Key, keys_of
from ..model import bodies
from ..model import grid
from ..model import mesh as mesh_mod
from ..model.grid import OUTER
from ..model.loading import ImpactPulse
from ..model.material import Material
from . import cost, output_keys
from .load import read_toml
from .schema import SCHEMA, SceneError, shown
from .settings import OutputSettings, Scene, WatchdogSettings, settings
from .values import check_identifier, check_value

#: Largest mesh accepted by the scene's own (default) budget, in quadrilaterals (``--force`` lifts it
#: up to ``cost.HARD``).
MAX_QUADS = int(cost.BUDGET["quads"])

#: Friction parameters that are slip distances [m].
SLIP_DISTANCES = ("Dc", "L0", "L1", "L2", "L")
#: A slip distance above this fraction of the plate gets a warning (slips in a plate are far shorter).
SLIP_SCALE_WARN = 0.01
#: Loading keys of the edge pulse, which an [experiment] scene (its projectile loads the specimen) does not use.
EXPERIMENT_UNUSED = ("t_rise", "t_hold_end", "t_fall", "direction", "kind", "impedance")
#: A cohesive / process zone resolved by fewer cells than this gets a warning.
ZONE_CELLS = 3.0


def _section(raw: dict, name: str) -> dict:
    """Checked values of one section, defaults filled in."""
    schema = SCHEMA[name]
    table = raw if name == "" else raw.get(name, {})
    if not isinstance(table, dict):
        raise SceneError(f"[{name}]: expected a table, got {shown(table)}")
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


def _x1_ranges(where: str, items, length: float, keys: tuple, x1) -> tuple:
    """Checked ``[{x1_min, x1_max, ...}]`` entries: inside the plate, every key of
    ``keys`` present, no two overlapping, each holding an interface Gauss point
    (``x1``: their positions)."""
    out = []
    for i, item in enumerate(items):
        w = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise SceneError(f"{w} = {shown(item)}: expected a table with {', '.join(keys)}")
        for k in item:
            if k not in keys:
                raise SceneError(f"{w}.{k}: unknown key; allowed: {', '.join(keys)}")
        for k in ("x1_min", "x1_max"):
            if k not in item:
                raise SceneError(f"{w}.{k}: missing (m)")
            check_value(f"{w}.{k}", Key(NUM, 0.0, "m", 0.0, length, "position along the interface"), item[k])
        lo, hi = item["x1_min"], item["x1_max"]
        if not lo < hi:
            raise SceneError(f"{w}: x1_min = {lo!r} m must be < x1_max = {hi!r} m")
        for k in keys:
            if k not in item:
                raise SceneError(f"{w}.{k}: missing; an entry without {k} changes nothing")
        inside = (x1 >= lo) & (x1 <= hi)
        if not inside.any():
            near = x1[(x1 >= lo).argmax()] if (x1 >= lo).any() else x1[-1]
            raise SceneError(f"{w}: [{lo!r}, {hi!r}] m holds no interface point (the next one is at x1 = "
                             f"{near:.6g} m; there are 4 Gauss points in each of the {x1.size // 4} interface "
                             f"segments); widen it")
        for j, other in enumerate(out):
            shared = inside & (x1 >= other["x1_min"]) & (x1 <= other["x1_max"])
            if max(lo, other["x1_min"]) < min(hi, other["x1_max"]) or shared.any():
                raise SceneError(f"{w} = [{lo!r}, {hi!r}] m overlaps {where}[{j}] = [{other['x1_min']!r}, "
                                 f"{other['x1_max']!r}] m; entries may not overlap (they may touch)")
        out.append(dict(item))
    return tuple(out)


def _mesh_file(path: str) -> mesh_mod.MeshSpec:
    """A mesh definition file: every key a MeshSpec field, every value in its range."""
    table = read_toml(path, "mesh file")
    keys = keys_of(mesh_mod.MeshSpec)
    for k, v in table.items():
        if k not in keys:
            raise SceneError(f"mesh file {path!r}: unknown key {k!r}; allowed: {', '.join(keys)}")
        check_value(f"mesh.{k} (in {path!r})", keys[k], v)
    return mesh_mod.MeshSpec(**{k: float(v) for k, v in table.items()})


def mesh_spec(m: dict) -> mesh_mod.MeshSpec:
    """The MeshSpec of a checked ``[mesh]`` section: the preset, its fields
    overridden, and the rules between fields."""
    ref = m["preset"]
    if not ref.strip():
        raise SceneError(f"mesh.preset = {ref!r}: empty; allowed: {', '.join(mesh_mod.preset_names())} "
                         "or a path to a .toml mesh file")
    if ref.endswith(".toml"):
        spec = _mesh_file(ref)
    else:
        try:
            spec = mesh_mod.preset(ref)
        except ValueError as err:
            raise SceneError(str(err)) from None
    spec = dataclasses.replace(spec, **{k: int(v) if k == "degree" else float(v) for k, v in m.items()
                                        if k not in ("preset", "absorbing") and v is not None})
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
    quads = cost.size_bound(spec)  # closed form first: nothing allocated for an absurd cell size
    if quads > cost.HARD["quads"]:
        raise SceneError(f"mesh: about {quads:.3g} quadrilaterals requested (mesh.dx = {spec.dx:g} m, mesh.dy = "
                         f"{spec.dy:g} m); at most {MAX_QUADS / 1e6:g}e6 are allowed without --force and "
                         f"{cost.HARD['quads']:.0e} with it")
    return spec


def validate_mesh(table: dict) -> mesh_mod.MeshSpec:
    """The MeshSpec of a ``[mesh]`` table alone (``fricfem mesh`` without a scene), every key checked."""
    return mesh_spec(_section({"mesh": table}, "mesh"))


def _absorbing(edges: list) -> tuple:
    """The checked ``mesh.absorbing`` list: outer edge names, each once."""
    for i, e in enumerate(edges):
        if e not in OUTER:
            raise SceneError(f"mesh.absorbing[{i}] = {shown(e)}: allowed {', '.join(map(repr, OUTER))}")
        if e in edges[:i]:
            raise SceneError(f"mesh.absorbing[{i}] = {e!r}: given twice")
    return tuple(edges)


def _law_rules(where: str, p: dict, length: float) -> None:
    """Rules between a law's parameters (by their names, whichever law has them)."""
    if "mu_s" in p and "mu_d" in p:
        if not p["mu_s"] > 0:
            raise SceneError(f"{where}.mu_s = {p['mu_s']!r}: must be > 0 (a static friction coefficient of 0 "
                             f"leaves the interface without strength)")
        if p["mu_s"] < p["mu_d"]:
            raise SceneError(f"{where}.mu_s = {p['mu_s']!r} < {where}.mu_d = {p['mu_d']!r}: the static "
                             f"coefficient must be >= the dynamic one (equal: no weakening)")
    if "C" in p and "D" in p and not p["C"] + p["D"] > 0:
        raise SceneError(f"{where}.C = {p['C']!r}, {where}.D = {p['D']!r}: C + D must be > 0 (the strength "
                         f"g(θ0)(θ1 + θ2) with θ1 + θ2 -> (C + D) T_n would vanish and the slip rate divide by "
                         f"zero)")
    for name in SLIP_DISTANCES:
        if name in p and p[name] >= length:
            raise SceneError(f"{where}.{name} = {p[name]!r} m: not smaller than the plate (mesh.length = "
                             f"{length:g} m); slips in a plate are far shorter, so the law would never evolve — "
                             f"a field-scale value (the slip-weakening default Dc = 0.40 m is the SCEC "
                             f"benchmarks'); scale it to the specimen, e.g. 1e-6 to 1e-4 m")


#: what a parameter of one law is called in another (a slip distance; how the state starts)
_ALIASES = {"Dc": "the slip distance", "L": "the slip distance", "L0": "the slip distance",
            "V_ini": "the initial slip rate the state is set from"}


def _other_law_hint(fr: dict) -> str:
    """For a parameter the scene's law does not have but another law does: whose it
    is, and the scene's law's own name for the same thing, if it has one."""
    try:
        law = friction.get_law(fr["law"])
    except ValueError:
        return ""
    mine = set(friction.param_names(law))
    for key in fr.get("params", {}):
        if key in mine:
            continue
        owners = sorted(n for n, lw in friction.LAWS.items() if key in friction.param_names(lw))
        if not owners:
            return ""
        hint = f" ({key} is a parameter of {', '.join(owners)}"
        same = [k for k in mine if _ALIASES.get(k) and _ALIASES.get(k) == _ALIASES.get(key)]
        if same:
            hint += f"; {_ALIASES[key]} of {law.name} is {', '.join(sorted(same))}"
        if "V_ini" in mine:
            hint += (f"; the state of {law.name} starts at steady sliding at V_ini, under each point's own "
                     f"traction or the background's: friction.initial_state")
        return hint + ")"
    return ""


def _friction(fr: dict, length: float, x1) -> tuple:
    """(law name, parameters, regions) of a checked ``[friction]`` section."""
    try:
        law = friction.get_law(fr["law"])
        params = friction.validate(law, fr["params"], where="friction.params")
    except ValueError as err:
        raise SceneError(str(err) + _other_law_hint(fr)) from None
    _law_rules("friction.params", params, length)
    regions = _x1_ranges("friction.regions", fr["regions"], length, ("x1_min", "x1_max", "params"), x1)
    for i, reg in enumerate(regions):
        w = f"friction.regions[{i}].params"
        if not isinstance(reg["params"], dict) or not reg["params"]:
            raise SceneError(f"{w} = {shown(reg['params'])}: expected a table of at least one parameter of "
                             f"'{fr['law']}' ({', '.join(friction.param_names(law))})")
        try:
            merged = friction.validate(law, {**params, **reg["params"]}, where=w)
        except ValueError as err:
            raise SceneError(str(err)) from None
        _law_rules(w, merged, length)
    return fr["law"], params, regions


def _knots(where: str, knots, par, length: float) -> tuple:
    """One checked profile: at least two [x1, value] pairs, x1 strictly increasing on
    the plate, every value finite and in the parameter's range."""
    if not isinstance(knots, list) or len(knots) < 2:
        raise SceneError(f"{where} = {shown(knots)}: expected a list of at least 2 knots [x1, value] "
                         f"(x1 in m, the value in {par.unit or 'no unit'})")
    rng = Key(NUM, par.default, par.unit, par.low, par.high, par.doc)
    out = []
    for i, kn in enumerate(knots):
        if not isinstance(kn, list) or len(kn) != 2:
            raise SceneError(f"{where}[{i}] = {shown(kn)}: expected a knot [x1, value]")
        x = check_value(f"{where}[{i}][0]", Key(NUM, 0.0, "m", 0.0, length, "knot position along the interface"),
                        kn[0])
        v = check_value(f"{where}[{i}][1]", rng, kn[1])
        if out and not x > out[-1][0]:
            raise SceneError(f"{where}[{i}][0] = {x!r} m: knots must be sorted by x1, strictly increasing (the "
                             f"previous knot is at {out[-1][0]!r} m)")
        out.append((float(x), float(v)))
    return tuple(out)


def _profiles(fr: dict, params: dict, regions: tuple, length: float) -> tuple:
    """The checked ``friction.profiles``: ((name, knots), ...).  A profiled parameter
    is not set in a region; the rules between parameters hold at every knot (they are
    linear in each parameter, so they then hold between knots too), with the
    scene's parameters and with each region's."""
    law = friction.get_law(fr["law"])
    known = {p.name: p for p in law.params}
    table = fr["profiles"]
    out = []
    for name, knots in table.items():
        if name not in known:
            raise SceneError(f"friction.profiles.{name}: unknown parameter for friction law '{law.name}'; "
                             f"allowed: {', '.join(known)}")
        for i, reg in enumerate(regions):
            if name in reg["params"]:
                raise SceneError(f"friction.profiles.{name} and friction.regions[{i}].params.{name} both set "
                                 f"{name}; give it in one of them")
        out.append((name, _knots(f"friction.profiles.{name}", knots, known[name], length)))
    xs = sorted({x for _, kn in out for x, _ in kn})
    for x in xs:
        at = {name: float(np.interp(x, [k[0] for k in kn], [k[1] for k in kn])) for name, kn in out}
        for where, base in [("friction.params", params)] + [(f"friction.regions[{i}].params", {**params,
                                                                                             **reg["params"]})
                                                            for i, reg in enumerate(regions)]:
            _law_rules(f"friction.profiles at x1 = {x:g} m with {where}", {**base, **at}, length)
    return tuple(out)


def _scale_warnings(law: str, p: dict, spec, mat: Material, sigma0: float) -> list:
    """Warnings when a length of the law is out of scale with the plate or the cells (docs/scenes.md)."""
    out = []
    for name in SLIP_DISTANCES:
        if name in p and p[name] > SLIP_SCALE_WARN * spec.length:
            out.append(f"friction.params.{name} = {p[name]:g} m is {p[name] / spec.length:.0%} of the plate "
                       f"(mesh.length = {spec.length:g} m): the run's slips may never reach it (laboratory "
                       f"values are µm: the paper's L0 = 20e-6 m)")
    zone = None
    if "Dc" in p and p["mu_s"] > p["mu_d"]:  # slip weakening: the static cohesive zone (Day et al. 2005)
        zone = ("cohesive zone (9π/32) μ Dc/((μs − μd) Σ0)",
                9 * math.pi / 32 * mat.mu * p["Dc"] / ((p["mu_s"] - p["mu_d"]) * sigma0))
    elif "L" in p and "b" in p:  # rate and state: the process zone (Lapusta & Liu 2009)
        zone = ("process zone (9π/32) μ L/(b Σ0)", 9 * math.pi / 32 * mat.mu * p["L"] / (p["b"] * sigma0))
    if zone is not None:
        what, size = zone
        if size > spec.length:
            out.append(f"friction ({law}): the {what} = {size:.3g} m is longer than the plate "
                       f"({spec.length:g} m): the interface cannot weaken within it")
        elif size < ZONE_CELLS * spec.dx / spec.degree:
            # spectral elements: their nodes, mesh.dx / degree apart on average, resolve the zone
            cells = "cells of" if spec.degree == 1 else f"node spacings of mesh.dx / mesh.degree = {spec.degree}:"
            out.append(f"friction ({law}): the {what} = {size:.3g} m spans {size * spec.degree / spec.dx:.2g} "
                       f"{cells} mesh.dx = {spec.dx:g} m (fewer than {ZONE_CELLS:g}: unresolved)")
    return out


def _time_rules(sc: Scene) -> None:
    """At least one step; a fixed step not above the stable one (unless allowed); field times."""
    est = cost.estimate(sc)
    if sc.dt:
        if sc.t_end < sc.dt:
            raise SceneError(f"time.end = {sc.t_end!r} s is shorter than one step time.dt = {sc.dt!r} s: "
                             f"the run would take no step")
        crit = est.dt_crit[1]  # the stable step is at most this
        if sc.dt > crit and not sc.allow_unstable_dt:
            raise SceneError(f"time.dt = {sc.dt!r} s exceeds the stable step of this mesh and interface "
                             f"(at most {crit:.3g} s); use time.dt_safety in (0, 1) (or set "
                             f"time.allow_unstable_dt = true for a stability experiment)")
    elif sc.t_end < est.dt_high:
        raise SceneError(f"time.end = {sc.t_end!r} s is shorter than one step (up to {est.dt_high:.3g} s on this "
                         f"mesh with time.dt_safety = {sc.dt_safety:g}): the run would take no step")
    times = sc.output.fields
    for i, t in enumerate(times):
        if t < 0.5 * est.dt_high:
            raise SceneError(f"output.fields[{i}] = {t!r} s: less than half a step (the step is up to "
                             f"{est.dt_high:.3g} s): it would be the state at t = 0, which is not written")
        for j, u in enumerate(times[:i]):
            if abs(t - u) < est.dt_high:
                raise SceneError(f"output.fields[{i}] = {t!r} s: " + ("given twice" if t == u else
                                 f"within one step (up to {est.dt_high:.3g} s) of output.fields[{j}] = {u!r} s; "
                                 f"both would be the same snapshot"))
    if sc.dt:
        n_end = math.floor(sc.t_end / sc.dt + 1e-9)
        for i, t in enumerate(times):
            if not 1 <= round(t / sc.dt) <= n_end:
                raise SceneError(f"output.fields[{i}] = {t!r} s rounds to step {round(t / sc.dt)} of time.dt = "
                                 f"{sc.dt!r} s, outside the run's steps 1 … {n_end}")
    output_keys.check(sc, est.dt_high)  # output.gauges, output.frames


def validate(raw: dict) -> Scene:
    """Check every key and value of the merged tables; return a :class:`Scene`."""
    if not isinstance(raw, dict) or not raw:
        raise SceneError("scene: no keys")
    for key in raw:
        if key not in SCHEMA[""] and key not in SCHEMA or key == "":
            raise SceneError(f"{key or repr(key)}: unknown key or section; allowed: "
                             f"{', '.join(k for k in SCHEMA[''])}, "
                             f"[{'], ['.join(s for s in SCHEMA if s)}]")
    top = _section(raw, "")
    try:
        check_identifier("name", top["name"], 128)
    except SceneError as err:
        raise SceneError(f"{err} (a scene without name = ... takes its file's name)") from None
    if len(top["description"]) > 2000:
        raise SceneError(f"description: {len(top['description'])} characters; at most 2000")
    sec = {name: _section(raw, name) for name in SCHEMA if name}
    if sec["experiment"]["projectile_speed"] > 0:  # the grid line at the projectile's lower edge
        if sec["mesh"]["impact_b"] is not None:
            raise SceneError(f"mesh.impact_b = {sec['mesh']['impact_b']!r} m: with an [experiment] the grid line "
                             "at the projectile's lower edge comes from experiment.projectile_diameter; remove it")
        sec["mesh"]["impact_b"] = sec["experiment"]["projectile_diameter"]
    try:
        spec = mesh_spec(sec["mesh"])
    except SceneError as err:
        if sec["experiment"]["projectile_speed"] > 0 and str(err).startswith("mesh.impact_b"):
            raise SceneError(f"experiment.projectile_diameter = {sec['experiment']['projectile_diameter']!r} m: "
                             "must not exceed the plate height mesh.height (it strikes the buffer below the "
                             "interface)") from None
        raise
    grid_x1 = cost.axes(spec)[0]  # the interface points: node pairs (rigid) or 4 Gauss points a segment
    x1 = grid_x1 if sec["interface"]["kind"] == "rigid" else cost.gauss_x1(grid_x1)
    mat = Material(**{k: (float(v) if k != "plane" else v) for k, v in sec["material"].items()})
    ld = sec["loading"]
    if not ld["t_hold_end"] >= ld["t_rise"]:
        raise SceneError(f"loading.t_hold_end = {ld['t_hold_end']!r} s: must be >= t_rise = {ld['t_rise']!r} s")
    pulse = ImpactPulse(float(ld["v_imp"]), float(ld["t_rise"]), float(ld["t_hold_end"]), float(ld["t_fall"]),
                        ld["direction"], ld["kind"], float(ld["impedance"]))
    try:
        experiment, spec = bodies.from_section(sec["experiment"], raw.get("experiment", {}), spec,
                                               float(ld["v_imp"]), ld["symmetric"])
    except ValueError as err:
        raise SceneError(str(err)) from None
    if experiment is not None:
        unused = [k for k in EXPERIMENT_UNUSED if k in (raw.get("loading") or {})]
        if unused:
            raise SceneError(f"{', '.join('loading.' + k for k in unused)}: not used with an [experiment] "
                             f"(experiment.projectile_speed = {experiment.projectile_speed!r} m/s: the steel "
                             f"projectile loads the specimen, not the loading section's edge pulse); remove "
                             f"{'it' if len(unused) == 1 else 'them'}")
    law, params, regions = _friction(sec["friction"], spec.length, x1)
    profiles = _profiles(sec["friction"], params, regions, spec.length)
    itf = sec["interface"]
    patches = _x1_ranges("interface.patches", itf["patches"], spec.length, ("x1_min", "x1_max", "tau0"), x1)
    for i, p in enumerate(patches):
        check_value(f"interface.patches[{i}].tau0", SCHEMA["interface"]["tau0"], p["tau0"])
    tm = sec["time"]
    if tm["stop_at_tip"] > spec.length:
        raise SceneError(f"time.stop_at_tip = {tm['stop_at_tip']!r} m: beyond the plate (mesh.length = "
                         f"{spec.length:g} m); 0 never stops")
    out = sec["output"]
    seen = {}
    for name, x in out["stations"].items():
        check_identifier("output.stations: a station name", name, 64)
        if name.casefold() in seen:
            raise SceneError(f"output.stations.{name}: the same name as output.stations.{seen[name.casefold()]} "
                             f"(names must differ ignoring case)")
        seen[name.casefold()] = name
        check_value(f"output.stations.{name}", Key(NUM, 0.0, "m", 0.0, spec.length,
                                                   "station position along the interface"), x)
    for i, t in enumerate(out["fields"]):
        check_value(f"output.fields[{i}]", Key(NUM, 0.0, "s", 0.0, tm["end"], "snapshot time, within time.end; "
                                               "--set output.fields=[] writes none", open_low=True), t)
    absorbing = _absorbing(sec["mesh"]["absorbing"])
    if itf["kind"] == "rigid" and friction.get_law(law).rigid is None:
        rigid = sorted(n for n, lw in friction.LAWS.items() if lw.rigid is not None)
        raise SceneError(f"interface.kind = 'rigid': the law {law!r} has no rigid (split-node) form; "
                         f"allowed with it: {', '.join(rigid)}")
    scene = Scene(
        name=top["name"], description=top["description"], mesh=spec, material=mat, pulse=pulse,
        sigma0=float(ld["sigma0"]), symmetric=ld["symmetric"], Cn=float(itf["Cn"]), Cs=float(itf["Cs"]),
        tau0=float(itf["tau0"]), tau0_patches=patches, law=law, params=params, regions=regions,
        t_end=float(tm["end"]), dt_safety=float(tm["dt_safety"]), dt=float(tm["dt"]) or None,
        stop_at_tip=float(tm["stop_at_tip"]), allow_unstable_dt=tm["allow_unstable_dt"],
        skip_quiet=tm["skip_quiet"], output=settings(OutputSettings, out),
        watchdog=settings(WatchdogSettings, {**sec["watchdog"],  # the spike threshold's default: c_l
                                             "max_slip_rate": sec["watchdog"]["max_slip_rate"] or mat.c_l}),
        raw=raw,
        interface_kind=itf["kind"], absorbing=absorbing, profiles=profiles,
        initial_state=sec["friction"]["initial_state"], experiment=experiment,
        damping_eta=float(itf["damping_eta"]), damping_width=float(itf["damping_width"]),
    )
    _damping_rules(scene, spec)
    _degree_rules(scene, spec)
    _time_rules(scene)
    warnings = _band_warnings(sec) + _nucleation_warning(scene) + _scale_warnings(law, params, spec, mat, scene.sigma0) \
        + _element_edge_warnings(scene, spec)
    return scene._replace(warnings=tuple(warnings))


def _damping_rules(scene, spec) -> None:
    """A Kelvin–Voigt layer needs both its keys, at least one cell, and a bulk of one material."""
    eta, width = scene.damping_eta, scene.damping_width
    if (eta > 0) != (width > 0):
        given, missing = (("interface.damping_eta", "interface.damping_width") if eta > 0 else
                          ("interface.damping_width", "interface.damping_eta"))
        raise SceneError(f"{given} = {eta if eta > 0 else width!r} without {missing}: a Kelvin-Voigt layer needs "
                         f"both (damping_eta > 0, a fraction of dt; damping_width > 0 m), or neither")
    if eta > 0 and width < spec.dy:
        raise SceneError(f"interface.damping_width = {width!r} m: thinner than one row of cells at the interface "
                         f"(mesh.dy = {spec.dy!r} m); allowed: >= mesh.dy")
    if eta > 0 and scene.experiment is not None:
        raise SceneError("interface.damping_eta: a Kelvin-Voigt layer is not available with the experiment's "
                         "steel buffer and projectile (several materials); allowed: 0")


def _degree_rules(scene, spec) -> None:
    """Spectral elements (mesh.degree >= 2) carry the two plates only (either
    interface kind: its pairs or springs on the GLL nodes)."""
    p = int(spec.degree)
    if p != 1 and scene.experiment is not None:
        raise SceneError(f"mesh.degree = {p}: spectral elements are not available with the experiment's steel "
                         f"buffer and projectile; allowed: 1")


def _element_edge_warnings(scene, spec) -> list:
    """Spectral elements: a patch's or a friction region's end inside an element is
    spread over that element's GLL nodes (each pair takes its share's mean), so the
    step in traction or strength is smeared over up to a whole element, not a node
    spacing; one warning naming the ends and a cell size that would hold them."""
    if int(spec.degree) == 1:
        return []
    edges = grid.plate_axes(spec, True)[0]
    ends = sorted({float(e[k]) for e in (*scene.tau0_patches, *scene.regions) for k in ("x1_min", "x1_max")
                   if 0.0 < float(e[k]) < spec.length})
    tol = 1e-3 * spec.dx  # the scenes' 1 nm margins put an end just outside a node
    inside = [x for x in ends if np.abs(edges - x).min() > tol]
    if not inside:
        return []
    listed = ", ".join(f"{x * 1e3:g} mm" for x in inside[:6]) + (" ..." if len(inside) > 6 else "")
    return [f"mesh.degree = {int(spec.degree)}: interface.patches / friction.regions end inside a spectral element "
            f"at x1 = {listed} (element edges every mesh.dx = {spec.dx * 1e3:g} mm in the fine region): the step "
            f"there is spread over the element's nodes; a mesh.dx that divides those positions keeps it sharp"]


def _nucleation_warning(scene) -> list:
    """A patch of raised shear traction under a law whose state is set from the
    traction ('local', the default) starts in steady sliding at V_ini, like the
    rest of the fault: it is not overstressed and nothing nucleates there."""
    law = friction.get_law(scene.law)
    if (scene.initial_state != "local" or "V_ini" not in friction.param_names(law)
            or not any(p.get("tau0", scene.tau0) != scene.tau0 for p in scene.tau0_patches)):
        return []
    return [f"interface.patches set a shear traction other than interface.tau0 = {scene.tau0:g} Pa, but "
            f"friction.initial_state = 'local' sets each point's state from its own traction, so a patch starts "
            f"in steady sliding at V_ini like the rest of the fault and is not overstressed: nothing nucleates "
            f"there. For nucleation by overstress (SCEC TPV101-102, SEM2DPACK) set friction.initial_state = "
            f"'background'"]


def _band_warnings(sec: dict) -> list:
    """A warning per key whose value lies outside its plausible band (:attr:`fricfem.keys.Key.band`:
    a likely unit slip, e.g. loading.sigma0 = 10 meant in MPa), with the value it was likely meant to be."""
    out = []
    for name, keys in SCHEMA.items():
        for key, k in keys.items():
            if k.band and name in sec:
                w = k.implausible(f"{name}.{key}", sec[name].get(key))
                if w:
                    out.append(w)
    return out
