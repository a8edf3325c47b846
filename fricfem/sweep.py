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
    mpirun -n 2 fricfem sweep case1 --sigma0 0.9:40:32 --v-imp 1:40:32 --adaptive --out runs/adaptive

Every grid point is one scene, BASE + ``--preset`` + ``--set`` + the point's
``loading.sigma0``, ``loading.v_imp`` and ``output.fields = []``, run into
``DIR/points/s<Σ0 MPa>_v<V m/s>/`` (a normal run directory) by the batch
runner (:mod:`fricfem.batch`): resumable, heaviest first, taken by groups of
``--ranks-per-scene`` ranks as they free up, each group reusing one model for the scenes that
share a mesh and interface (:mod:`fricfem.model.reuse`).  ``--adaptive``
computes a coarse grid first and refines only where labels differ
(:mod:`fricfem.adaptive`).  Then rank 0 writes

- ``DIR/modemap.json``: the grid, the label table, the crack/pulse boundary and
  per point the label and its confidence, initiation, peak slip rate, median
  tip speed, wall time and the scene overrides;
- ``DIR/modemap.png`` (:mod:`fricfem.plot.modemap`);
- with ``--variants``: ``DIR/stiff_x10/`` and ``DIR/stiff_div10/`` (the same
  files) and ``DIR/modemap_variants.png`` with the three maps side by side.

Progress: rank 0 prints a line per point it finishes; every rank appends to
``DIR/sweep.log``.  The command line: :mod:`fricfem.sweep_cli`.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path
from typing import NamedTuple

from mpi4py import MPI

from . import batch
from . import scene as scene_mod
from .analysis.modemap import boundary, confidence, label_table, log_axis, tag
from .output.quantities import INTERFACE_FILE
from .output.rundir import open_interface, read_summary
from .scene import SceneError

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


# --------------------------------------------------------------------------- grid and scenes


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
        from matplotlib.mathtext import MathTextParser

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
    if base_scene.output["frames"]:  # a base scene's camera frames are field snapshots too: none in a sweep
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


def point_label(point: Point) -> str | None:
    """The point's label from its run directory (None unless complete): the mode, or
    ``diverged`` when the watchdog stopped it."""
    if batch.status(point.job) != "done":
        return None
    s = read_summary(point.dir)
    return "diverged" if s.get("watchdog") else (s.get("mode") or {}).get("label")


def record(point: Point) -> dict:
    """One point of ``modemap.json``, from its run directory."""
    s = read_summary(point.dir)
    mode = s.get("mode") or {}
    ev = mode.get("evidence") or {}
    tip = s.get("tip") or {}
    ini = s.get("initiation")
    label = "diverged" if s.get("watchdog") else mode.get("label")
    return {
        "key": point.key,
        "sigma0_MPa": point.sigma0_mpa,
        "v_imp_m_s": point.v_imp,
        "dir": str(Path("points") / point.key),
        "complete": batch.status(point.job) == "done",
        "label": label,
        "confidence": confidence(label, ev),
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


BOUNDARY_METHOD = ("cell edges between a crack-like point and a neighbour with pulse, pulse-train or mixed "
                   "sliding (each point's cell reaches half-way, in log, to its neighbours); polylines "
                   "[[Σ0 MPa, V_imp m/s], ...]")
CONFIDENCE_MEANING = ("share of the late-window slip-rate profiles (last 20 % of the sliding duration) whose "
                      "type decided the label; for 'none', 1 - (samples with slipping regions) / min_phase")


def write_map(out: Path, meta: dict, sigma0, v_imp, records: list, adaptive: dict | None = None) -> dict:
    """``out/modemap.json`` and ``out/modemap.png``; returns the JSON document.

    ``adaptive``: {"labels", "computed", ...} of an adaptive map (labels of the
    points not computed inferred from their cell); else the records' labels."""
    from .plot.modemap import figure

    by_key = {r["key"]: r for r in records}
    labels = adaptive["labels"] if adaptive else label_table(sigma0, v_imp, by_key)
    conf = [[(by_key.get(f"s{tag(s)}_v{tag(v)}") or {}).get("confidence") for v in v_imp] for s in sigma0]
    doc = {
        **meta,
        "grid": {"sigma0_MPa": list(sigma0), "v_imp_m_s": list(v_imp)},
        "labels": {"layout": "labels[i][j] at sigma0_MPa[i], v_imp_m_s[j]", "values": labels},
        "confidence": {"meaning": CONFIDENCE_MEANING, "values": conf},
        "boundary": {"method": BOUNDARY_METHOD, "lines": [[list(p) for p in line]
                                                          for line in boundary(sigma0, v_imp, labels)]},
        **({"adaptive": {k: v for k, v in adaptive.items() if k != "labels"}} if adaptive else {}),
        "points": records,
    }
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "modemap.json.tmp"
    tmp.write_text(json.dumps(doc, indent=2, allow_nan=False, default=str))
    tmp.replace(out / "modemap.json")
    figure({meta["title"]: (sigma0, v_imp, labels, conf, adaptive and adaptive["computed"])},
           out / "modemap.png", note=meta.get("note"))
    return doc


# --------------------------------------------------------------------------- running


class _Log:
    """Progress lines: every rank appends to ``sweep.log``; rank 0 also prints to stderr."""

    def __init__(self, path: Path, rank: int, quiet: bool):
        self.path, self.rank, self.quiet = path, rank, quiet

    def __call__(self, msg: str) -> None:
        line = f"{time.strftime('%H:%M:%S')} [rank {self.rank}] {msg}"
        try:
            with open(self.path, "a") as fh:
                fh.write(line + "\n")
        except OSError as err:  # the log is a record, not a collective: a failure never stops one rank alone
            if not getattr(self, "failed", False):
                self.failed = True
                print(f"fricfem sweep: warning: {self.path}: cannot append: {err.strerror or err}; progress "
                      f"continues without the log", file=sys.stderr, flush=True)
        if self.rank == 0 and not self.quiet:
            print(line, file=sys.stderr, flush=True)


def _diff(a, b, prefix=""):
    """First differing key path between two nested dicts (for the stale-point message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                return _diff(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else k)
    return f"{prefix}: {a!r} (stored) vs {b!r} (now)"


def _todo(spec: dict, select=None) -> tuple:
    """Rank 0: (maps, points, points to run), or a SceneError (bad input, stale points).
    ``spec["planned"]``: (maps, every point) planned already (the cost check), else planned here."""
    out = spec["out"]
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
    if spec.get("planned"):
        maps, points = spec["planned"]
        if select is not None:
            chosen = {m: set(ij) for m, ij in select.items()}
            points = [p for p in points if p.ij in chosen.get(p.map, ())]
    else:
        maps, points = plan(spec["base"], spec["sigma0"], spec["v_imp"], spec["sets"], spec["preset"],
                            spec["variants"], out, select)
    todo, stale = [], []
    for p in points:
        st = batch.status(p.job)
        if st == "stale":
            stale.append((p, _diff(batch.stored(p.job)["identity"], p.job.ident())))
        if st == "todo" or (st == "stale" and spec["overwrite"]) or \
                (st == "done" and spec.get("rerun_stopped") and read_summary(p.dir).get("watchdog")):
            todo.append(p)
    if stale and not spec["overwrite"]:
        p, why = stale[0]
        raise SceneError(f"{p.dir}: complete run with other inputs ({why}); {len(stale)} point(s) "
                         f"differ. Use another --out, or --overwrite to recompute them")
    for mp in maps.values():
        (mp["dir"] / "points").mkdir(parents=True, exist_ok=True)
    return maps, points, todo


def _on_root(comm, fn, what: str):
    """``fn()`` on rank 0, its value on every rank; an error there raised on every rank
    (a SceneError as such, anything else as RuntimeError ``what: ...``)."""
    value = problem = None
    if comm.rank == 0:
        try:
            value = fn()
        except SceneError as err:
            problem = ("scene", str(err))
        except Exception as err:  # reported on every rank: no rank is left waiting
            problem = ("other", f"{what}: {type(err).__name__}: {err}")
    problem = comm.bcast(problem, root=0)
    if problem:
        raise (SceneError if problem[0] == "scene" else RuntimeError)(problem[1])
    return comm.bcast(value, root=0)


#: The files rank 0 writes at the top of a map's directory (checked before any point runs).
MAP_FILES = ("modemap.json", "modemap.json.tmp", "modemap.png")
LOG_FILE = "sweep.log"


def _reason(err: OSError) -> str:
    return err.strerror or str(err)


def _writable_file(path: Path) -> None:
    """A file the sweep will write: not a directory or other non-regular file, and its
    folder writable (tried, not guessed: a read-only mount, a full quota)."""
    if path.is_symlink() or (path.exists() and not path.is_file()):
        what = "a directory" if path.is_dir() and not path.is_symlink() else \
            "a symbolic link" if path.is_symlink() else "not a regular file"
        raise SceneError(f"{str(path)!r}: is {what}, where the sweep writes its file {path.name}; remove it or "
                         f"choose another --out")


def _preflight(out: Path, variants: bool):
    """Rank 0, before any point runs: the sweep directory made, locked (as a run
    directory is: :class:`fricfem.output.directory.Lock`, so a second sweep into it
    stops at once), and every path the sweep writes usable — ``sweep.log``
    appendable, ``modemap.json``/``.png`` of every map and ``modemap_variants.png``
    not in the way.  Returns the lock; a :class:`SceneError` naming the path."""
    from .output.directory import LOCK_FILE, Lock

    if out.is_symlink() and not out.exists():
        raise SceneError(f"--out {str(out)!r}: a dangling symbolic link (to {os.readlink(out)!r})")
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise SceneError(f"--out {str(out)!r}: cannot make the directory: {_reason(err)}") from None
    lock = Lock(out / LOCK_FILE)
    lock.acquire(out)  # a RunDirError (a SceneError) names the sweep that holds it
    try:
        dirs = [out] + ([out / name for name in VARIANTS] if variants else [])
        for d in dirs:
            if d.exists() and not d.is_dir():
                raise SceneError(f"{str(d)!r}: is not a directory, where the sweep writes a map")
            for name in MAP_FILES:
                _writable_file(d / name)
            if (d / "points").exists() and not (d / "points").is_dir():
                raise SceneError(f"{str(d / 'points')!r}: is not a directory, where the sweep runs its points")
        if variants:
            _writable_file(out / "modemap_variants.png")
        log = out / LOG_FILE
        _writable_file(log)
        for d in dirs:
            try:
                d.mkdir(parents=True, exist_ok=True)
                probe = d / f".modemap.json.{os.getpid()}.probe"
                probe.write_text("")
                probe.unlink()
                with open(log, "a"):
                    pass
            except OSError as err:
                raise SceneError(f"--out {str(out)!r}: cannot write there: {_reason(err)} "
                                 f"({err.filename or d})") from None
    except BaseException:
        lock.release()
        raise
    return lock


def run_round(pool, spec: dict, log, select=None, note: str = "") -> tuple:
    """Plan (rank 0), then run the points not yet complete on the pool (collective):
    ``(maps, points, todo, results)``; results on rank 0 only."""
    maps, points, todo = _on_root(pool.comm, lambda: _todo(spec, select), "planning the map failed")
    if pool.comm.rank == 0:
        log(f"{note}{len(points)} point(s) in {len(maps)} map(s): {len(points) - len(todo)} complete, "
            f"{len(todo)} to run on {pool.comm.size} rank(s) ({pool.groups} group(s) of {pool.k})")
    results = pool.run([p.job for p in todo], log=log)
    return maps, points, todo, results


def sweep(base: str, sigma0_mpa, v_imp, out, sets=(), preset=None, label=None, variants=False,
          overwrite=False, quiet=False, comm=MPI.COMM_WORLD, ranks_per_scene: int = 1,
          adaptive: tuple | None = None, reuse: bool = True, planned=None,
          rerun_stopped: bool = False) -> dict | None:
    """Run (or resume) the map(s) (collective on ``comm``).

    ``adaptive``: (coarse Σ0 values, coarse V_imp values) to start an adaptive
    map from (:mod:`fricfem.adaptive`); None: every point of the grid.  ``reuse``:
    the points of a group share one model per mesh and interface
    (:mod:`fricfem.model.reuse`; False builds each afresh, for comparison).
    ``planned``: ``plan(...)`` of every point with these arguments, if done
    already (rank 0 uses it instead of loading every scene again).
    ``rerun_stopped``: also recompute the complete points the watchdog stopped
    (their inputs are the same, but the code that judged them may not be).
    Returns ``{"maps": {map name: modemap.json document}, "wall_s"}`` on every
    rank.  Raises :class:`SceneError` on every rank, before any
    run, when an input is bad or (without ``overwrite``) a complete point in
    ``out`` was computed with other inputs.
    """
    t0 = time.perf_counter()
    spec = {"base": base, "sigma0": tuple(sigma0_mpa), "v_imp": tuple(v_imp), "out": Path(out),
            "sets": list(sets or ()), "preset": preset, "variants": variants, "overwrite": overwrite,
            "rerun_stopped": rerun_stopped,
            "planned": planned if comm.rank == 0 else None}
    log = _Log(spec["out"] / LOG_FILE, comm.rank, quiet)
    held = []  # rank 0: the sweep directory's lock
    if label is not None:
        check_label(label)  # the same on every rank: the figures can draw it, before any point runs
    _on_root(comm, lambda: held.append(_preflight(spec["out"], variants)), "preparing --out failed")
    try:
        with batch.Pool(comm, ranks_per_scene, reuse=reuse) as pool:
            if adaptive is None:
                maps, points, _, results = run_round(pool, spec, log)
                refined = None
            else:
                from .adaptive import run_adaptive

                maps, points, results, refined = run_adaptive(pool, spec, log, adaptive)
        return _on_root(comm, lambda: _collect(maps, points, results, spec, label, comm.size, t0, refined),
                        "writing the map failed")
    finally:
        for lock in held:
            lock.release()


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


def _collect(maps, points, results, spec, label, ranks, t0, refined=None) -> dict:
    """Rank 0: records of every point, ``modemap.json``/``.png`` per map, the combined figure.
    ``refined``: {map name: adaptive dict} of an adaptive map."""
    computed = {r.key: r.error for r in results}
    wall = time.perf_counter() - t0
    s, v = spec["sigma0"], spec["v_imp"]
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
            "title": label if label and not name else f"{label}: C_n, C_s {_factor(f)}" if label
            else physics_title(mp["scene"]),
            "note": f"base scene {mp['scene'].name};\n{len(recs)} scenes"
                    + (f" of {len(s) * len(v)} points\n(adaptive)" if refined else ""),
            "base": str(spec["base"]), "map": name or "main", "dir": str(mp["dir"]), "sets": spec["sets"],
            "preset": spec["preset"], "interface_factor": f, "Cn_Pa_m": mp["Cn"], "Cs_Pa_m": mp["Cs"],
            "t_end_s": mp["scene"].t_end, "law": mp["scene"].law,
            "overrides": list(mp["overrides"]), "ranks": ranks, "sweep_wall_s": wall,
            "calls": _calls(mp["dir"] / "modemap.json", ranks, wall, recs),
            "computed": [r["key"] for r in recs if r["computed_now"]],
            "reused": [r["key"] for r in recs if not r["computed_now"] and r["complete"]],
            "incomplete": [r["key"] for r in recs if not r["complete"]],
        }
        docs[name] = write_map(mp["dir"], meta, s, v, recs, refined and refined[name])
    if len(maps) > 1:
        from .plot.modemap import figure

        panels = {}
        for name, doc in docs.items():
            t = "C_n, C_s of the scene" if not name else f"C_n, C_s {_factor(maps[name]['factor'])}"
            t += f"\n(C_n = {doc['Cn_Pa_m'] / 1e12:g}, C_s = {doc['Cs_Pa_m'] / 1e12:g} MPa/µm)"
            panels[t] = (s, v, doc["labels"]["values"], doc["confidence"]["values"],
                         (doc.get("adaptive") or {}).get("computed"))
        figure(panels, spec["out"] / "modemap_variants.png", suptitle=physics_title(maps[""]["scene"]).split("\n")[0])
    return {"maps": docs, "wall_s": wall}


def _factor(f: float) -> str:
    return f"× {tag(f)}" if f >= 1 else f"÷ {tag(1 / f)}"


def main(argv=None, comm=MPI.COMM_WORLD) -> int:
    """``fricfem sweep ...``: :func:`fricfem.sweep_cli.main`."""
    from .sweep_cli import main as cli_main

    return cli_main(argv, comm)
