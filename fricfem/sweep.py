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
``DIR/points/s<Σ0 MPa>_v<V m/s>/`` (a normal run directory).  A point whose
``summary.json`` says ``"complete": true`` is reused, so a killed sweep picks
up where it stopped; an incomplete point is rerun from scratch.

Under ``mpirun -n N`` the points to compute are sorted by expected cost and
dealt round-robin to the ranks; each rank runs its points on
``MPI.COMM_SELF`` (one serial run per point — a sweep scales by points, not
by domain decomposition).  Then rank 0 reads every point's record and writes:

- ``DIR/modemap.json``: the grid, the label table, the crack/pulse boundary and
  per point the label, initiation, peak slip rate, median tip speed, wall time
  and the scene overrides;
- ``DIR/modemap.png``: Σ0 (log) × V_imp (log), one marker per mode, the
  boundary dashed;
- with ``--variants``: ``DIR/stiff_x10/`` and ``DIR/stiff_div10/`` (the same
  files) and ``DIR/modemap_variants.png`` with the three maps side by side.

Progress: rank 0 prints a line per point it finishes; every rank appends to
``DIR/sweep.log``.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import json
import math
import sys
import time
from pathlib import Path

from mpi4py import MPI

from . import config
from .config import SceneError

#: The default grid (``--grid default``): the span of the paper's Fig. 19.
DEFAULT_SIGMA0_MPA = (0.9, 2.0, 4.0, 6.0, 10.0, 16.0, 24.0, 40.0)
DEFAULT_V_IMP = (1.0, 2.0, 4.0, 7.0, 10.0, 15.0, 20.0, 40.0)

#: ``--variants``: sub-map directory -> factor on C_n and C_s (the paper's "Mesh and
#: interface stiffness" paragraph: × 10 gives only crack-like sliding, ÷ 10 no trains).
VARIANTS = {"stiff_x10": 10.0, "stiff_div10": 0.1}

#: Keys the sweep sets itself; ``--set`` may not touch them.
SWEPT_KEYS = ("loading.sigma0", "loading.v_imp", "output.fields")

#: Marker per mode label (all of :data:`fricfem.diagnostics.LABELS`) and for a point without one.
MARKERS = {
    "none": dict(marker="o", facecolor="none", edgecolor="0.55", label="no sliding"),
    "crack-like": dict(marker="s", facecolor="C3", edgecolor="k", label="crack-like"),
    "pulse": dict(marker="^", facecolor="C0", edgecolor="k", label="pulse"),
    "pulse-train": dict(marker="D", facecolor="C2", edgecolor="k", label="train of pulses"),
    "mixed": dict(marker="*", facecolor="C4", edgecolor="k", label="mixed", size=1.8),
    "diverged": dict(marker="X", facecolor="0.2", edgecolor="k", label="stopped by the watchdog"),
    None: dict(marker="x", facecolor="k", edgecolor="k", label="incomplete / not classified"),
}

#: Table cell per label (stdout).
SHORT = {"none": ".", "crack-like": "crack", "pulse": "pulse", "pulse-train": "train", "mixed": "mixed", "diverged": "div",
         None: "?"}

_CRACK = ("crack-like",)
_PULSE = ("pulse", "pulse-train")


@dataclasses.dataclass(frozen=True)
class Point:
    """One grid point of one map: what to run and where.

    ``overrides`` are the ``--set`` items that turn the base scene into this
    point (all of them, in order); ``cost`` is the relative expected cost
    used to deal points to ranks.
    """

    map: str            # "" for the main map, else the variant's sub-directory
    sigma0_mpa: float   # Σ0 [MPa]
    v_imp: float        # V_imp [m/s]
    key: str            # s<Σ0>_v<V>
    dir: Path           # run directory
    overrides: tuple
    cost: float


# --------------------------------------------------------------------------- grid and scenes


def tag(x: float) -> str:
    """Short decimal form of a grid value for directory names: 0.9 -> '0.9', 40.0 -> '40'."""
    return f"{x:g}"


def parse_axis(text: str, name: str, unit: str) -> tuple:
    """'0.9,2,4' -> (0.9, 2.0, 4.0), sorted; every value finite and > 0, no duplicates."""
    values = []
    for item in text.split(","):
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


def _key_of(item: str) -> str:
    return item.partition("=")[0].strip()


def expected_cost(scene: config.Scene) -> float:
    """Relative cost of a run, for dealing points to ranks (heavier first).

    Steps ∝ t_end / dt with dt ∝ the smallest cell size (interface springs
    stiffer than the bulk shorten it further, ∝ 1/√C_n); work per step ∝ the
    cell count ∝ 1/(dx·dy); and the friction kernel sub-steps more when
    sliding is fast, which grows with V_imp.  Only the ordering matters.
    """
    m = scene.mesh
    h = min(m.dx, m.dy)
    stiff = max(1.0, math.sqrt(scene.Cn / 3e11))
    return scene.t_end / h * stiff / (m.dx * m.dy) * (1.0 + scene.pulse.v_imp / 10.0)


def plan(base: str, sigma0_mpa, v_imp, sets=(), preset: str | None = None, variants: bool = False,
         out: Path = Path(".")) -> tuple:
    """Every point of every map, validated: ``(maps, points)``.

    ``maps`` is {map name: {"dir", "overrides", "factor", "Cn", "Cs"}} ("" is
    the main map; factor scales C_n and C_s [Pa/m]).  Each
    point's scene is loaded once (``config.load``: TOML + validation, no mesh),
    so any bad input raises one :class:`SceneError` before anything runs.
    """
    sets = list(sets or ())
    for item in sets:
        config.parse_override(item)  # the item's form: section.key=value
        key = _key_of(item)
        if key in SWEPT_KEYS:
            raise SceneError(f"--set {item!r}: {key} is set by the sweep itself (use --sigma0 / --v-imp; "
                             f"sweeps write no field snapshots)")
        if key == "mesh.preset" and preset:
            raise SceneError(f"--set {item!r} and --preset {preset}: give the mesh preset once")
    common = sets + ([f"mesh.preset={json.dumps(preset)}"] if preset else []) + ["output.fields=[]"]
    base_scene = config.load(base, common)
    maps = {"": {"dir": out, "overrides": tuple(common), "factor": 1.0, "Cn": base_scene.Cn,
                 "Cs": base_scene.Cs}}
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
                over = mp["overrides"] + (f"loading.sigma0={round(s * 1e6, 3)!r}", f"loading.v_imp={float(v)!r}")
                label = f"{base_scene.name}{'_' + name if name else ''}_{key}"
                try:
                    scene = config.load(base, over + (f"name={json.dumps(label)}",))
                except SceneError as err:
                    raise SceneError(f"point Σ0 = {tag(s)} MPa, V_imp = {tag(v)} m/s"
                                     f"{' (' + name + ')' if name else ''}: {err}") from None
                points.append(Point(name, s, v, key, mp["dir"] / "points" / key, over
                                    + (f"name={json.dumps(label)}",), expected_cost(scene)))
    return maps, points


def deal(points, size: int) -> list:
    """Round-robin over points sorted by expected cost (heaviest first): list per rank."""
    order = sorted(points, key=lambda p: (-p.cost, p.map, p.sigma0_mpa, p.v_imp))
    return [order[r::size] for r in range(size)]


# --------------------------------------------------------------------------- point state and records


def read_summary(run_dir: Path) -> dict | None:
    try:
        return json.loads((run_dir / "summary.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def finished(s: dict | None) -> bool:
    """A run that ended for good: complete, or stopped by the watchdog (rerunning gives the same)."""
    return bool(s) and bool(s.get("complete") or s.get("watchdog"))


def status(point: Point, scene_raw: dict) -> str:
    """'done' (finished, same inputs), 'stale' (finished, other inputs), 'todo' (absent or incomplete)."""
    s = read_summary(point.dir)
    if not finished(s):
        return "todo"
    if json.loads(json.dumps(s.get("input"))) != json.loads(json.dumps(scene_raw)):
        return "stale"
    return "done"


def _diff(a, b, prefix=""):
    """First differing key path between two nested dicts (for the stale-point message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                return _diff(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else k)
    return f"{prefix}: {a!r} (stored) vs {b!r} (now)"


def peak_slip_rate(run_dir: Path) -> float | None:
    """max Δu̇_slip [m/s] over the recorded interface snapshots (None without a file)."""
    import h5py

    try:
        with h5py.File(run_dir / "interface.h5", "r") as f:
            n = int(f.attrs.get("n_time", f["time"].shape[0]))
            if n == 0:
                return 0.0
            return float(f["slip_rate"][:n].max())
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
    s = read_summary(point.dir) or {}
    mode = s.get("mode") or {}
    ev = mode.get("evidence") or {}
    tip = s.get("tip") or {}
    ini = s.get("initiation")
    return {
        "key": point.key,
        "sigma0_MPa": point.sigma0_mpa,
        "v_imp_m_s": point.v_imp,
        "dir": str(Path("points") / point.key),
        "complete": finished(s),
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


# --------------------------------------------------------------------------- the map


def boundary(sigma0, v_imp, labels) -> list:
    """The crack/pulse boundary: at most one point per Σ0 column, joined into a line.

    ``labels[i][j]`` is the label at (sigma0[i], v_imp[j]), both axes
    increasing.  In each column the points without sliding (``none``) or
    without a label are set aside; walking up in V_imp over the rest, the
    first change between crack-like and the others places the boundary
    point: on the ``mixed`` point when the change is to or from one (the
    paper: mixed modes occur near the dashed line), else at the geometric
    mean of the two V_imp (the middle on the log axis) between crack-like and
    pulse / pulse-train.  A column without such a change has no point.
    Returns [(Σ0, V_imp), ...] in increasing Σ0.
    """
    out = []
    for i, s in enumerate(sigma0):
        col = [(v, lab) for v, lab in zip(v_imp, labels[i]) if lab in _CRACK + _PULSE + ("mixed",)]
        for (va, la), (vb, lb) in zip(col, col[1:]):
            if (la in _CRACK) != (lb in _CRACK):
                out.append((s, va if la == "mixed" else vb if lb == "mixed" else math.sqrt(va * vb)))
                break
    return out


def label_table(sigma0, v_imp, by_key) -> list:
    """labels[i][j] at (sigma0[i], v_imp[j]) from {key: record}."""
    return [[(by_key.get(f"s{tag(s)}_v{tag(v)}") or {}).get("label") for v in v_imp] for s in sigma0]


def draw(ax, sigma0, v_imp, labels, title: str = "") -> None:
    """One map on ``ax``: markers per mode, the boundary dashed, log axes."""
    for lab, style in MARKERS.items():
        xs = [s for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
              if (labels[i][j] if labels[i][j] in MARKERS else None) == lab]
        ys = [v for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
              if (labels[i][j] if labels[i][j] in MARKERS else None) == lab]
        if not xs:
            continue
        ax.scatter(xs, ys, marker=style["marker"], s=55 * style.get("size", 1.0) ** 2,
                   facecolors=style["facecolor"], edgecolors=style["edgecolor"], linewidths=0.8,
                   label=style["label"], zorder=3)
    line = boundary(sigma0, v_imp, labels)
    if line:
        bx, by = zip(*line)
        ax.plot(bx, by, "k--", lw=1.2, marker="_" if len(line) == 1 else None, ms=14,
                label="crack / pulse boundary", zorder=2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    pad = 1.35
    ax.set_xlim(min(sigma0) / pad, max(sigma0) * pad)
    ax.set_ylim(min(v_imp) / pad, max(v_imp) * pad)
    ax.set_xticks(sigma0)
    ax.set_xticklabels([tag(s) for s in sigma0])
    ax.set_yticks(v_imp)
    ax.set_yticklabels([tag(v) for v in v_imp])
    ax.minorticks_off()
    ax.set_xlabel("Σ0 [MPa]")
    ax.set_ylabel("V_imp [m/s]")
    ax.grid(True, which="major", lw=0.3, alpha=0.5)
    if title:
        ax.set_title(title, fontsize=10)


def figure(maps: dict, path: Path) -> None:
    """``maps``: {title: (sigma0, v_imp, labels)} → one panel each, a shared legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(maps)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n + 1.8, 4.8), squeeze=False)
    handles = {}
    for ax, (title, (s, v, labels)) in zip(axes[0], maps.items()):
        draw(ax, s, v, labels, title)
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="center right", fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1 - 1.7 / (5.2 * n + 1.8), 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


def write_map(out: Path, meta: dict, sigma0, v_imp, records: list) -> dict:
    """``out/modemap.json`` and ``out/modemap.png``; returns the JSON document."""
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


def table(sigma0, v_imp, labels) -> str:
    """The label grid as text: V_imp rows (top = fastest), Σ0 columns."""
    w = 7
    lines = ["V_imp \\ Σ0 " + "".join(f"{tag(s):>{w}}" for s in sigma0) + "  [MPa]"]
    for j in reversed(range(len(v_imp))):
        lines.append(f"{tag(v_imp[j]):>6} m/s " + "".join(f"{SHORT.get(labels[i][j], '?'):>{w}}"
                                                          for i in range(len(sigma0))))
    return "\n".join(lines)


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


def run_points(points, base: str, log) -> list:
    """Run ``points`` one after another on ``MPI.COMM_SELF``; [(key, map, error or None, wall)]."""
    from . import run

    done = []
    for k, p in enumerate(points):
        t0 = time.perf_counter()
        err = None
        interrupted = False
        try:
            scene = config.load(base, p.overrides)
            summary = run.run_scene(scene, p.dir, MPI.COMM_SELF, overwrite=True, quiet=True)
            interrupted = bool(summary.get("interrupted"))
            label = (summary.get("mode") or {}).get("label", "?")
        except Exception as e:  # one failed point does not stop the sweep (nor leave ranks waiting)
            err = f"{type(e).__name__}: {e}"
            label = "failed"
        wall = time.perf_counter() - t0
        where = f"{p.map}/{p.key}" if p.map else p.key
        log(f"{k + 1}/{len(points)} {where}: {err or label} ({wall:.1f} s)")
        done.append((p.key, p.map, err, wall))
        # runs on COMM_SELF leave PETSc objects to the garbage collector: free them now
        gc.collect()
        petsc = sys.modules.get("petsc4py.PETSc")
        if petsc is not None and hasattr(petsc, "garbage_cleanup"):
            petsc.garbage_cleanup(MPI.COMM_SELF)
        if interrupted:  # SIGTERM (mpirun forwards it to every rank): leave the rest for a rerun
            log("interrupted (SIGTERM): stopping; rerun the same command to resume")
            break
    return done


def sweep(base: str, sigma0_mpa, v_imp, out, sets=(), preset=None, label=None, variants=False,
          overwrite=False, quiet=False, comm=MPI.COMM_WORLD) -> dict | None:
    """Run (or resume) the map(s) (collective on ``comm``).

    Returns ``{"maps": {map name: modemap.json document}, "wall_s"}`` on rank
    0, None elsewhere.  Raises :class:`SceneError` on every rank, before any
    run, when an input is bad or (without ``overwrite``) a complete point in
    ``out`` was computed with other inputs.
    """
    t0 = time.perf_counter()
    out = Path(out)
    problem = plan_out = None
    if comm.rank == 0:
        try:
            if out.exists() and not out.is_dir():
                raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
            maps, points = plan(base, sigma0_mpa, v_imp, sets, preset, variants, out)
            root = config.resolve(base)
            todo, stale = [], []
            for p in points:
                raw = config.apply_overrides(root, p.overrides)
                st = status(p, raw)
                if st == "stale":
                    stale.append((p, _diff((read_summary(p.dir) or {}).get("input"), json.loads(json.dumps(raw)))))
                if st == "todo" or (st == "stale" and overwrite):
                    todo.append(p)
            if stale and not overwrite:
                p, why = stale[0]
                raise SceneError(f"{p.dir}: complete run with other inputs ({why}); {len(stale)} point(s) "
                                 f"differ. Use another --out, or --overwrite to recompute them")
            for mp in maps.values():
                (mp["dir"] / "points").mkdir(parents=True, exist_ok=True)
            plan_out = (maps, points, todo)
        except Exception as err:  # reported on every rank: no rank is left waiting
            problem = str(err) if isinstance(err, SceneError) else f"{type(err).__name__}: {err}"
    problem = comm.bcast(problem, root=0)
    if problem:
        raise SceneError(problem)
    maps, points, todo = comm.bcast(plan_out, root=0)

    log = _Log(out / "sweep.log", comm.rank, quiet)
    if comm.rank == 0:
        log(f"{len(points)} point(s) in {len(maps)} map(s): {len(points) - len(todo)} complete, "
            f"{len(todo)} to run on {comm.size} rank(s)")
    done = run_points(deal(todo, comm.size)[comm.rank], base, log)
    gathered = comm.gather(done, root=0)

    result = failure = None
    if comm.rank == 0:
        try:
            result = _collect(maps, points, gathered, base, sigma0_mpa, v_imp, sets, preset, label, out,
                              comm.size, t0)
        except Exception as err:  # say so on every rank rather than leave them waiting
            failure = f"writing the map failed: {type(err).__name__}: {err}"
            raise
        finally:
            failure = comm.bcast(failure, root=0)
    else:
        failure = comm.bcast(None, root=0)
        if failure:
            raise RuntimeError(failure)
    return result


def _collect(maps, points, gathered, base, sigma0_mpa, v_imp, sets, preset, label, out, ranks, t0) -> dict:
    """Rank 0: records of every point, ``modemap.json``/``.png`` per map, the combined figure."""
    title0 = label or config.resolve(base).get("name", str(base))
    computed = {(m, k): err for part in gathered for k, m, err, _ in part}
    wall = time.perf_counter() - t0
    docs = {}
    for name, mp in maps.items():
        recs = []
        for p in (p for p in points if p.map == name):
            r = record(p)
            r["computed_now"] = (name, p.key) in computed
            if computed.get((name, p.key)):
                r["error"] = computed[(name, p.key)]
            recs.append(r)
        f = mp["factor"]
        try:  # keep the record of earlier calls (a resumed sweep's own wall time is small)
            calls = json.loads((mp["dir"] / "modemap.json").read_text()).get("calls", [])
        except (FileNotFoundError, json.JSONDecodeError, AttributeError):
            calls = []
        computed_here = [r["key"] for r in recs if r["computed_now"]]
        calls.append({"finished": time.strftime("%Y-%m-%dT%H:%M:%S"), "ranks": ranks, "wall_s": wall,
                      "computed": len(computed_here), "point_wall_s": sum(r["wall_s"] or 0.0 for r in recs
                                                                          if r["computed_now"])})
        meta = {
            "title": title0 if not name else f"{title0}: C_n, C_s {_factor(f)}",
            "base": str(base), "map": name or "main", "dir": str(mp["dir"]), "sets": list(sets or ()),
            "preset": preset, "interface_factor": f, "Cn_Pa_m": mp["Cn"], "Cs_Pa_m": mp["Cs"],
            "overrides": list(mp["overrides"]), "ranks": ranks, "sweep_wall_s": wall, "calls": calls,
            "computed": computed_here,
            "reused": [r["key"] for r in recs if not r["computed_now"] and r["complete"]],
            "incomplete": [r["key"] for r in recs if not r["complete"]],
        }
        docs[name] = write_map(mp["dir"], meta, sigma0_mpa, v_imp, recs)
    if len(maps) > 1:
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
    p = _Parser(prog="fricfem sweep", description="the sliding-mode map over Σ0 × V_imp (paper's Fig. 19); "
                "resumable, parallel over points under mpirun")
    p.add_argument("scene", metavar="BASE_SCENE", help="shipped scene name or .toml file every point starts from")
    p.add_argument("--sigma0", metavar="LIST", help="Σ0 values in MPa, comma-separated, e.g. 0.9,2,4,6,10,16,24,40")
    p.add_argument("--v-imp", metavar="LIST", help="V_imp values in m/s, comma-separated, e.g. 1,2,4,7,10,15,20,40")
    p.add_argument("--grid", choices=["default"],
                   help="the default 8 × 8 grid (Σ0 0.9–40 MPa, V_imp 1–40 m/s) for any axis not given")
    p.add_argument("--set", action="extend", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a scene key for every point (repeatable; not loading.sigma0/v_imp)")
    p.add_argument("--preset", choices=list(_presets()), help="mesh preset for every point")
    p.add_argument("--out", required=True, metavar="DIR", help="sweep directory (resumed if it holds points)")
    p.add_argument("--label", metavar="NAME", help="the map's title (default: the base scene's name)")
    p.add_argument("--variants", action="store_true",
                   help="also the maps with C_n, C_s × 10 (DIR/stiff_x10) and ÷ 10 (DIR/stiff_div10)")
    p.add_argument("--overwrite", action="store_true",
                   help="recompute complete points whose stored inputs differ from this sweep's")
    p.add_argument("--quiet", action="store_true", help="no per-point progress lines on stderr")
    p.comm = comm
    return p


def _presets():
    from . import mesh

    return mesh.PRESETS


def main(argv=None, comm=MPI.COMM_WORLD) -> int:
    """``fricfem sweep ...`` (collective): 0 when every point is complete, 1 if some are not
    (failed or interrupted: rerun to resume), 2 on bad input (nothing run)."""
    args = parser(comm).parse_args(argv)
    try:
        if args.sigma0 is None and args.grid is None:
            raise SceneError("--sigma0: give the Σ0 values (MPa), or --grid default")
        if args.v_imp is None and args.grid is None:
            raise SceneError("--v-imp: give the V_imp values (m/s), or --grid default")
        s = parse_axis(args.sigma0, "--sigma0", "MPa") if args.sigma0 else DEFAULT_SIGMA0_MPA
        v = parse_axis(args.v_imp, "--v-imp", "m/s") if args.v_imp else DEFAULT_V_IMP
        res = sweep(args.scene, s, v, args.out, args.set, args.preset, args.label, args.variants,
                    args.overwrite, args.quiet, comm)
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
