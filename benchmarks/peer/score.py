# # fricfem against a peer code: SEM2DPACK on tpv205_2d, rsf_aging_2d and rsf_slip_2d
#
# The three problems of benchmarks/peer/ (README there) are shipped as scenes,
# ``fricfem/scenes/tpv205_2d.toml``, ``rsf_aging_2d.toml`` and ``rsf_slip_2d.toml``.  This script
# runs them on a ladder of cell sizes h (the band of square cells along the
# fault; graded outside), with both interface kinds (``rigid`` split nodes and
# ``elastic`` springs with the scene's C_n, C_s), and scores each run against
# the peer's finest run (``p8_h0.0625mm``: polynomial degree 8, 0.5 mm
# elements) at the peer's stations (17 on tpv205_2d and rsf_aging_2d, 21 on rsf_slip_2d):
#
# - rupture time t_r: the first time the slip rate exceeds 1e-3 m/s,
#   interpolated linearly between samples (the peer's definition).  A rigid
#   run's sample is its step's mean rate V^{n+½}: a zero sample means no slip
#   until its step ends at t^{n+1}, so the crossing out of it is interpolated
#   from there (the peer's whole-step samples: from the sample; ``rupture_time``);
# - peak slip rate and the slip at the peer's end time.
#
# Errors: the worst |Δt_r| over the stations that rupture after 1 µs (µs and %
# of t_r: the nucleation patch slips from the first step), the worst relative
# error of the peak slip rate and of the final slip over the stations that slip
# (peak > 1e-3 m/s).  The peer's own coarser runs are scored the same way from
# its summary JSON.
#
# Work: the CPU seconds (user + system) of the whole run summed over its ranks
# (start-up, imports, mesh, assembly, time loop, output; every run a separate
# ``mpirun``, its ranks measuring themselves with getrusage at exit; the
# numba and ffcx caches warm; ``output.diagnostics = false``: the mode
# classifier is not needed for the scores; idle MPI ranks yield the core,
# ``OMPI_MCA_mpi_yield_when_idle=1``), against the peer's ``cpu_s`` (user +
# system of its serial solver, /usr/bin/time).
#
# Where the stations sit.  A rigid run's points are the node pairs: every
# station is a node.  An elastic run's points are Gauss points (4 a segment);
# a node lies half-way between two of them, so each station is recorded at
# both (x ∓ 0.0694 h) and their histories are averaged (linear interpolation
# to the node).  A rigid pair's slip rate over the step t^n → t^{n+1} and its
# slip after it hold at t^{n+½} and t^{n+1}: the file says so (each dataset's
# time_shift_s) and the reader's ``time_of`` gives those times (a run written
# before the files said so: dt/2 and dt added here, as they were).
#
# Run (both problems, h = 0.4, 0.2, 0.1, 0.05 mm, both kinds; about 30 CPU
# minutes, 1-2 h on 2 busy cores):
#
#     .venv/bin/python benchmarks/peer/score.py                                 # 2 ranks, tag "tree"
#     .venv/bin/python benchmarks/peer/score.py --ranks 1 --tag serial --note "fricfem as in this tree, on 1 rank"
#     .venv/bin/python benchmarks/peer/score.py --problems tpv205_2d --h 0.2e-3 0.1e-3 --kinds rigid
#
# Each run goes to ``runs/peer_score/<tag>/<problem>/<kind>_h<h>``; a complete
# run with its CPU record is reused unless ``--rerun``.  ``--pythonpath DIR
# --tag NAME --note TEXT`` scores a modified fricfem (another source tree)
# under its own tag, kept beside the others in the results.  Writes
# ``benchmarks/results/peer_score.{json,md}`` and ``peer_<problem>.png``
# (``report.py`` draws them from the JSON).

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_par  # noqa: E402  (the peer's inputs: the stations of each problem)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RESULTS = ROOT / "benchmarks" / "results"
PROBLEMS = ("tpv205_2d", "rsf_aging_2d", "rsf_slip_2d")
REFERENCE = "p8_h0.0625mm"
PEER_RUNS = ("h0.25mm", "h0.1mm", "h0.05mm", "p8_h0.125mm", "p8_h0.0625mm")
THRESHOLD = 1e-3  # m/s: rupture
T_R_MIN = 1e-6  # s: rupture times below this (the nucleation patch) are not scored
GAUSS_OFFSET = 0.5 * (1.0 - 0.8611363115940526)  # a node's distance to its nearest Gauss point, in cells


# --- the peer ----------------------------------------------------------------------------


def peer_summary(problem: str) -> dict:
    return json.loads((HERE / problem / "sem2dpack_summary.json").read_text())


def reference(problem: str) -> str:
    """The peer run a problem is scored against: its finest, REFERENCE, where the
    peer ran it, else the finest it has (rsf_slip_2d: README, problem (c))."""
    have = peer_summary(problem)["resolutions"]
    return next(lab for lab in (REFERENCE, "h0.05mm", "p8_h0.125mm") if lab in have)


def peer_metrics(problem: str, label: str) -> dict:
    """{x_mm: {t_r, v_peak, slip}} of one peer resolution (its summary), and its CPU seconds."""
    res = peer_summary(problem)["resolutions"][label]
    st = {int(s["x_mm"]): {"t_r": s["rupture_time_s"], "v_peak": s["peak_slip_rate_mps"],
                           "slip": s["final_slip_m"]} for s in res["stations"]}
    return {"stations": st, "cpu_s": res["cpu_s"], "end_s": res["end_time_s"]}


# --- metrics of one history --------------------------------------------------------------


def rupture_time(t: np.ndarray, v: np.ndarray, threshold: float = THRESHOLD, width: float = 0.0):
    """First time v > threshold, interpolated linearly between samples (None: never).
    ``width`` [s]: each sample is the mean over an interval this long centred on its
    time (the rigid kind's step rate: fricfem.analysis.rupture.step_width), so a
    crossing out of a zero sample starts where that sample's interval ends (the
    peer's samples are at instants: 0)."""
    k = np.flatnonzero(v > threshold)
    if not len(k):
        return None
    k = int(k[0])
    if k == 0:
        return float(t[0])
    t0 = t[k - 1] + 0.5 * width if v[k - 1] == 0.0 else t[k - 1]
    return float(t0 + (threshold - v[k - 1]) / (v[k] - v[k - 1]) * (t[k] - t0))


def station_metrics(t_v, v, t_s, slip, t_end: float, width: float = 0.0) -> dict:
    """Rupture time, peak slip rate and the slip at ``t_end`` (interpolated; the
    last value if the history ends before it); ``width``: :func:`rupture_time`."""
    return {"t_r": rupture_time(t_v, v, width=width), "v_peak": float(np.max(v)) if len(v) else 0.0,
            "slip": float(np.interp(min(t_end, t_s[-1]), t_s, slip))}


def run_metrics(rundir: Path, kind: str, stations_mm, t_end: float) -> dict:
    """{x_mm: metrics} of a fricfem run directory (module comment: where the stations sit)."""
    from fricfem.output.rundir import open_interface

    dt = json.loads((rundir / "summary.json").read_text())["dt_s"]
    rigid = kind == "rigid"
    with open_interface(rundir) as itf:
        st = itf.stations()
    out = {}
    for x in stations_mm:
        if rigid:
            s = st[f"x{x}mm"]
            t = s.time
            legacy = {} if s.shift else {"slip_rate": 0.5 * dt, "slip": dt}  # a file without time_shift_s
            out[x] = station_metrics(s.time_of("slip_rate") + legacy.get("slip_rate", 0.0), s.data["slip_rate"],
                                     s.time_of("slip") + legacy.get("slip", 0.0), s.data["slip"], t_end,
                                     width=dt)  # the rate of step t^n -> t^{n+1}: its mean
        else:
            a, b = st[f"x{x}mm_l"], st[f"x{x}mm_r"]
            n = min(len(a.time), len(b.time))
            v = 0.5 * (a.data["slip_rate"][:n] + b.data["slip_rate"][:n])
            slip = 0.5 * (a.data["slip"][:n] + b.data["slip"][:n])
            out[x] = station_metrics(a.time[:n], v, a.time[:n], slip, t_end)
    return out


def errors(metrics: dict, ref: dict) -> dict:
    """Per-station differences from the reference and the worst of each (module comment)."""
    rows, dt_us, dt_pct, dv, ds = [], [], [], [], []
    for x, r in sorted(ref.items()):
        m = metrics[x]
        row = {"x_mm": x, "t_r_s": m["t_r"], "t_r_ref_s": r["t_r"], "v_peak": m["v_peak"], "v_peak_ref": r["v_peak"],
               "slip_m": m["slip"], "slip_ref_m": r["slip"]}
        if r["t_r"] is not None and r["t_r"] > T_R_MIN:
            d = (m["t_r"] - r["t_r"]) if m["t_r"] is not None else np.inf
            row["dt_r_us"] = 1e6 * d
            dt_us.append(abs(1e6 * d))
            dt_pct.append(abs(100 * d / r["t_r"]))
        if r["v_peak"] > THRESHOLD:
            row["dv_peak_pct"] = 100 * (m["v_peak"] - r["v_peak"]) / r["v_peak"]
            row["dslip_pct"] = 100 * (m["slip"] - r["slip"]) / r["slip"]
            dv.append(abs(row["dv_peak_pct"]))
            ds.append(abs(row["dslip_pct"]))
        rows.append(row)
    return {"stations": rows, "t_r_us": max(dt_us), "t_r_pct": max(dt_pct), "v_peak_pct": max(dv),
            "slip_pct": max(ds), "t_r_rms_pct": float(np.sqrt(np.mean(np.square(dt_pct))))}


# --- running fricfem --------------------------------------------------------------------


def child(out: str, argv: list) -> None:
    """Under mpirun: ``fricfem`` with ``argv``, then each rank's CPU seconds (user +
    system, the whole process) summed into ``out`` by rank 0."""
    from mpi4py import MPI

    from fricfem.cli import main as fricfem_main

    status = 0
    try:
        status = fricfem_main(argv) or 0
    except SystemExit as err:
        status = err.code if isinstance(err.code, int) else 1
    ru = resource.getrusage(resource.RUSAGE_SELF)
    cpu = MPI.COMM_WORLD.gather(ru.ru_utime + ru.ru_stime, root=0)
    status = MPI.COMM_WORLD.allreduce(status, op=MPI.MAX)
    if MPI.COMM_WORLD.rank == 0:
        Path(out).write_text(json.dumps({"cpu_s": sum(cpu), "cpu_per_rank_s": cpu, "status": status}))
    sys.exit(status)


def load_results(path: Path) -> dict:
    """A results file merged run by run (``{"runs": {...}}``), or a new one."""
    return json.loads(path.read_text()) if path.exists() else {"runs": {}}


def save_results(path: Path, doc: dict, table) -> None:
    """Write ``doc`` (dated) to ``path`` and its table ``table(doc)`` beside it (.md)."""
    doc["date"] = time.strftime("%Y-%m-%d %H:%M")
    path.write_text(json.dumps(doc, indent=1, default=float))
    path.with_suffix(".md").write_text(table(doc))


def overrides(problem: str, kind: str, h: float, t_end=None) -> list:
    """--set items of one run: the band's cells, the kind and, for an elastic run,
    each station twice, at the Gauss points on either side of its node."""
    sets = [f"mesh.dx={h!r}", f"mesh.dy={h!r}", f"interface.kind='{kind}'", "output.diagnostics=false"]
    if kind == "elastic":
        d = GAUSS_OFFSET * h
        xs = make_par.GEOMETRY[problem][1]  # the peer's stations [mm]
        table = ", ".join(f'"x{x}mm_{s}" = {x * 1e-3 + sign * d!r}' for x in xs for s, sign in (("l", -1), ("r", 1)))
        sets.append(f"output.stations={{ {table} }}")
    if t_end is not None:
        sets.append(f"time.end={t_end!r}")
    return sets


def run_fricfem(problem: str, kind: str, h: float, rundir: Path, ranks: int, pythonpath: str | None,
                t_end=None, rerun: bool = False, extra=()) -> dict:
    """One run in its own mpirun (``extra``: more fricfem arguments, e.g. ``--set``
    items); returns its record (CPU, sizes, wall times)."""
    cpu_file = rundir / "cpu.json"
    summary_file = rundir / "summary.json"
    if not rerun and cpu_file.exists() and summary_file.exists():
        rec = json.loads(cpu_file.read_text())
        if rec.get("status") == 0 and json.loads(summary_file.read_text()).get("complete"):
            return _record(rec, summary_file)
    rundir.mkdir(parents=True, exist_ok=True)
    argv = ["run", problem, "--out", str(rundir), "--overwrite", "--quiet"]
    for s in overrides(problem, kind, h, t_end):
        argv += ["--set", s]
    argv += list(extra)
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OMPI_MCA_mpi_yield_when_idle": "1"}
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    cmd = ["mpirun", "-n", str(ranks), "-x", "OMP_NUM_THREADS"] + (["-x", "PYTHONPATH"] if pythonpath else []) \
        + [sys.executable, str(Path(__file__).resolve()), "--child", str(cpu_file), "--"] + argv
    for attempt in range(2):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
        rec = json.loads(cpu_file.read_text())
        rec["wall_s"] = time.perf_counter() - t0
        rec["load_avg"] = os.getloadavg()[0]
        summ = json.loads(summary_file.read_text())
        if summ["wall_s"]["first_step_incl_jit"] < 5.0:
            break  # a first step above 5 s compiled kernels (a cold cache): run again, warm
    cpu_file.write_text(json.dumps(rec))
    return _record(rec, summary_file)


def _record(rec: dict, summary_file: Path) -> dict:
    summ = json.loads(summary_file.read_text())
    return {"cpu_s": rec["cpu_s"], "cpu_per_rank_s": rec["cpu_per_rank_s"], "wall_s": rec.get("wall_s"),
            "load_avg": rec.get("load_avg"), "dofs": summ["dofs"], "steps": summ["steps"], "dt_s": summ["dt_s"],
            "ranks": summ["ranks"], "time_loop_wall_s": summ["wall_s"]["time_loop"],
            "points": summ["interface_points"]}


# --- the study ----------------------------------------------------------------------------


def peer_runs(problem: str) -> dict:
    """{label: peer_metrics} of every peer run of ``problem`` but its reference, in PEER_RUNS order."""
    label_ref = reference(problem)
    return {lab: peer_metrics(problem, lab) for lab in PEER_RUNS
            if lab in peer_summary(problem)["resolutions"] and lab != label_ref}


def stored_metrics(run: dict) -> dict:
    """{x_mm: metrics} of a run as stored in peer_score.json (its stations' rows)."""
    return {s["x_mm"]: {"t_r": s["t_r_s"], "v_peak": s["v_peak"], "slip": s["slip_m"]} for s in run["stations"]}


def _score_peer(problem: str, prob: dict) -> dict:
    """The reference of ``problem``'s entry ``prob`` and every other peer run's errors against it, set in
    ``prob``; returns the reference's metrics."""
    prob["reference"] = reference(problem)
    ref = peer_metrics(problem, prob["reference"])
    prob["peer"] = {label: {"cpu_s": p["cpu_s"], **errors(p["stations"], ref["stations"])}
                    for label, p in peer_runs(problem).items()}
    return ref


def score_problem(problem: str, args, doc: dict) -> None:
    prob = doc["problems"].setdefault(problem, {"peer": {}, "fricfem": {}})
    ref = _score_peer(problem, prob)
    xs = sorted(ref["stations"])
    runs = prob["fricfem"].setdefault(args.tag, {"note": args.note, "runs": {}})
    runs["note"] = args.note
    for kind in args.kinds:
        for h in args.h:
            key = f"{kind}_h{h * 1e3:g}mm"
            rundir = ROOT / "runs" / "peer_score" / args.tag / problem / key
            extra = []
            if args.degree > 1:  # spectral elements: the run sem_ladder.py makes at --safety (reused)
                import sem_ladder

                rundir = sem_ladder.rundir(ROOT / "runs" / "sem", problem, args.degree, h, args.uniform, args.safety)
                extra = sem_ladder.layout(args.degree, h, args.uniform, args.safety)
            print(f"{args.tag} {problem} {key} ...", flush=True)
            rec = run_fricfem(problem, kind, h, rundir, args.ranks, args.pythonpath, args.t_end, args.rerun, extra)
            err = errors(run_metrics(rundir, kind, xs, ref["end_s"]), ref["stations"])
            runs["runs"][key] = {"kind": kind, "h_m": h, **rec, **err}
            print(f"   cpu {rec['cpu_s']:.1f} s, t_r worst {err['t_r_us']:.3f} us ({err['t_r_pct']:.2f} %), "
                  f"V_peak {err['v_peak_pct']:.1f} %, slip {err['slip_pct']:.2f} %", flush=True)


def rescore(doc: dict) -> None:
    """Every stored fricfem run's and every peer run's errors again, against each
    problem's reference as it now is (the stations' own metrics are stored with
    each run, so nothing runs again; the peer's tables come from its summaries)."""
    for problem, prob in doc["problems"].items():
        ref = _score_peer(problem, prob)
        for series in prob["fricfem"].values():
            for run in series["runs"].values():
                run.update(errors(stored_metrics(run), ref["stations"]))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=PROBLEMS)
    ap.add_argument("--h", nargs="+", type=float, default=[0.4e-3, 0.2e-3, 0.1e-3, 0.05e-3],
                    help="band cell sizes [m]")
    ap.add_argument("--kinds", nargs="+", default=["rigid", "elastic"], choices=["rigid", "elastic"])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--degree", type=int, default=1,
                    help="mesh.degree (2-8: spectral elements, rigid kind; --h the element size)")
    ap.add_argument("--safety", type=float, default=0.9,
                    help="time.dt_safety of the spectral runs (sem_ladder.py makes 0.9 and 0.45)")
    ap.add_argument("--uniform", action="store_true",
                    help="spectral elements over the whole box at --h (sem_ladder.py --uniform)")
    ap.add_argument("--tag", default="tree", help="name of this fricfem (default: the tree's own)")
    ap.add_argument("--note", help="what this fricfem is (default: as in this tree, on N ranks)")
    ap.add_argument("--pythonpath", help="run fricfem from this source tree instead")
    ap.add_argument("--t-end", type=float, help="end time [s] (default: the scene's; shorter for quick looks)")
    ap.add_argument("--rerun", action="store_true")
    ap.add_argument("--out", default=str(RESULTS))
    ap.add_argument("--no-report", action="store_true")
    ap.add_argument("--rescore", action="store_true",
                    help="score every stored run again against the references as they now are (runs nothing)")
    args = ap.parse_args(argv)
    args.note = args.note or f"fricfem as in this tree, on {args.ranks} rank{'s' if args.ranks > 1 else ''}"
    out = Path(args.out)
    path = out / "peer_score.json"
    doc = json.loads(path.read_text()) if path.exists() else {"problems": {}}
    doc.update(reference=REFERENCE, threshold_m_s=THRESHOLD, t_r_min_s=T_R_MIN, machine=os.uname().nodename,
               date=time.strftime("%Y-%m-%d %H:%M"))
    if args.rescore:
        rescore(doc)
    for problem in [] if args.rescore else args.problems:
        score_problem(problem, args, doc)
        out.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(doc, indent=1, default=float))
    if args.rescore:
        path.write_text(json.dumps(doc, indent=1, default=float))
    if not args.no_report:
        import report

        report.write(doc, out)
    return doc


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[4:])
    sys.path.insert(0, str(HERE))
    main()
