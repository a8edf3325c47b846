"""What the paper-figure demos in ``demos/paper/`` share.

Each demo reproduces one figure group of the "Numerical Results" of Coker,
Lykotrafitis, Needleman & Rosakis from fricfem runs of the shipped scenes.
They share

- the command line (:func:`options`): ``--out`` (figures and ``numbers.json``),
  ``--runs`` (run directories, shared between the demos), the reading of the
  loading (``--direction push|pull``, ``--v-scale K`` multiplying every
  scene's V_imp), the mesh (``--preset``), free ``--set`` overrides applied to
  every scene, a shorter ``--t-end`` for smoke tests, and ``--rerun``;
- :func:`scene` and :func:`run_scenes`: a shipped scene under those options,
  run on every rank, a finished run of the same input being reused;
- :func:`load`: a finished run as ``demos/reproduction.py``'s ``Run``, so that
  its helpers (``first_slip``, ``tip_and_behind``, ``loading_front``, ...)
  measure the same things the same way here;
- :class:`Report`: the numbers, the paper's value next to fricfem's, written
  to ``numbers.json``;
- the figures fricfem.plot has no kind for: slip-rate profiles at
  several times (Figs. 15, 17) and station histories of several runs (Figs. 20, 21).

All inputs are SI; figures and reports use mm, µs, MPa, m/s.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpi4py import MPI

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")  # headless pyvista


from fricfem import scene as scenes
from fricfem import analysis, open_run
from fricfem.analysis import measures
from fricfem.output.rundir import Run
from fricfem.output import rundir as rd
from fricfem.plot import common as plot_common
from fricfem import batch
from fricfem.output import quantities
from fricfem.plot import isochromatics as plot_iso

OUTPUT = Path("demos/output/paper")

#: Field snapshot times [s] the paper's isochromatic figures need beyond the
#: shipped scene's (output only: the run is otherwise the shipped scene).
#: Fig. 18 shows Case V at 32, 38 and 44.6 µs; the scene writes 32 and 44 µs.
SNAPSHOTS = {"case5": [32e-6, 38e-6, 44.6e-6]}


# ---------------------------------------------------------------------------
# Command line


def options(name: str, description: str, argv=None) -> argparse.Namespace:
    """Parse the shared options of demo ``name`` (output default ``demos/output/paper/<name>``)."""
    ap = argparse.ArgumentParser(prog=f"{name}.py", description=description)
    ap.add_argument("--out", type=Path, default=OUTPUT / name, help="figures and numbers.json")
    ap.add_argument("--runs", type=Path, default=None,
                    help="run directories, shared by the demos (default: OUT/../runs)")
    ap.add_argument("--preset", default="reference", help="mesh preset: coarse, reference, half, fine")
    ap.add_argument("--direction", default="push", choices=("push", "pull"),
                    help="the struck edge moves into the specimen (push) or out of it (pull)")
    ap.add_argument("--v-scale", type=float, default=1.0, help="factor on every scene's V_imp")
    ap.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                    help="scene override applied to every scene (as for `fricfem run`)")
    ap.add_argument("--t-end", type=float, default=None,
                    help="end every run at this time [s] if earlier than the scene's (smoke tests)")
    ap.add_argument("--rerun", action="store_true", help="run again even if a finished run exists")
    ap.add_argument("--quiet", action="store_true", help="no progress bars, no printed tables")
    args = ap.parse_args(argv)
    args.name = name
    args.runs = args.runs or args.out.parent / "runs"
    return args


def reading(args) -> dict:
    """The options that change the runs, for the record."""
    return {"direction": args.direction, "v_scale": args.v_scale, "preset": args.preset,
            "set": list(args.set), "t_end_s": args.t_end}


def reading_text(args) -> str:
    """The reading in words, for figure titles."""
    extra = f", --set {' '.join(args.set)}" if args.set else ""
    return f"{args.direction}, V_imp × {args.v_scale:g}, {args.preset} mesh{extra}"


def reading_tag(args) -> str:
    """Directory name of a reading: ``push_v1_reference`` (+ a hash of ``--set``/``--t-end`` if any)."""
    tag = f"{args.direction}_v{args.v_scale:g}_{args.preset}"
    if args.set or args.t_end is not None:
        extra = json.dumps([args.set, args.t_end]).encode()
        tag += "_" + hashlib.sha1(extra).hexdigest()[:8]
    return tag


# ---------------------------------------------------------------------------
# Scenes and runs


def scene(name: str, args) -> scenes.Scene:
    """Shipped scene ``name`` under the options: ``--set`` first, then the preset,
    the direction, V_imp × ``--v-scale``, the paper's snapshot times and ``--t-end``.
    Validated here, before any heavy work."""
    raw = scenes.apply_overrides(scenes.resolve(name), args.set)
    raw.setdefault("mesh", {})["preset"] = args.preset
    loading = raw.setdefault("loading", {})
    loading["direction"] = args.direction
    v_imp = loading.get("v_imp", scenes.SCHEMA["loading"]["v_imp"].default)
    loading["v_imp"] = v_imp * args.v_scale
    output = raw.setdefault("output", {})
    if name in SNAPSHOTS:
        output["fields"] = list(SNAPSHOTS[name])
    if args.t_end is not None:
        t_end = min(args.t_end, raw.get("time", {}).get("end", scenes.SCHEMA["time"]["end"].default))
        raw.setdefault("time", {})["end"] = t_end
        output["fields"] = [t for t in output.get("fields", []) if t <= t_end]
    return scenes.validate(raw)


def run_scenes(names, args, comm=MPI.COMM_WORLD) -> dict:
    """Run the shipped scenes ``names`` on all ranks of ``comm``, one after the other
    (the batch runner, :mod:`fricfem.batch`).

    Every scene is validated first.  A run directory holding a finished run of
    the same input is reused unless ``--rerun``.  Returns {scene name: run directory}.
    """
    jobs = [batch.Job(name, args.runs / reading_tag(args) / name, scene(name, args)) for name in names]
    todo = [j for j in jobs if args.rerun or batch.status(j) != "done"]
    if comm.rank == 0 and not args.quiet:
        for j in jobs:
            if j not in todo:
                print(f"{j.key}: reusing {j.dir}", flush=True)
    batch.run_jobs(todo, comm, ranks_per_job=comm.size)
    return {j.key: j.dir for j in jobs}


def load(rundir: Path) -> Run:
    """A finished run as ``reproduction.Run`` (slip rate, |T_s|, T_n, stations, summary)."""
    return open_run(Path(rundir))


def profile(rundir: Path, name: str, t: float):
    """(x1 [m], values) of interface quantity ``name`` in the stored row nearest to ``t`` [s]."""
    with rd.open_interface(rundir) as itf:
        k = int(itf.nearest([t])[0])
        return itf.x1.copy(), itf.rows(name, [k])[0]


def sign(rundir: Path) -> float:
    """Sliding direction sgn(Σ Δu̇_slip T_s): signed quantities times it are positive as in the paper."""
    with rd.open_interface(rundir) as itf:
        return rd.sliding_sign(itf)


def info(rundir: Path) -> rd.RunInfo:
    """Title data of a run (scene, Σ0, V_imp, wave speeds, mode)."""
    with rd.open_interface(rundir) as itf:
        return rd.run_info(rundir, interface=itf)


# ---------------------------------------------------------------------------
# Measurements shared by several demos


def leading_regions(r: Run, t: float) -> list:
    """Slipping regions at ``t`` (``Run.regions``: ≥ 3 points, peak ≥ 0.05 m/s), leading one last."""
    return measures.regions(r, r.at(t))


def mu_app(r: Run) -> np.ndarray:
    """|μ_app| = |T_s| / T_n [n_t, n_p] (0 where the interface is open)."""
    return np.divide(np.abs(r.shear_traction), r.normal_traction, out=np.zeros_like(np.abs(r.shear_traction)), where=r.normal_traction > 0)


def pulse_train(r: Run, t: float, x_max: float = 60e-3) -> dict:
    """Pulse geometry at ``t``, measured as in ``demos/reproduction.py``."""
    return measures.pulse_train(r, t, x_max)


def v_tip(r: Run, t: float, half_window: float = 1e-6) -> float:
    """Mean V_tip [m/s] of summary.json (5-point progressive fit) over t ± ``half_window``."""
    tip = r.summary.get("tip") or {}
    tv = np.asarray(tip.get("v_tip_time_s") or [], dtype=float)
    v = np.asarray(tip.get("v_tip_m_s") or [], dtype=float)
    near = np.abs(tv - t) <= half_window
    return float(np.mean(v[near])) if near.any() else math.nan


def median_v_tip(r: Run, after: float = 0.0, before: float = math.inf) -> float:
    """Median V_tip [m/s] of summary.json over after ≤ t ≤ before [s]."""
    tip = r.summary.get("tip") or {}
    tv = np.asarray(tip.get("v_tip_time_s") or [], dtype=float)
    v = np.asarray(tip.get("v_tip_m_s") or [], dtype=float)
    sel = (tv >= after) & (tv <= before) & np.isfinite(v)
    return float(np.median(v[sel])) if sel.any() else math.nan


def front_speed(r: Run, t: float, x: float, edge: str = "leading", tol: float = 1e-3) -> float:
    """Speed [m/s] of the tracked front (summary.json ``fronts``) of ``edge``
    ("leading": the front of a slipping region, "trailing": its back) that
    passes within ``tol`` [m] of x1 = ``x`` at the sample nearest ``t``: its
    5-point progressive speed there, else its mean speed; NaN if none does."""
    best, speed = tol, math.nan
    for f in r.summary.get("fronts") or []:
        ft = np.asarray(f.get("t") or [], dtype=float)
        if f.get("edge") != edge or ft.size == 0 or not ft[0] - 0.5e-6 <= t <= ft[-1] + 0.5e-6:
            continue
        j = int(np.argmin(np.abs(ft - t)))
        gap = abs(f["x"][j] - x)
        if gap <= best:
            best = gap
            ts, v = np.asarray(f.get("t_speed") or [], dtype=float), np.asarray(f.get("speed") or [], dtype=float)
            speed = float(v[np.argmin(np.abs(ts - t))]) if v.size else float(f.get("mean_speed", math.nan))
    return speed


def station(r: Run, sgn: float, name: str = "x16.1mm") -> dict:
    """Station histories, SI, with signed quantities × ``sgn`` (positive as in the paper)."""
    st = r.stations.get(name, {})
    out = {q: np.asarray(v, dtype=float) for q, v in st.items()}
    for q in plot_common.SIGNED:
        if q in out:
            out[q] = sgn * out[q]
    return out


def station_measures(r: Run, sgn: float, name: str = "x16.1mm") -> dict:
    """What Figs. 20 and 21 show at a station, in numbers.

    Sliding episodes are the runs of Δu̇_slip > 0 in time, found as
    ``analysis.slip_regions`` finds them in space (≥ 3 samples, peak
    ≥ 0.05 m/s): their count, median duration and the median period between
    their starts [µs], and duration / period (the pulse width-to-spacing
    ratio of a steadily travelling train).  "Late" is the last quarter of the
    history, as ``demos/reproduction.py`` takes it for μ_app.
    """
    st = station(r, sgn, name)
    if "time" not in st or len(st["time"]) < 8:
        return {}
    t = st["time"]
    eps = analysis.slip_regions(t, st["slip_rate"], min_points=3, floor=0.05)
    starts = np.array([e.x_start for e in eps])
    period = float(np.median(np.diff(starts))) * 1e6 if len(eps) > 2 else math.nan
    duration = float(np.median([e.width for e in eps[1:]] or [math.nan])) * 1e6 if eps else math.nan
    late = slice(-(len(t) // 4), None)
    mu = st["mu_app"][late]
    return {"onset_us": eps[0].x_start * 1e6 if eps else math.nan, "episodes": len(eps),
            "period_us": period, "duration_us": duration, "duty": duration / period,
            "peak_slip_rate": float(st["slip_rate"].max()), "late_slip_rate": float(st["slip_rate"][late].mean()),
            "late_jump_rate_swing": float(np.ptp(st["jump_rate_s"][late])),
            "late_ts_MPa": float(st["shear_traction"][late].mean()) / 1e6,
            "late_mu": float(mu.mean()), "late_mu_min": float(mu.min()), "late_mu_max": float(mu.max()),
            "peak_mu": float(st["mu_app"].max())}


# ---------------------------------------------------------------------------
# Report: numbers.json


def _tidy(v):
    """JSON-friendly value: floats to 4 significant digits, NaN as null."""
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return None if not math.isfinite(v) else float(f"{v:.4g}")
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (list, tuple)):
        return [_tidy(x) for x in v]
    if isinstance(v, dict):
        return {k: _tidy(x) for k, x in v.items()}
    return v


class Report:
    """The numbers a demo reports: what, the paper's value (quoted), fricfem's, unit."""

    def __init__(self, args, figure: str):
        self.args = args
        self.data = {"demo": args.name, "paper_figure": figure, "reading": reading(args), "runs": {},
                     "numbers": [], "figures": []}

    def add_run(self, name: str, rundir: Path, r: Run) -> None:
        s = r.summary
        inp = s.get("input", {})
        self.data["runs"][name] = {
            "dir": str(rundir), "complete": s.get("complete"), "t_end_us": 1e6 * s.get("t_s", 0.0),
            "sigma0_MPa": inp.get("loading", {}).get("sigma0", math.nan) / 1e6,
            "v_imp_m_s": inp.get("loading", {}).get("v_imp"), "mode": measures.mode(r),
            "interface_points": s.get("interface_points"), "dofs": s.get("dofs"),
        }

    def add(self, quantity: str, paper, fricfem, unit: str = "", note: str = "") -> None:
        row = {"quantity": quantity, "paper": paper, "fricfem": fricfem, "unit": unit}
        if note:
            row["note"] = note
        self.data["numbers"].append(row)

    def figure(self, path) -> None:
        if path is not None:
            self.data["figures"].append(str(path))

    def write(self) -> dict:
        """Write ``OUT/numbers.json`` and print the table (call on rank 0)."""
        out = self.args.out
        out.mkdir(parents=True, exist_ok=True)
        data = _tidy(self.data)
        (out / "numbers.json").write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n")
        if not self.args.quiet:
            print(f"\n{self.args.name} — {data['paper_figure']}")
            for row in data["numbers"]:
                print(f"  {row['quantity']:<58s} paper {str(row['paper']):>14s}   "
                      f"fricfem {str(row['fricfem']):>14s} {row['unit']}")
            print(f"  -> {out / 'numbers.json'}", flush=True)
        return data


def on_rank0(work, comm=MPI.COMM_WORLD):
    """``work()`` on rank 0 (figures and numbers read the run files there); its
    result on every rank.  An error on rank 0 is raised on every rank, so no
    rank is left waiting."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = work()
        except Exception as err:  # re-raised below, after the other ranks have heard of it
            error = err
    failed = comm.bcast(None if error is None else f"{type(error).__name__}: {error}", root=0)
    if error is not None:
        raise error
    if failed:
        raise RuntimeError(f"rank 0 failed: {failed}")
    return comm.bcast(result, root=0)


# ---------------------------------------------------------------------------
# Figures fricfem.plot has no kind for


def isochromatics(rundir: Path, times, out: Path, window=plot_iso.ISO_WINDOW) -> list:
    """``isochromatics_<t>us.png`` at the written snapshots nearest to ``times`` [s]."""
    fields = Path(rundir) / quantities.FIELDS_FILE
    if not fields.is_file():
        return []
    with rd.open_interface(rundir) as itf:
        return plot_iso.isochromatics(fields, out, times=times, info=rd.run_info(rundir, interface=itf),
                                      itf=itf, window=window)


def slip_rate_panels(rundir: Path, times, path: Path, *, traction_at=None, xlim=(0.0, 80e-3)) -> Path:
    """One panel of Δu̇_slip [m/s] against x1 per time (Figs. 15 and 17), with the
    integration points marked; ``traction_at`` adds the sign-corrected T_s at that time."""
    with rd.open_interface(rundir) as itf:
        inf = rd.run_info(rundir, interface=itf)
        sgn = rd.sliding_sign(itf)
        rows = [int(itf.nearest([t])[0]) for t in times]
        x = itf.x1 * 1e3
        fig = Figure(figsize=(7.0, 2.2 * len(rows) + 0.8), dpi=plot_common.DPI)
        axes = fig.subplots(len(rows), 1, sharex=True, squeeze=False)[:, 0]
        for k, (ax, row) in enumerate(zip(axes, rows)):
            rate = itf.rows("slip_rate", [row])[0]
            ax.plot(x, rate, "C0-", lw=1.0, marker="o", ms=2, mfc="none", mew=0.5)
            ax.set_ylabel(quantities.label("slip_rate") + " [m/s]", color="C0")
            ax.text(0.99, 0.92, f"t = {itf.time[row] * 1e6:.3g} µs", transform=ax.transAxes, ha="right",
                    va="top", fontsize=9)
            if traction_at is not None and abs(itf.time[row] - traction_at) < 0.5e-6:
                axr = ax.twinx()
                axr.plot(x, sgn * itf.rows("shear_traction", [row])[0] / 1e6, "C3-", lw=1.0)
                axr.set_ylabel(quantities.label("shear_traction", sgn) + " [MPa]", color="C3")
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.grid(alpha=0.25)
            ax.text(0.01, 0.92, f"({'abcdefgh'[k]})", transform=ax.transAxes, va="top", fontweight="bold")
        axes[-1].set_xlim(xlim[0] * 1e3, xlim[1] * 1e3)
        axes[-1].set_xlabel(r"$x_1$ [mm]")
        fig.suptitle(f"{inf.title()}\nsliding rate along the interface; mode: {inf.mode}", fontsize=10)
        fig.tight_layout()
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=plot_common.DPI)
    return path


def station_stack(runs: dict, path: Path, title: str) -> Path:
    """Histories at x1 = 16.1 mm of several runs (Figs. 20, 21): (a) Δu̇_s, (b)
    Δu̇_slip, (c) T_s, (d) μ_app, one colour per run, the legend giving each
    run's label and sliding mode.  ``runs``: {legend label: run directory}.

    A run whose peak Δu̇_slip is more than 3× every other's is drawn off
    scale in (b), as the paper does for Σ0 = 30 MPa; its legend gives the peak.
    """
    fig = Figure(figsize=(7.0, 9.0), dpi=plot_common.DPI)
    axes = fig.subplots(4, 1, sharex=True)
    panels = (("jump_rate_s", 1.0, " [m/s]"), ("slip_rate", 1.0, " [m/s]"),
              ("shear_traction", 1e-6, " [MPa]"), ("mu_app", 1.0, ""))
    peaks = {}
    t_max = 0.0
    sgn = sign(next(iter(runs.values())))  # one reading for all: one sliding direction
    for k, (text, rundir) in enumerate(runs.items()):
        r = load(rundir)
        st = station(r, sgn)
        if "time" not in st:
            continue
        t = st["time"] * 1e6
        t_max = max(t_max, t[-1])
        peaks[text] = float(st["slip_rate"].max())
        for ax, (q, scale, _) in zip(axes, panels):
            ax.plot(t, st[q] * scale, color=f"C{k}", lw=0.9,
                    label=f"{text} — {measures.mode(r)}" if q == "jump_rate_s" else None)
    if len(peaks) > 1:
        ordered = sorted(peaks.values())
        if ordered[-1] > 3 * ordered[-2] > 0:
            axes[1].set_ylim(top=1.2 * ordered[-2])
            big = max(peaks, key=peaks.get)
            axes[1].text(0.99, 0.95, f"{big}: peak {peaks[big]:.0f} m/s, off scale", transform=axes[1].transAxes,
                         ha="right", va="top", fontsize=8)
    for k, (ax, (q, _, unit)) in enumerate(zip(axes, panels)):
        ax.set_ylabel(quantities.label(q, sgn) + unit)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.grid(alpha=0.25)
        ax.text(0.01, 0.95, f"({'abcd'[k]})", transform=ax.transAxes, va="top", fontweight="bold")
    axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.06, 1.0), framealpha=0.85)
    axes[-1].set_xlim(0.0, t_max)
    axes[-1].set_xlabel(r"$t$ [µs]")
    fig.suptitle(title + "\n" + r"histories at $x_1$ = 16.1 mm (signed quantities as the paper draws them)",
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=plot_common.DPI)
    return path
