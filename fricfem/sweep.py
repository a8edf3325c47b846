"""``fricfem sweep``: the sliding-mode map over Σ0 × V_imp (the paper's Fig. 19).

Coker, Lykotrafitis, Needleman & Rosakis, "Dependence of the sliding mode on
the initial compressive stress and impact velocity": one calculation per
(Σ0, V_imp) on a grid, each classified as crack-like, pulse-like, a train of
pulses or mixed; a dashed line separates the crack-like from the pulse-like
region.  The paper also reports, without a map, that C_n, C_s × 10 gives only
crack-like sliding over the same range and ÷ 10 gives no trains; ``--variants``
computes those two maps too.

    fricfem sweep case1 --grid default --out runs/modemap
    mpirun -n 4 fricfem sweep case1 --sigma0 2,10,30 --v-imp 2,10,40 \\
        --preset coarse --set time.end=30e-6 --out runs/quick

Every grid point is one scene, BASE + ``--preset`` + ``--set`` + the point's
``loading.sigma0``, ``loading.v_imp`` and ``output.fields = []``, run into
``DIR/points/s<Σ0 MPa>_v<V m/s>/`` (a normal run directory) by the batch
runner (:mod:`fricfem.batch`): resumable, heaviest first, dealt to ranks (one
serial run per point: a sweep scales by points).  Then rank 0 writes

- ``DIR/modemap.json``: the grid, the label table, the crack/pulse boundary and
  per point the label, initiation, peak slip rate, median tip speed, wall time
  and the scene overrides;
- ``DIR/modemap.png`` (:mod:`fricfem.plot.modemap`);
- with ``--variants``: ``DIR/stiff_x10/`` and ``DIR/stiff_div10/`` (the same
  files) and ``DIR/modemap_variants.png`` with the three maps side by side.

Progress: rank 0 prints a line per point it finishes; every rank appends to
``DIR/sweep.log``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import NamedTuple

from mpi4py import MPI

from . import batch
from . import scene as scene_mod
from .analysis.modemap import boundary, label_table, table, tag
from .output.quantities import INTERFACE_FILE
from .output.rundir import open_interface, read_summary
from .scene import SceneError

#: The default grid (``--grid default``): the span of the paper's Fig. 19.
DEFAULT_SIGMA0_MPA = (0.9, 2.0, 4.0, 6.0, 10.0, 16.0, 24.0, 40.0)
DEFAULT_V_IMP = (1.0, 2.0, 4.0, 7.0, 10.0, 15.0, 20.0, 40.0)

#: ``--variants``: sub-map directory -> factor on C_n and C_s (the paper's "Mesh and
#: interface stiffness" paragraph: × 10 gives only crack-like sliding, ÷ 10 no trains).
VARIANTS = {"stiff_x10": 10.0, "stiff_div10": 0.1}

#: Keys the sweep sets itself; ``--set`` may not touch them.
SWEPT_KEYS = ("loading.sigma0", "loading.v_imp", "output.fields")


class Point(NamedTuple):
    """One grid point of one map: where it sits and its batch job."""

    map: str            # "" for the main map, else the variant's sub-directory
    sigma0_mpa: float   # Σ0 [MPa]
    v_imp: float        # V_imp [m/s]
    key: str            # s<Σ0>_v<V>
    overrides: tuple    # the --set items that turn the base scene into this point
    job: batch.Job

    @property
    def dir(self) -> Path:
        return self.job.dir


# --------------------------------------------------------------------------- grid and scenes


#: Most values on one axis of a map.
MAX_AXIS = 100


def parse_axis(text: str, name: str, unit: str) -> tuple:
    """'0.9,2,4' -> (0.9, 2.0, 4.0), sorted; every value finite and > 0, no duplicates,
    at most :data:`MAX_AXIS` of them."""
    if not text.strip():
        raise SceneError(f"{name} {text!r}: empty; expected a comma-separated list, e.g. {name} 2,10,40")
    items = text.split(",")
    if len(items) > MAX_AXIS:
        raise SceneError(f"{name}: {len(items)} values; at most {MAX_AXIS} per axis")
    values = []
    for item in items:
        item = item.strip()
        try:
            v = float(item)
        except ValueError:
            raise SceneError(f"{name} {text!r}: {item!r} is not a number [{unit}]; "
                             f"expected a comma-separated list, e.g. {name} 2,10,40") from None
        if not (math.isfinite(v) and v > 0):
            raise SceneError(f"{name}: {item} {unit} must be a positive number (the map's axes are logarithmic)")
        values.append(v)
    values = sorted(values)
    dup = sorted({tag(a) for a, b in zip(values, values[1:]) if tag(a) == tag(b)})
    if dup:
        raise SceneError(f"{name}: {', '.join(dup)} {unit} given twice")
    return tuple(values)


def _check_sets(sets, preset) -> list:
    """The --set items, checked: well formed, not a key the sweep sets, the preset given once."""
    sets = list(sets or ())
    for item in sets:
        scene_mod.parse_override(item)  # the item's form: section.key=value
        key = item.partition("=")[0].strip()
        if key in SWEPT_KEYS:
            raise SceneError(f"--set {item!r}: {key} is set by the sweep itself (use --sigma0 / --v-imp; "
                             f"sweeps write no field snapshots)")
        if key == "mesh.preset" and preset:
            raise SceneError(f"--set {item!r} and --preset {preset}: give the mesh preset once")
    return sets


def plan(base: str, sigma0_mpa, v_imp, sets=(), preset: str | None = None, variants: bool = False,
         out: Path = Path(".")) -> tuple:
    """Every point of every map, validated: ``(maps, points)``.

    ``maps`` is {map name: {"dir", "overrides", "factor", "Cn", "Cs"}} ("" is
    the main map; factor scales C_n and C_s [Pa/m]).  Each point's scene is
    loaded once (TOML + validation, no mesh), so any bad input raises one
    :class:`SceneError` before anything runs.
    """
    common = _check_sets(sets, preset) + ([f"mesh.preset={json.dumps(preset)}"] if preset else []) \
        + ["output.fields=[]"]
    base_scene = scene_mod.load(base, common)
    maps = {"": {"dir": out, "overrides": tuple(common), "factor": 1.0, "Cn": base_scene.Cn, "Cs": base_scene.Cs}}
    if variants:  # scale whatever C_n, C_s the base scene and --set give
        for name, f in VARIANTS.items():
            cn, cs = (float(f"{c * f:.12g}") for c in (base_scene.Cn, base_scene.Cs))
            maps[name] = {"dir": out / name, "factor": f, "Cn": cn, "Cs": cs,
                          "overrides": tuple(common) + (f"interface.Cn={cn!r}", f"interface.Cs={cs!r}")}
    points = []
    for name, mp in maps.items():
        for s in sigma0_mpa:
            for v in v_imp:
                key = f"s{tag(s)}_v{tag(v)}"
                label = f"{base_scene.name}{'_' + name if name else ''}_{key}"
                over = mp["overrides"] + (f"loading.sigma0={round(s * 1e6, 3)!r}", f"loading.v_imp={float(v)!r}",
                                          f"name={json.dumps(label)}")
                try:
                    sc = scene_mod.load(base, over)
                except SceneError as err:
                    raise SceneError(f"point Σ0 = {tag(s)} MPa, V_imp = {tag(v)} m/s"
                                     f"{' (' + name + ')' if name else ''}: {err}") from None
                job = batch.Job(f"{name}/{key}" if name else key, mp["dir"] / "points" / key, sc,
                                batch.expected_cost(sc))
                points.append(Point(name, s, v, key, over, job))
    return maps, points


# --------------------------------------------------------------------------- records


def peak_slip_rate(run_dir: Path) -> float | None:
    """max Δu̇_slip [m/s] over the recorded interface snapshots (None without a file)."""
    try:
        with open_interface(Path(run_dir) / INTERFACE_FILE) as itf:
            return float(itf.all("slip_rate").max()) if itf.n_time else 0.0
    except (OSError, KeyError):
        return None


def _finite_median(values) -> float | None:
    vals = sorted(v for v in values or () if v is not None and math.isfinite(v))
    if not vals:
        return None
    n = len(vals)
    return vals[n // 2] if n % 2 else 0.5 * (vals[n // 2 - 1] + vals[n // 2])


def record(point: Point) -> dict:
    """One point of ``modemap.json``, from its run directory."""
    s = read_summary(point.dir)
    mode = s.get("mode") or {}
    ev = mode.get("evidence") or {}
    tip = s.get("tip") or {}
    ini = s.get("initiation")
    return {
        "key": point.key,
        "sigma0_MPa": point.sigma0_mpa,
        "v_imp_m_s": point.v_imp,
        "dir": str(Path("points") / point.key),
        "complete": batch.status(point.job) == "done",
        "label": "diverged" if s.get("watchdog") else mode.get("label"),
        "reason": s.get("watchdog") or ev.get("reason") or s.get("diagnostics_error"),
        "initiation": ini,
        "peak_slip_rate_m_s": peak_slip_rate(point.dir) if s else None,
        "tip_speed_median_m_s": _finite_median(tip.get("v_tip_m_s")) if ini else None,
        "tip_extent_m": max(tip.get("x1_m") or [], default=None),
        "wall_s": (s.get("wall_s") or {}).get("total"),
        "steps": s.get("steps"),
        "dofs": s.get("dofs"),
        "overrides": [o for o in point.overrides if not o.startswith("name=")],
    }


def write_map(out: Path, meta: dict, sigma0, v_imp, records: list) -> dict:
    """``out/modemap.json`` and ``out/modemap.png``; returns the JSON document."""
    from .plot.modemap import figure

    by_key = {r["key"]: r for r in records}
    labels = label_table(sigma0, v_imp, by_key)
    doc = {
        **meta,
        "grid": {"sigma0_MPa": list(sigma0), "v_imp_m_s": list(v_imp)},
        "labels": {"layout": "labels[i][j] at sigma0_MPa[i], v_imp_m_s[j]", "values": labels},
        "boundary": {"method": "per Σ0 column, the first change between crack-like and pulse / pulse-train / "
                               "mixed walking up in V_imp (none set aside): at the mixed point, else at the "
                               "geometric mean of the two V_imp",
                     "points": [list(p) for p in boundary(sigma0, v_imp, labels)]},
        "points": records,
    }
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "modemap.json.tmp"
    tmp.write_text(json.dumps(doc, indent=2, allow_nan=False, default=str))
    tmp.replace(out / "modemap.json")
    figure({meta["title"]: (sigma0, v_imp, labels)}, out / "modemap.png")
    return doc


# --------------------------------------------------------------------------- running


class _Log:
    """Progress lines: every rank appends to ``sweep.log``; rank 0 also prints to stderr."""

    def __init__(self, path: Path, rank: int, quiet: bool):
        self.path, self.rank, self.quiet = path, rank, quiet

    def __call__(self, msg: str) -> None:
        line = f"{time.strftime('%H:%M:%S')} [rank {self.rank}] {msg}"
        with open(self.path, "a") as fh:
            fh.write(line + "\n")
        if self.rank == 0 and not self.quiet:
            print(line, file=sys.stderr, flush=True)


def _diff(a, b, prefix=""):
    """First differing key path between two nested dicts (for the stale-point message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                return _diff(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else k)
    return f"{prefix}: {a!r} (stored) vs {b!r} (now)"


def _todo(base, sigma0_mpa, v_imp, sets, preset, variants, out, overwrite) -> tuple:
    """Rank 0: (maps, points, points to run), or a SceneError (bad input, stale points)."""
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
    maps, points = plan(base, sigma0_mpa, v_imp, sets, preset, variants, out)
    todo, stale = [], []
    for p in points:
        st = batch.status(p.job)
        if st == "stale":
            stale.append((p, _diff(batch.stored(p.job)["identity"], p.job.ident())))
        if st == "todo" or (st == "stale" and overwrite):
            todo.append(p)
    if stale and not overwrite:
        p, why = stale[0]
        raise SceneError(f"{p.dir}: complete run with other inputs ({why}); {len(stale)} point(s) "
                         f"differ. Use another --out, or --overwrite to recompute them")
    for mp in maps.values():
        (mp["dir"] / "points").mkdir(parents=True, exist_ok=True)
    return maps, points, todo


def sweep(base: str, sigma0_mpa, v_imp, out, sets=(), preset=None, label=None, variants=False,
          overwrite=False, quiet=False, comm=MPI.COMM_WORLD, ranks_per_scene: int = 1) -> dict | None:
    """Run (or resume) the map(s) (collective on ``comm``).

    Returns ``{"maps": {map name: modemap.json document}, "wall_s"}`` on rank
    0, None elsewhere.  Raises :class:`SceneError` on every rank, before any
    run, when an input is bad or (without ``overwrite``) a complete point in
    ``out`` was computed with other inputs.
    """
    t0 = time.perf_counter()
    out = Path(out)
    problem = planned = None
    if comm.rank == 0:
        try:
            planned = _todo(base, sigma0_mpa, v_imp, sets, preset, variants, out, overwrite)
        except Exception as err:  # reported on every rank: no rank is left waiting
            problem = str(err) if isinstance(err, SceneError) else f"{type(err).__name__}: {err}"
    problem = comm.bcast(problem, root=0)
    if problem:
        raise SceneError(problem)
    maps, points, todo = comm.bcast(planned, root=0)
    log = _Log(out / "sweep.log", comm.rank, quiet)
    if comm.rank == 0:
        log(f"{len(points)} point(s) in {len(maps)} map(s): {len(points) - len(todo)} complete, "
            f"{len(todo)} to run on {comm.size} rank(s)")
    results = batch.run_jobs([p.job for p in todo], comm, ranks_per_job=ranks_per_scene, log=log)
    result = failure = None
    if comm.rank == 0:
        try:
            result = _collect(maps, points, results, base, sigma0_mpa, v_imp, sets, preset, label, out,
                              comm.size, t0)
        except Exception as err:  # say so on every rank rather than leave them waiting
            failure = f"writing the map failed: {type(err).__name__}: {err}"
    failure = comm.bcast(failure, root=0)
    if failure:
        raise RuntimeError(failure)
    return result


def _calls(path: Path, ranks: int, wall: float, recs: list) -> list:
    """The record of every call on this map (a resumed sweep's own wall time is small)."""
    try:
        calls = json.loads(path.read_text()).get("calls", [])
    except (FileNotFoundError, json.JSONDecodeError, AttributeError):
        calls = []
    now = [r for r in recs if r["computed_now"]]
    calls.append({"finished": time.strftime("%Y-%m-%dT%H:%M:%S"), "ranks": ranks, "wall_s": wall,
                  "computed": len(now), "point_wall_s": sum(r["wall_s"] or 0.0 for r in now)})
    return calls


def _collect(maps, points, results, base, sigma0_mpa, v_imp, sets, preset, label, out, ranks, t0) -> dict:
    """Rank 0: records of every point, ``modemap.json``/``.png`` per map, the combined figure."""
    title0 = label or scene_mod.resolve(base).get("name", str(base))
    computed = {r.key: r.error for r in results}
    wall = time.perf_counter() - t0
    docs = {}
    for name, mp in maps.items():
        recs = []
        for p in (p for p in points if p.map == name):
            r = record(p)
            r["computed_now"] = p.job.key in computed
            if computed.get(p.job.key):
                r["error"] = computed[p.job.key]
            recs.append(r)
        f = mp["factor"]
        meta = {
            "title": title0 if not name else f"{title0}: C_n, C_s {_factor(f)}",
            "base": str(base), "map": name or "main", "dir": str(mp["dir"]), "sets": list(sets or ()),
            "preset": preset, "interface_factor": f, "Cn_Pa_m": mp["Cn"], "Cs_Pa_m": mp["Cs"],
            "overrides": list(mp["overrides"]), "ranks": ranks, "sweep_wall_s": wall,
            "calls": _calls(mp["dir"] / "modemap.json", ranks, wall, recs),
            "computed": [r["key"] for r in recs if r["computed_now"]],
            "reused": [r["key"] for r in recs if not r["computed_now"] and r["complete"]],
            "incomplete": [r["key"] for r in recs if not r["complete"]],
        }
        docs[name] = write_map(mp["dir"], meta, sigma0_mpa, v_imp, recs)
    if len(maps) > 1:
        from .plot.modemap import figure

        panels = {}
        for name, doc in docs.items():
            t = "C_n, C_s of the scene" if not name else f"C_n, C_s {_factor(maps[name]['factor'])}"
            t += f"\n(C_n = {doc['Cn_Pa_m'] / 1e12:g}, C_s = {doc['Cs_Pa_m'] / 1e12:g} MPa/µm)"
            panels[t] = (sigma0_mpa, v_imp, doc["labels"]["values"])
        figure(panels, out / "modemap_variants.png")
    return {"maps": docs, "wall_s": wall}


def _factor(f: float) -> str:
    return f"× {tag(f)}" if f >= 1 else f"÷ {tag(1 / f)}"


# --------------------------------------------------------------------------- command line


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are printed by rank 0 of ``comm`` only."""

    comm = MPI.COMM_WORLD

    def error(self, message):
        if self.comm.rank == 0:
            self.print_usage(sys.stderr)
            print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def parser(comm=MPI.COMM_WORLD) -> argparse.ArgumentParser:
    from .model.mesh import preset_names

    p = _Parser(prog="fricfem sweep", description="the sliding-mode map over Σ0 × V_imp (paper's Fig. 19); "
                "resumable, parallel over points under mpirun")
    p.add_argument("scene", metavar="BASE_SCENE", help="shipped scene name or .toml file every point starts from")
    p.add_argument("--sigma0", metavar="LIST", help="Σ0 values in MPa, comma-separated, e.g. 0.9,2,4,6,10,16,24,40")
    p.add_argument("--v-imp", metavar="LIST", help="V_imp values in m/s, comma-separated, e.g. 1,2,4,7,10,15,20,40")
    p.add_argument("--grid", choices=["default"],
                   help="the default 8 × 8 grid (Σ0 0.9–40 MPa, V_imp 1–40 m/s) for any axis not given")
    p.add_argument("--set", action="extend", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a scene key for every point (repeatable; not loading.sigma0/v_imp)")
    p.add_argument("--preset", choices=list(preset_names()), help="mesh preset for every point")
    p.add_argument("--out", required=True, metavar="DIR", help="sweep directory (resumed if it holds points)")
    p.add_argument("--label", metavar="NAME", help="the map's title (default: the base scene's name)")
    p.add_argument("--variants", action="store_true",
                   help="also the maps with C_n, C_s × 10 (DIR/stiff_x10) and ÷ 10 (DIR/stiff_div10)")
    p.add_argument("--overwrite", action="store_true",
                   help="recompute complete points whose stored inputs differ from this sweep's")
    p.add_argument("--ranks-per-scene", type=int, default=1, metavar="K",
                   help="run each point on K ranks (K divides the number of ranks; default 1)")
    p.add_argument("--quiet", action="store_true", help="no per-point progress lines on stderr")
    p.add_argument("--force", action="store_true",
                   help="run points (or a map) whose estimated cost is above the budget (docs/scenes.md)")
    p.comm = comm
    return p


def _check_cost(args, s, v, comm) -> None:
    """Every point's scene within the budget (each point, and the map's total dof·steps),
    unless ``--force``; the points' scale warnings once, on rank 0.  Nothing is built."""
    from .scene import cost

    _, points = plan(args.scene, s, v, args.set, args.preset, args.variants, Path(args.out))
    total = 0.0
    warned = []
    for p in points:
        try:
            est = cost.check(p.job.scene, force=args.force)
        except SceneError as err:
            raise SceneError(f"point Σ0 = {tag(p.sigma0_mpa)} MPa, V_imp = {tag(p.v_imp)} m/s: {err}") from None
        total += est.dof_steps
        warned += [w for w in p.job.scene.warnings if w not in warned]
    if total > cost.BUDGET["dof_steps"] and not args.force:
        raise SceneError(f"{len(points)} points: about {total:.3g} dof·steps in all, above the budget of "
                         f"{cost.BUDGET['dof_steps']:.3g}; pass --force to run them anyway")
    if comm.rank == 0:
        for w in warned[:3]:
            print(f"fricfem sweep: warning: {w}", file=sys.stderr)
        if len(warned) > 3:
            print(f"fricfem sweep: warning: ... and {len(warned) - 3} more", file=sys.stderr)


def main(argv=None, comm=MPI.COMM_WORLD) -> int:
    """``fricfem sweep ...`` (collective): 0 when every point is complete, 1 if some are not
    (failed or interrupted: rerun to resume), 2 on bad input (nothing run)."""
    try:
        args = parser(comm).parse_args(argv)
    except SystemExit as stop:
        return 2 if stop.code else 0
    try:
        if args.sigma0 is None and args.grid is None:
            raise SceneError("--sigma0: give the Σ0 values (MPa), or --grid default")
        if args.v_imp is None and args.grid is None:
            raise SceneError("--v-imp: give the V_imp values (m/s), or --grid default")
        if args.grid and args.sigma0 is not None and args.v_imp is not None:
            raise SceneError("--grid default: not used when --sigma0 and --v-imp are both given")
        for opt in ("out", "label", "scene"):
            value = getattr(args, opt)
            if value is not None and not value.strip():
                raise SceneError(f"{'--' + opt if opt != 'scene' else 'BASE_SCENE'} {value!r}: empty")
        s = parse_axis(args.sigma0, "--sigma0", "MPa") if args.sigma0 is not None else DEFAULT_SIGMA0_MPA
        v = parse_axis(args.v_imp, "--v-imp", "m/s") if args.v_imp is not None else DEFAULT_V_IMP
        if args.ranks_per_scene < 1 or comm.size % args.ranks_per_scene:
            raise SceneError(f"--ranks-per-scene {args.ranks_per_scene}: must divide the number of ranks "
                             f"({comm.size})")
        _check_cost(args, s, v, comm)
        res = sweep(args.scene, s, v, args.out, args.set, args.preset, args.label, args.variants,
                    args.overwrite, args.quiet, comm, args.ranks_per_scene)
    except SceneError as err:
        if comm.rank == 0:
            print(f"fricfem sweep: error: {err}", file=sys.stderr)
        return 2
    status_code = 0
    if comm.rank == 0:
        for name, doc in res["maps"].items():
            print(f"{doc['title']}  ({doc['dir']}/modemap.json, .png)")
            print(table(s, v, doc["labels"]["values"]))
            bad = doc["incomplete"]
            print(f"  computed {len(doc['computed'])}, reused {len(doc['reused'])}, incomplete {len(bad)}"
                  + (f": {', '.join(bad)} (see {doc['dir']}/sweep.log; rerun to resume)" if bad else ""))
            print()
            if bad:
                status_code = 1
        if len(res["maps"]) > 1:
            print(f"combined figure: {Path(args.out) / 'modemap_variants.png'}")
        print(f"total wall time {res['wall_s']:.1f} s on {comm.size} rank(s)")
    return comm.bcast(status_code, root=0)


if __name__ == "__main__":
    sys.exit(main())
