"""Planning a mode map (:mod:`fricfem.sweep`): the axes (``--sigma0``, ``--v-imp``),
the map's title, the ``--set`` items the sweep allows, and every point's scene
loaded and validated (:func:`plan`) before anything runs."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import NamedTuple

from .. import batch
from .. import scene as scene_mod
from ..analysis.modemap import log_axis, tag
from ..scene import SceneError

#: The default grid (``--grid default``): the span of the paper's Fig. 19.
DEFAULT_SIGMA0_MPA = (0.9, 2.0, 4.0, 6.0, 10.0, 16.0, 24.0, 40.0)


DEFAULT_V_IMP = (1.0, 2.0, 4.0, 7.0, 10.0, 15.0, 20.0, 40.0)

#: ``--variants``: sub-map directory -> factor on C_n and C_s (the paper's "Mesh and
#: interface stiffness" paragraph: × 10 gives only crack-like sliding, ÷ 10 no trains).
VARIANTS = {"stiff_x10": 10.0, "stiff_div10": 0.1}

#: Keys the sweep sets itself (or, for field output, turns off); ``--set`` may not touch them.
SWEPT_KEYS = ("loading.sigma0", "loading.v_imp", "output.fields", "output.frames")


class Point(NamedTuple):
    """One grid point of one map: where it sits and its batch job."""

    map: str            # "" for the main map, else the variant's sub-directory
    sigma0_mpa: float   # Σ0 [MPa]
    v_imp: float        # V_imp [m/s]
    key: str            # s<Σ0>_v<V>
    overrides: tuple    # the --set items that turn the base scene into this point
    job: batch.Job
    ij: tuple = (0, 0)  # its indices on the grid (sigma0, v_imp)

    @property
    def dir(self) -> Path:
        return self.job.dir


#: Most values on one axis of a map.
MAX_AXIS = 100


def parse_axis(text: str, name: str, unit: str) -> tuple:
    """'0.9,2,4' -> (0.9, 2.0, 4.0), sorted; or 'LO:HI:N' -> N values from LO to HI
    evenly spaced in log (:func:`fricfem.analysis.modemap.log_axis`).  Every value
    finite and > 0, no duplicates, at most :data:`MAX_AXIS` of them."""
    if not text.strip():
        raise SceneError(f"{name} {text!r}: empty; expected a comma-separated list, e.g. {name} 2,10,40, "
                         f"or LO:HI:N")
    if ":" in text:
        return _log_range(text, name, unit)
    items = text.split(",")
    if len(items) > MAX_AXIS:
        raise SceneError(f"{name}: {len(items)} values; at most {MAX_AXIS} per axis")
    values = sorted(_positive(item.strip(), text, name, unit) for item in items)
    dup = sorted({tag(a) for a, b in zip(values, values[1:]) if tag(a) == tag(b)})
    if dup:
        raise SceneError(f"{name}: {', '.join(dup)} {unit} given twice")
    return tuple(values)


#: Longest ``--label`` (the map's title; the figure draws it in one or two lines).
MAX_LABEL = 200


def check_label(label: str) -> str:
    """``--label`` if the figures can draw it: at most :data:`MAX_LABEL` characters, no control
    characters but a line break, and any ``$...$`` valid mathtext — checked before any point runs."""
    if len(label) > MAX_LABEL:
        raise SceneError(f"--label: {len(label)} characters; at most {MAX_LABEL} (the map's title)")
    bad = sorted({f"U+{ord(c):04X}" for c in label if (ord(c) < 32 and c != "\n") or 0x7f <= ord(c) < 0xa0})
    if bad:
        raise SceneError(f"--label {label[:40]!r}: holds control characters ({', '.join(bad[:5])})")
    if label.replace("\\$", "").count("$") >= 2:  # matplotlib draws $...$ as mathematics
        from matplotlib.mathtext import MathTextParser  # here: matplotlib only for a label with $...$ (start-up)

        try:
            MathTextParser("path").parse(label)
        except ValueError as err:
            raise SceneError(f"--label {label!r}: its $...$ is not valid mathtext ({' '.join(str(err).split())}); "
                             f"write \\$ for a dollar sign") from None
    return label


def _positive(item: str, text: str, name: str, unit: str) -> float:
    try:
        v = float(item)
    except ValueError:
        raise SceneError(f"{name} {text!r}: {item!r} is not a number [{unit}]; "
                         f"expected a comma-separated list, e.g. {name} 2,10,40, or LO:HI:N") from None
    if not (math.isfinite(v) and v > 0):
        raise SceneError(f"{name}: {item} {unit} must be a positive number (the map's axes are logarithmic)")
    return v


def _log_range(text: str, name: str, unit: str) -> tuple:
    parts = text.split(":")
    if len(parts) != 3:
        raise SceneError(f"{name} {text!r}: expected LO:HI:N (N values from LO to HI {unit}, even in log), "
                         f"e.g. {name} 0.9:40:32")
    lo, hi = (_positive(p.strip(), text, name, unit) for p in parts[:2])
    try:
        n = int(parts[2])
    except ValueError:
        n = 0
    if not 2 <= n <= MAX_AXIS:
        raise SceneError(f"{name} {text!r}: N = {parts[2].strip()!r} must be a whole number in [2, {MAX_AXIS}]")
    if not lo < hi:
        raise SceneError(f"{name} {text!r}: LO = {lo:g} must be below HI = {hi:g} {unit}")
    values = log_axis(lo, hi, n)
    if len({tag(v) for v in values}) < n:
        raise SceneError(f"{name} {text!r}: {n} values between {lo:g} and {hi:g} {unit} are too close to "
                         f"tell apart; use fewer")
    return values


def _check_sets(sets, preset) -> list:
    """The --set items, checked: well formed, not a key the sweep sets, the preset given once."""
    sets = list(sets or ())
    for item in sets:
        keys, _ = scene_mod.parse_override(item)  # the item's form: section.key=value
        key = ".".join(keys)  # normalised: 'loading . sigma0' is loading.sigma0
        if key in SWEPT_KEYS:
            raise SceneError(f"--set {item!r}: {key} is set by the sweep itself (use --sigma0 / --v-imp; "
                             f"sweeps write no field snapshots nor isochromatic frames)")
        if key == "mesh.preset" and preset:
            raise SceneError(f"--set {item!r} and --preset {preset}: give the mesh preset once")
    return sets


def plan(base: str, sigma0_mpa, v_imp, sets=(), preset: str | None = None, variants: bool = False,
         out: Path = Path("."), select: dict | None = None) -> tuple:
    """The points of every map, validated: ``(maps, points)``.

    ``maps`` is {map name: {"dir", "overrides", "factor", "Cn", "Cs", "scene"}}
    ("" is the main map; factor scales C_n and C_s [Pa/m]; scene: the map's base
    scene, for its title).  ``select``: {map name: [(i, j), ...]} the grid
    indices to plan (default: every point).  Each point's scene is loaded once
    (TOML + validation, no mesh), so any bad input raises one
    :class:`SceneError` before anything runs.
    """
    common = _check_sets(sets, preset) + ([f"mesh.preset={json.dumps(preset)}"] if preset else []) \
        + ["output.fields=[]"]
    base_scene = scene_mod.load(base, common)
    if base_scene.output.frames:  # a base scene's camera frames are field snapshots too: none in a sweep
        common.append("output.frames=[]")
        base_scene = scene_mod.load(base, common)
    maps = {"": {"dir": out, "overrides": tuple(common), "factor": 1.0, "Cn": base_scene.Cn, "Cs": base_scene.Cs,
                 "scene": base_scene}}
    if variants:  # scale whatever C_n, C_s the base scene and --set give
        for name, f in VARIANTS.items():
            cn, cs = (float(f"{c * f:.12g}") for c in (base_scene.Cn, base_scene.Cs))
            maps[name] = {"dir": out / name, "factor": f, "Cn": cn, "Cs": cs,
                          "overrides": tuple(common) + (f"interface.Cn={cn!r}", f"interface.Cs={cs!r}"),
                          "scene": base_scene._replace(Cn=cn, Cs=cs)}
    points = []
    for name, mp in maps.items():
        pairs = [(i, j) for i in range(len(sigma0_mpa)) for j in range(len(v_imp))] if select is None \
            else sorted(select.get(name, ()))
        for i, j in pairs:
            points.append(_point(base, base_scene.name, name, mp, sigma0_mpa[i], v_imp[j], (i, j)))
    return maps, points


def _point(base, base_name, name, mp, s, v, ij) -> Point:
    key = f"s{tag(s)}_v{tag(v)}"
    label = f"{base_name}{'_' + name if name else ''}_{key}"
    over = mp["overrides"] + (f"loading.sigma0={round(s * 1e6, 3)!r}", f"loading.v_imp={float(v)!r}",
                              f"name={json.dumps(label)}")
    try:
        sc = scene_mod.load(base, over)
    except SceneError as err:
        raise SceneError(f"point Σ0 = {tag(s)} MPa, V_imp = {tag(v)} m/s"
                         f"{' (' + name + ')' if name else ''}: {err}") from None
    job = batch.Job(f"{name}/{key}" if name else key, mp["dir"] / "points" / key, sc, batch.expected_cost(sc))
    return Point(name, s, v, key, over, job, ij)


def physics_title(scene) -> str:
    """A map's title from what was computed: the friction law, the mesh (preset
    and its finest cells), the end time and the interface stiffnesses."""
    preset = str((scene.raw.get("mesh") or {}).get("preset", "reference"))
    if preset.endswith(".toml"):
        preset = Path(preset).stem
    m = scene.mesh
    return (f"{scene.law} law · {preset} mesh ({m.dx * 1e3:.3g} × {m.dy * 1e3:.3g} mm cells) · "
            f"to {scene.t_end * 1e6:.3g} µs\nC_n = {scene.Cn / 1e12:.3g}, C_s = {scene.Cs / 1e12:.3g} MPa/µm")
