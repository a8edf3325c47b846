# # Work–precision: error against wall time, refining the mesh and the step
#
# How much accuracy does a second of computing buy?  For three problems this
# study runs a ladder of meshes, each at two time steps (0.9 and 0.45 of the
# stable step), and measures every run against the finest mesh at the smaller
# step:
#
# - ``case1_v10`` — the paper's Case I at V_imp = 10 m/s (crack-like sliding
#   from the struck edge), mesh presets coarse / reference / half / fine, to
#   34 µs, stations at x1 = 6, 12, 16.1, 24, 30, 36 mm;
# - ``case3`` — the paper's Case III (Σ0 = 10 MPa, V_imp = 20 m/s: a train of
#   pulses), the same presets, end and stations;
# - ``rupture_sw`` — the shipped slip-weakening rupture (an overstressed patch
#   in the middle of a prestressed interface, barriers near both ends, no
#   impact), uniform cells dx = dy = 0.8, 0.4, 0.2, 0.1 mm.
#
# Error metrics, each against the reference run (finest mesh, dt = 0.45 × stable):
#
# - ``station_L2``: the slip-rate histories Δu̇_slip(t) at the stations (every
#   step), interpolated onto the reference's times,
#   sqrt(Σ_s ∫ (v_s − v_s,ref)² dt / Σ_s ∫ v_s,ref² dt);
# - ``tip_mm``: the front of sliding, x_f(t) = max over t' <= t of the leading
#   sliding tip that ``summary.json`` reports (the furthest point with
#   Δu̇_slip > 0, every step) — the running maximum leaves out the retreat of
#   the tip when sliding heals behind an arrested front; max |x_f − x_f,ref|
#   from the reference's initiation to the end (before a run's own initiation
#   its front is taken at the point where it starts);
# - ``rupture_time_us``: the rupture time at a station, the first time
#   Δu̇_slip reaches 1 mm/s, interpolated between steps as the summary's
#   (fricfem.analysis.convergence.rupture_times), max |t_r − t_r,ref| over the
#   stations (a station that breaks in one run but not the other counts as the
#   time to the end).
#
# The observed order is the slope of log(error) against log(h), h the cell
# size along the interface, over the levels coarser than the reference, for
# each step factor.  The wall time is the time loop's (``wall_s.time_loop``:
# stepping, no set-up or output); ``total`` is in the table too, and so is
# the load-independent work, dofs × steps (``Mdof·st``): wall times measured
# on a shared machine carry its load (the load average is recorded).  Every
# run uses all ranks of COMM_WORLD, one after the other.
#
# Run (about 5 minutes on 2 quiet cores, 15 on a busy machine; ``--quick``
# drops the finest level and takes a quarter of that):
#
#     mpirun -n 2 .venv/bin/python benchmarks/work_precision.py [--quick]
#
# writes ``benchmarks/results/work_precision.json``, one figure per problem
# ``work_precision_<problem>.png`` and prints the table.  ``--smoke`` (tests)
# runs the rupture problem on two very coarse meshes for a few µs.  Run
# directories go to ``runs/work_precision/``; ``--reuse`` keeps a complete run
# whose input is unchanged.

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from fricfem import batch, load_scene
from fricfem.analysis.convergence import (RUPTURE_THRESHOLD, front_at, order, record, rupture_speeds,  # noqa: F401
                                         rupture_time_error, rupture_times, station_l2, tip_error)

HERE = Path(__file__).resolve().parent
SAFETY = (0.9, 0.45)  # fractions of the stable step

# Stations of the paper cases [m] (the paper's 16.1 mm among them): inside the
# fine region, where both cases slide by 34 µs.
PAPER_STATIONS = {"x06mm": 6e-3, "x12mm": 12e-3, "x16.1mm": 16.1e-3, "x24mm": 24e-3, "x30mm": 30e-3,
                  "x36mm": 36e-3}


class Level(NamedTuple):
    """One mesh of a ladder: a name, the overrides that select it."""

    name: str
    overrides: tuple


class Problem(NamedTuple):
    """A scene, the overrides common to its runs, and its mesh ladder (coarse to fine)."""

    scene: str
    overrides: tuple
    levels: tuple


def _stations(d: dict) -> str:
    return "output.stations={" + ", ".join(f'"{k}" = {v!r}' for k, v in d.items()) + "}"


def problems(mode: str) -> dict:
    """The problems of the study: ``mode`` is ``full``, ``quick`` or ``smoke``."""
    presets = ["coarse", "reference", "half", "fine"]
    cells = [0.8e-3, 0.4e-3, 0.2e-3, 0.1e-3]
    if mode == "quick":
        presets, cells = presets[:3], cells[:3]
    paper = (_stations(PAPER_STATIONS), "time.end=34e-6")
    out = {
        "case1_v10": Problem("case1", ("loading.v_imp=10",) + paper,
                             tuple(Level(p, (f"mesh.preset='{p}'",)) for p in presets)),
        "case3": Problem("case3", paper, tuple(Level(p, (f"mesh.preset='{p}'",)) for p in presets)),
        "rupture_sw": Problem("rupture_sw", (),
                              tuple(Level(f"dx{h * 1e3:g}mm", (f"mesh.dx={h!r}", f"mesh.dy={h!r}")) for h in cells)),
    }
    if mode == "smoke":
        out = {"rupture_sw": Problem("rupture_sw", ("time.end=6e-6",),
                                     tuple(Level(f"dx{h * 1e3:g}mm", (f"mesh.dx={h!r}", f"mesh.dy={h!r}"))
                                           for h in (1.6e-3, 0.8e-3)))}
    return out


# ## Running and reading one run
#
# Every run writes its directory (the batch runner reuses a finished one); rank
# 0 keeps what the metrics need (fricfem.analysis.convergence.record): the
# station histories, the tip track and the timings.


def run_one(scene, d: Path, comm, reuse: bool) -> dict:
    """Run (or, with ``reuse``, keep) ``scene`` in ``d`` on every rank; its record on rank 0, None elsewhere."""
    job = batch.Job(d.name, d, scene)
    keep = comm.bcast(reuse and batch.status(job) == "done" if comm.rank == 0 else None, root=0)
    if not keep:
        batch.run_jobs([job], comm, ranks_per_job=comm.size)
    return {**record(d, scene), "reused": keep} if comm.rank == 0 else None


# ## Metrics


METRICS = {"station_L2": "station slip-rate L2 (rel.)", "tip_mm": "front of sliding max |Δx| [mm]",
           "rupture_time_us": "rupture time max |Δt_r| [µs]"}


def analyse(label: str, prob: Problem, recs: dict) -> dict:
    """Rows (one per run), orders and, for the rupture problem, its behaviour (rank 0)."""
    finest = prob.levels[-1].name
    ref = recs[(finest, min(SAFETY))]
    rows = []
    for lev in prob.levels:
        for s in SAFETY:
            r = recs[(lev.name, s)]
            is_ref = r is ref
            rows.append({
                "level": lev.name, "h_mm": r["h_m"] * 1e3, "dt_safety": s, "dofs": r["dofs"],
                "dt_ns": r["dt_s"] * 1e9, "steps": r["steps"], "mdof_steps": r["dofs"] * r["steps"] * 1e-6,
                "wall_loop_s": r["wall_loop_s"],
                "wall_total_s": r["wall_total_s"], "us_per_step": r["us_per_step"], "reference": is_ref,
                "reused": r["reused"],
                "station_L2": 0.0 if is_ref else station_l2(r, ref),
                "tip_mm": 0.0 if is_ref else 1e3 * tip_error(r, ref),
                "rupture_time_us": 0.0 if is_ref else 1e6 * rupture_time_error(r, ref),
            })
    orders = {}
    for s in SAFETY:
        sel = [row for row in rows if row["dt_safety"] == s and row["level"] != finest]
        orders[str(s)] = {m: order([row["h_mm"] for row in sel], [row[m] for row in sel]) for m in METRICS}
    out = {"scene": prob.scene, "overrides": list(prob.overrides),
           "reference": f"{finest}, dt = {min(SAFETY)} × stable", "rows": rows, "orders": orders}
    if label.startswith("rupture"):
        scene = load_scene(prob.scene)
        patch = scene.tau0_patches[0]
        xc = 0.5 * (patch["x1_min"] + patch["x1_max"])
        sp = ref["speeds"]
        beh = {}
        for lev in prob.levels:
            r = recs[(lev.name, min(SAFETY))]
            v = rupture_speeds(r, xc)
            tr = rupture_times(r)
            beh[lev.name] = {
                "speed_m_s": v, "speed_over_c_R": {k: x / sp["c_R"] for k, x in v.items()},
                "speed_over_c_s": {k: x / sp["c_s"] for k, x in v.items()},
                "rupture_time_us": {n: (t * 1e6 if np.isfinite(t) else None) for n, t in tr.items()},
                "station_x_mm": {n: s["x1"] * 1e3 for n, s in r["stations"].items()},
                "peak_slip_rate_m_s": {n: float(s["v"].max(initial=0.0)) for n, s in r["stations"].items()},
            }
        out["behaviour"] = {"patch_centre_mm": xc * 1e3, "speeds": sp, "levels": beh}
    return out


# ## Figure and table


def figure(label: str, res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, len(METRICS), figsize=(5.2 * len(METRICS), 4.2))
    for ax, (m, title) in zip(axs, METRICS.items()):
        for s, marker in zip(SAFETY, ("o", "s")):
            rows = [r for r in res["rows"] if r["dt_safety"] == s and not r["reference"] and r[m] > 0]
            if not rows:
                continue
            p = res["orders"][str(s)][m]
            ax.loglog([r["wall_loop_s"] for r in rows], [r[m] for r in rows], marker=marker, ls="-",
                      label=f"dt = {s} × stable, order p = {p:.2f}" if np.isfinite(p) else f"dt = {s} × stable")
            for r in rows:
                note = " (dt only)" if r["level"] == res["rows"][-1]["level"] else ""
                ax.annotate(r["level"] + note, (r["wall_loop_s"], r[m]), textcoords="offset points",
                            xytext=(4, 4), fontsize=7)
        ax.set_xlabel("wall time, time loop [s] (2 ranks)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{label}: error against the {res['reference']} run (p: slope vs cell size)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(results: dict) -> str:
    head = (f"{'problem':11s} {'level':10s} {'h mm':>6s} {'dt/st':>5s} {'dofs':>7s} {'dt ns':>6s} {'steps':>5s} "
            f"{'Mdof·st':>7s} {'loop s':>7s} {'total s':>7s} {'station L2':>10s} {'tip mm':>8s} {'t_r µs':>8s}")
    lines = [head, "-" * len(head)]
    for label, res in results.items():
        for r in res["rows"]:
            mark = "  (reference)" if r["reference"] else ""
            lines.append(f"{label:11s} {r['level']:10s} {r['h_mm']:6.3f} {r['dt_safety']:5.2f} {r['dofs']:7d} "
                         f"{r['dt_ns']:6.1f} {r['steps']:5d} {r['mdof_steps']:7.0f} {r['wall_loop_s']:7.1f} "
                         f"{r['wall_total_s']:7.1f} "
                         f"{r['station_L2']:10.2e} {r['tip_mm']:8.3f} {r['rupture_time_us']:8.3f}{mark}")
        for s, o in res["orders"].items():
            lines.append(f"{'':11s} observed order at dt = {s} × stable: "
                         + ", ".join(f"{m} {v:.2f}" for m, v in o.items()))
        beh = res.get("behaviour")
        if beh:
            for lev, b in beh["levels"].items():
                v = b["speed_m_s"]
                lines.append(f"{'':11s} {lev}: rupture speed left {v['left']:.0f} m/s "
                             f"({b['speed_over_c_R']['left']:.2f} c_R), right {v['right']:.0f} m/s "
                             f"({b['speed_over_c_R']['right']:.2f} c_R)")
    return "\n".join(lines)


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    ap = argparse.ArgumentParser(description="Error against wall time for mesh and step refinement.")
    ap.add_argument("--quick", action="store_true", help="three mesh levels instead of four")
    ap.add_argument("--smoke", action="store_true", help="the rupture problem on two very coarse meshes (tests)")
    ap.add_argument("--problems", nargs="+", help="a subset of case1_v10, case3, rupture_sw")
    ap.add_argument("--work", type=Path, default=Path("runs/work_precision"), help="run directories")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--reuse", action="store_true", help="keep complete runs whose input is unchanged")
    args = ap.parse_args(argv)
    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    probs = problems(mode)
    if args.problems:
        probs = {k: v for k, v in probs.items() if k in args.problems}
    t0 = time.perf_counter()
    load0 = os.getloadavg()
    results = {}
    for label, prob in probs.items():
        recs = {}
        for lev in prob.levels:
            for s in SAFETY:
                scene = load_scene(prob.scene, list(prob.overrides) + list(lev.overrides)
                                    + [f"time.dt_safety={s}", "output.fields=[]"])
                d = args.work / mode / label / f"{lev.name}_s{s}"
                recs[(lev.name, s)] = run_one(scene, d, comm, args.reuse)
                if comm.rank == 0:
                    r = recs[(lev.name, s)]
                    print(f"{label} {lev.name} dt={s}: {r['dofs']} dofs, {r['steps']} steps, "
                          f"loop {r['wall_loop_s']:.1f} s", flush=True)
        if comm.rank == 0:
            results[label] = analyse(label, prob, recs)
    data = None
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
        stem = "work_precision" if mode == "full" else f"work_precision_{mode}"
        data = {"mode": mode, "ranks": comm.size, "safety": list(SAFETY), "rupture_threshold_m_s": RUPTURE_THRESHOLD,
                "wall_s": time.perf_counter() - t0, "loadavg_start": load0, "loadavg_end": os.getloadavg(),
                "runs_wall_total_s": sum(r["wall_total_s"] for res in results.values() for r in res["rows"]),
                "problems": results}
        (args.out / f"{stem}.json").write_text(json.dumps(data, indent=2))
        for label, res in results.items():
            figure(label, res, args.out / f"{stem}_{label}.png")
        print(table(results))
        print(f"wall time of the study: {data['wall_s']:.0f} s (runs: {data['runs_wall_total_s']:.0f} s; "
              f"load average {load0[0]:.1f} at the start, {data['loadavg_end'][0]:.1f} at the end)")
    return comm.bcast(data, root=0)


if __name__ == "__main__":
    main()
