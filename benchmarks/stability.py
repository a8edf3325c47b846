# # Stability stress test
#
# Does a fricfem run either reach its end time with finite results or stop
# with the watchdog's message — over the whole range of loadings, interface
# stiffnesses, time steps and friction integrators a user may set?  Five
# factors around the paper's Case I, on the coarse mesh to 40 µs:
#
# =========================  =======================================  ============
# factor                     levels                                   Case I
# =========================  =======================================  ============
# Σ0 (loading.sigma0)        0.1, 0.3, 1, 3, 6, 10, 30, 100 MPa       6 MPa
# V_imp (loading.v_imp)      0.5, 1, 2, 5, 10, 20, 50, 100 m/s        2 m/s
# k: C_n, C_s × k            0.01, 0.1, 1, 10, 100                    1
# time.dt_safety             0.5, 0.6, 0.7, 0.8, 0.9, 0.95            0.9
# friction.params.gamma γ    0, 0.25, 0.45, 0.5, 0.6, 0.75, 1         0.5
# =========================  =======================================  ============
#
# The design (duplicates merged, each point keeps the parts it belongs to):
#
# * ``corner``: the 2⁵ corners of the box;
# * ``ofat``: one factor at a time through every level, the others at Case I;
# * ``gamma_dt``: the full γ × dt_safety grid at three loadings that slide —
#   (6 MPa, 10 m/s), (30 MPa, 100 m/s), and (6 MPa, 20 m/s) with k = 100;
# * ``sigma_v``: the full Σ0 × V_imp grid at the default step and γ, for
#   k = 0.01, 1 and 100;
# * ``lhs``: a Latin hypercube on the levels (each factor's levels repeated
#   evenly and shuffled independently, fixed seed).
#
# γ below ½ is outside the law's range, so those points are *rejected* at
# validation (with the message), before any mesh is made.  Every other point
# runs to its end time or is stopped by the watchdog (``[watchdog]`` at its
# defaults), which stops only on divergence: non-finite values, a negative
# discrete kinetic energy, an energy budget that does not close.  A slip rate
# above c_l is reported in summary.json (``slip_rate_spike``), not stopped: the
# Povirk–Needleman point's slip rate is bounded over any finite time and such
# peaks are genuine at strong loading (docs/friction_reference.md §4).  The
# outcome of a point is one of
#
# * ``ok`` — complete, and every dataset of ``interface.h5`` and the energy of
#   ``summary.json`` finite (a run that completes with a non-finite value is
#   reported as ``error: silent non-finite ...``: there must be none);
# * ``watchdog: <message>`` — stopped, with the watchdog's message;
# * ``rejected: <message>`` — the scene's validation refused it;
# * ``error: <exception>`` — anything else.
#
# For contrast, ``unstable`` points run with a fixed ``time.dt`` of 1.05, 1.2
# and 1.5 × the stable step ``dt_crit`` (from ``run.build_model``) at four
# loadings: the watchdog must stop each and name the step as the cause.
#
# Interface snapshots are taken every step (``output.interface_every`` below
# the step), so the peak slip rate is the largest over every step.
#
# Run (parallel over points by fricfem's batch runner, :mod:`fricfem.batch`:
# each rank takes the next point, heaviest first, as it frees up; resumable —
# a point whose ``job.json`` holds a record of the same inputs is not run again)::
#
#     mpirun -n 2 .venv/bin/python benchmarks/stability.py
#
# writes ``benchmarks/results/stability.json``, ``stability.md`` and
# ``stability.png``; the run directories go to ``runs/stability/points/``.
# ``--smoke`` runs a handful of points to 10 µs (tests); ``--fresh`` ignores
# earlier records.

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import load_scene, open_run
from fricfem import batch, runner
from fricfem.model.build import build_model
from fricfem.observe import energy_scale
from fricfem.scene import SceneError

# the factors, the design and the shared constants (benchmarks/ is this script's
# directory, and on pytest's path)
from stability_design import (  # noqa: F401 (the study's names, in one place)
    BASE, CENTRE, DEFAULT, ENERGY_REL, ENERGY_TERMS, FACTORS, GAMMA_DT_LOADINGS, KINDS, LABELS, LEVELS,
    LHS_POINTS, LHS_SEED, PEAK_TOL, SIGMA_V_K, UNSTABLE_FACTORS, UNSTABLE_LOADINGS, design, expected_cost,
    growth_floor, hopf_floor, key_of, overrides)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


# ## One point
#
# The batch runner keeps the point's record in ``job.json`` next to the run's
# own files; it is removed before the point runs and written after it, so a
# killed point is rerun on resume.


def finite_check(rundir: Path) -> dict:
    """What the run directory says about the run's health, read through the public
    reader (:func:`fricfem.open_run`, valid rows only).

    ``nonfinite``: names of interface quantities, station histories and energy
    terms holding a non-finite value; ``peak``: the largest finite slip rate
    [m/s] (snapshots and stations); from the energy history (every
    ``output.energy_every`` steps), each row relative to its energy scale
    (:func:`fricfem.observe.energy_scale`, the watchdog's): ``kinetic_min_rel``,
    the smallest kinetic energy, and ``balance_rel``, the largest |balance
    error|; ``kinetic_min`` [J/m] and ``external_max`` [J/m]; ``tn_max`` [Pa],
    the largest normal traction, and ``open_fraction_max``, the largest share of
    interface points open at one time; ``ts_at_peak`` and ``tn_at_peak`` [Pa],
    |T_s| and T_n where and when the snapshots' slip rate peaks.
    """
    run = open_run(rundir)
    bad = [name for name in run.names if not np.isfinite(run.quantity(name)).all()]
    bad += [f"stations/{n}/{k}" for n, st in run.stations.items() for k, v in st.items()
            if k != "x1" and not np.isfinite(v).all()]
    bad += [f"energy/{k}" for k, v in run.energy.items() if not np.isfinite(v).all()]
    finite = [run.quantity("slip_rate")] + [st["slip_rate"] for st in run.stations.values() if "slip_rate" in st]
    peak = max((float(x[np.isfinite(x)].max(initial=0.0)) for x in finite), default=0.0)
    e = {k: run.energy[k] for k in ENERGY_TERMS}
    tn, opened = run.quantity("normal_traction"), run.quantity("open")
    rate = np.where(np.isfinite(run.quantity("slip_rate")), run.quantity("slip_rate"), -1.0)
    ts_at_peak = tn_at_peak = 0.0
    if rate.size and rate.max() > 0.0:
        i, q = np.unravel_index(np.argmax(rate), rate.shape)
        ts_at_peak = abs(float(run.quantity("shear_traction")[i, q]))
        tn_at_peak = float(tn[i, q])
    with np.errstate(invalid="ignore"):
        scale = np.array([energy_scale({k: e[k][j] for k in ENERGY_TERMS}) for j in range(len(e["time"]))])
        return {
            "nonfinite": bad, "peak": peak,
            "kinetic_min": float(np.nanmin(e["kinetic"], initial=0.0)),
            "kinetic_min_rel": float(np.nanmin(e["kinetic"] / scale, initial=0.0)),
            "external_max": float(np.nanmax(np.abs(e["external"]), initial=0.0)),
            "balance_rel": float(np.nanmax(np.abs(e["balance_error"]) / scale, initial=0.0)),
            "tn_max": float(np.nanmax(tn, initial=0.0)),
            "open_fraction_max": float(opened.mean(axis=1).max(initial=0.0)) if opened.size else 0.0,
            "ts_at_peak": ts_at_peak, "tn_at_peak": tn_at_peak,
        }


def silent_divergence(health: dict) -> str:
    """'' when the energy history looks sound, else what is wrong."""
    if health["kinetic_min_rel"] < -ENERGY_REL:
        return (f"kinetic energy {health['kinetic_min_rel']:.3g} × the energy scale in the energy history")
    if health["balance_rel"] > ENERGY_REL:
        return f"energy balance error {health['balance_rel']:.3g} × the energy scale"
    return ""


def _energy_finite(summary: dict) -> bool:
    e = summary.get("energy") or {}
    return all(math.isfinite(v) for v in e.values() if isinstance(v, (int, float)))


def run_point(pt: dict, work: Path, t_end: float, comm=MPI.COMM_SELF) -> dict:
    """Run one point on ``comm`` (a batch group's); its record (outcome, peak slip rate, steps, wall)."""
    key = key_of(pt)
    d = work / "points" / key
    base = load_scene(BASE)
    items = overrides(pt, t_end, base.Cn, base.Cs)
    rec = {"key": key, **{f: pt[f] for f in FACTORS}, "dt_factor": pt.get("dt_factor"),
           "parts": pt["parts"], "t_end_s": t_end, "peak_slip_rate_m_s": None, "steps": None,
           "t_stop_s": None, "dt_s": None, "dt_crit_s": None, "wall_s": None, "mode": None}
    t0 = time.perf_counter()
    try:
        scene = load_scene(BASE, items)
    except SceneError as err:
        return rec | {"outcome": f"rejected: {err}", "kind": "rejected", "wall_s": time.perf_counter() - t0}
    d.mkdir(parents=True, exist_ok=True)
    try:
        if pt.get("dt_factor"):
            _, model = build_model(scene, comm)
            rec["dt_crit_s"] = model.dt_crit
            scene = load_scene(BASE, items + [f"time.dt={pt['dt_factor'] * model.dt_crit!r}", "time.allow_unstable_dt=true"])
            del model
        summary = runner.run_scene(scene, d, comm, overwrite=True, quiet=True)
        rec.update(steps=summary["steps"], t_stop_s=summary["t_s"], dt_s=summary["dt_s"],
                   dt_crit_s=summary["dt_crit_s"], mode=(summary.get("mode") or {}).get("label"),
                   run_wall_s=summary["wall_s"]["total"])
        health = finite_check(d)
        bad = health["nonfinite"]
        rec.update(peak_slip_rate_m_s=health["peak"], nonfinite_datasets=bad,
                   kinetic_min_J_m=health["kinetic_min"], kinetic_min_rel=health["kinetic_min_rel"],
                   external_max_J_m=health["external_max"],
                   balance_rel=health["balance_rel"], tn_max_Pa=health["tn_max"],
                   open_fraction_max=health["open_fraction_max"], ts_at_peak_Pa=health["ts_at_peak"],
                   tn_at_peak_Pa=health["tn_at_peak"], slip_rate_spike=summary.get("slip_rate_spike"))
        silent = silent_divergence(health)
        if summary.get("interrupted"):
            rec.update(outcome="error: interrupted (SIGTERM)", kind="error")
        elif summary.get("watchdog"):
            rec.update(outcome=f"watchdog: {summary['watchdog']}", kind="watchdog")
        elif not summary.get("complete"):
            rec.update(outcome="error: run incomplete without a watchdog message", kind="error")
        elif bad or not _energy_finite(summary):
            what = ", ".join(bad) or "summary.json energy"
            rec.update(outcome=f"error: silent non-finite values in a complete run ({what})", kind="error")
        elif silent:
            rec.update(outcome=f"error: silent divergence in a complete run ({silent})", kind="error")
        else:
            rec.update(outcome="ok", kind="ok")
        if summary.get("diagnostics_error"):
            rec["diagnostics_error"] = summary["diagnostics_error"]
    except Exception as err:  # one failing point must not stop the study (nor leave ranks waiting)
        rec.update(outcome=f"error: {type(err).__name__}: {err}", kind="error")
    rec["wall_s"] = time.perf_counter() - t0
    return rec


def _settled(rec: dict) -> bool:
    """Whether a point's record is kept for the next call (``job.json``): not a rejected
    scene (checked again, cheaply) nor a run interrupted by SIGTERM."""
    return rec["kind"] != "rejected" and rec["outcome"] != "error: interrupted (SIGTERM)"


#: Bumped whenever a record's fields change, so older records are recomputed.
RECORD_VERSION = 4


def _identity(pt: dict, t_end: float) -> dict:
    return {**{f: pt[f] for f in FACTORS}, "dt_factor": pt.get("dt_factor"), "t_end_s": t_end,
            "version": RECORD_VERSION}


def job_of(pt: dict, work: Path, t_end: float) -> batch.Job:
    """The point as a job of the batch runner: its run directory, cost and identity (its
    factors, the end time and :data:`RECORD_VERSION`; the scene is loaded when it runs)."""
    return batch.Job(key_of(pt), work / "points" / key_of(pt), None, expected_cost(pt), _identity(pt, t_end))


def stored(pt: dict, work: Path, t_end: float) -> dict | None:
    """The point's earlier record (its ``job.json``) if it was computed with the same inputs."""
    job = job_of(pt, work, t_end)
    s = batch.stored(job)
    if s is None or not batch.same_identity(s.get("identity"), job.ident()) or not isinstance(s.get("record"), dict):
        return None
    return s["record"] | {"parts": pt["parts"]}


# ## Summaries
#
# Counts per factor level (design points; the unstable contrast apart), the
# γ × dt_safety cells per loading, the Σ0 × V_imp maps, the slip-rate spikes
# above c_l against the spring–slider's thresholds, and the unstable contrast
# against the same loading at the default step.

def counts(records: list) -> dict:
    out = {k: 0 for k in KINDS}
    for r in records:
        out[r["kind"]] += 1
    return out


def per_level(records: list) -> dict:
    return {f: {f"{lv:g}": counts([r for r in records if r[f] == lv]) for lv in LEVELS[f]} for f in FACTORS}


def gamma_dt(by_key: dict, c_l: float) -> dict:
    """Per γ × dt loading: every accepted cell, the default cell, whether the loading
    spikes (a peak slip rate above c_l, whose size depends on where the fast slip
    events fall in the steps); and the cells that agree with the default at every
    loading that does not spike (the stable region)."""
    accepted = sorted({r["gamma"] for r in by_key.values() if "gamma_dt" in r["parts"] and r["kind"] != "rejected"})
    loadings = []
    for s, v, k in GAMMA_DT_LOADINGS:
        cells = {}
        for g in LEVELS["gamma"]:
            for d in LEVELS["dt_safety"]:
                r = by_key.get(key_of({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, "dt_safety": d, "gamma": g}))
                if r is not None:
                    cells[f"{g:g}/{d:g}"] = {"gamma": g, "dt_safety": d, "kind": r["kind"],
                                             "peak": r["peak_slip_rate_m_s"], "mode": r["mode"]}
        ref = cells.get(f"{DEFAULT['gamma']:g}/{DEFAULT['dt_safety']:g}")
        peaks = [c["peak"] for c in cells.values() if c["peak"] is not None]
        if not peaks:  # not in this design (--smoke)
            continue
        loadings.append({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, "cells": cells, "default": ref,
                         "spikes": bool(peaks) and max(peaks) > c_l,
                         "peak_range": [min(peaks), max(peaks)] if peaks else None,
                         "counts": counts([{"kind": c["kind"]} for c in cells.values()])})
    region = []
    for g in accepted:
        for d in LEVELS["dt_safety"]:
            good = True
            for ld in loadings:
                c, ref = ld["cells"].get(f"{g:g}/{d:g}"), ld["default"]
                if ld["spikes"] or c is None or ref is None:
                    continue
                good &= (c["kind"] == "ok" and c["mode"] == ref["mode"]
                         and abs(c["peak"] - ref["peak"]) <= PEAK_TOL * max(ref["peak"], 1e-9))
            if good:
                region.append([g, d])
    return {"loadings": loadings, "accepted_gamma": accepted, "stable_cells": region,
            "rejected_gamma": sorted({r["gamma"] for r in by_key.values() if r["kind"] == "rejected"}),
            "peak_tol": PEAK_TOL}


def spikes(records: list, c_l: float) -> dict:
    """Runs (ok or watchdog) whose peak slip rate exceeds c_l, against the spring–slider's
    thresholds (docs/friction_reference.md §4): the slip rate of a sliding point grows
    only while |T_s| > C_s L0/(B κ(θ0)) ≥ m L0 C_s/B, and stops growing once θ0 has
    decayed to about L0/v, so a spike is bounded; steady sliding turns to stick–slip
    above T_n,c(v) ≥ e C_s L0/(B (μs − μd) p).  Also: whether summary.json's
    ``slip_rate_spike`` reports each (its peak, taken every step, against the snapshots')."""
    fast = [r for r in records if r["kind"] in ("ok", "watchdog") and (r["peak_slip_rate_m_s"] or 0) > c_l]
    ts_above = [r for r in fast if (r.get("ts_at_peak_Pa") or 0) > growth_floor(r["k"])]
    tn_above = [r for r in fast if (r.get("tn_at_peak_Pa") or 0) > hopf_floor(r["k"])]
    reported = [r for r in fast if (r.get("slip_rate_spike") or {}).get("above_threshold")
                and r["slip_rate_spike"]["peak_m_s"] >= r["peak_slip_rate_m_s"]]
    peaks = [r["peak_slip_rate_m_s"] for r in fast]
    return {"c_l_m_s": c_l, "count": len(fast), "ok": sum(r["kind"] == "ok" for r in fast),
            "watchdog": sum(r["kind"] == "watchdog" for r in fast), "reported": len(reported),
            "peak_range_m_s": [min(peaks), max(peaks)] if peaks else None,
            "ts_above_growth_floor": len(ts_above), "tn_above_hopf_floor": len(tn_above),
            "keys": [r["key"] for r in fast],
            "growth_floor_Pa": {f"{k:g}": growth_floor(k) for k in LEVELS["k"]},
            "hopf_floor_Pa": {f"{k:g}": hopf_floor(k) for k in LEVELS["k"]},
            "k_of_spikes": {f"{k:g}": sum(r["k"] == k for r in fast) for k in LEVELS["k"]}}


def changed(old: dict, records: list, source: str) -> dict:
    """Against an earlier results document: its counts, and every point whose outcome
    kind or mode label differs (with its peak slip rate then and now)."""
    before = {r["key"]: r for r in old["points"]}
    rows = [{"key": r["key"], "before": f"{b['kind']}/{b['mode'] or '–'}", "now": f"{r['kind']}/{r['mode'] or '–'}",
             "peak_before": b["peak_slip_rate_m_s"], "peak_now": r["peak_slip_rate_m_s"]}
            for r in records if (b := before.get(r["key"])) and (b["kind"], b["mode"]) != (r["kind"], r["mode"])]
    return {"against": source, "finished_before": old.get("finished"), "counts_before": old["counts"],
            "unstable_counts_before": old["unstable_counts"], "points": rows}


def contrast(records: list, by_key: dict) -> list:
    """Each unstable point against the same loading at the default step and γ."""
    out = []
    for r in records:
        if not r.get("dt_factor"):
            continue
        ref = by_key.get(key_of({f: r[f] for f in ("sigma0_MPa", "v_imp_m_s", "k")} | DEFAULT)) or {}
        stopped = r["kind"] == "watchdog" and "× the stable step" in r["outcome"]
        out.append({"key": r["key"], "dt_factor": r["dt_factor"], "stopped_naming_step": stopped,
                    "kind": r["kind"], "reference": ref.get("key"), "reference_kind": ref.get("kind"),
                    "peak": r["peak_slip_rate_m_s"], "reference_peak": ref.get("peak_slip_rate_m_s"),
                    "tn_max": r.get("tn_max_Pa"), "reference_tn_max": ref.get("tn_max_Pa"),
                    "open_fraction_max": r.get("open_fraction_max"),
                    "reference_open_fraction_max": ref.get("open_fraction_max"),
                    "mode": r["mode"], "reference_mode": ref.get("mode")})
    return out


# ## Outputs: benchmarks/stability_report.py (stability.md, stability.png)


# ## Driver


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    """Run (or resume) the study (collective); the results document on every rank."""
    ap = argparse.ArgumentParser(description="fricfem stability stress test (coarse mesh, parallel over points)")
    ap.add_argument("--out", type=Path, default=HERE / "results", help="directory of stability.json/.md/.png")
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "stability", help="run directories")
    ap.add_argument("--t-end", type=float, default=40e-6, help="end time [s]")
    ap.add_argument("--smoke", action="store_true", help="five points to 10 µs (tests)")
    ap.add_argument("--fresh", action="store_true", help="ignore earlier point records")
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    ap.add_argument("--compare", type=Path, help="an earlier stability.json: list the points whose outcome or "
                                                 "mode changed")
    args = ap.parse_args(argv)
    t_end = 10e-6 if args.smoke else args.t_end
    t0 = time.perf_counter()

    todo = reused = None
    points = {key_of(pt): pt for pt in design(args.smoke)}
    if comm.rank == 0:
        reused = {}
        todo = []
        for key, pt in points.items():
            rec = None if args.fresh else stored(pt, args.work, t_end)
            if rec is not None:
                reused[key] = rec
            else:
                todo.append(job_of(pt, args.work, t_end))
        if not args.quiet:
            print(f"stability: {len(points)} points, {len(reused)} reused, {len(todo)} to run on "
                  f"{comm.size} rank(s)", file=sys.stderr, flush=True)
    todo = comm.bcast(todo, root=0)
    log = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    results = batch.run_jobs(todo, comm, work=lambda job, c: run_point(points[job.key], args.work, t_end, c),
                             log=log, finished=_settled)
    gathered = None
    if comm.rank == 0:  # a point whose work raised past run_point's own guard: an error record
        gathered = [[r.record or {"key": r.key, **{f: points[r.key][f] for f in FACTORS},
                                  "dt_factor": points[r.key].get("dt_factor"), "parts": points[r.key]["parts"],
                                  "t_end_s": t_end, "outcome": f"error: {r.error}", "kind": "error",
                                  "wall_s": r.wall_s, "peak_slip_rate_m_s": None, "mode": None}
                     for r in results]]

    doc = failure = None
    if comm.rank == 0:
        try:
            doc = _write(args, gathered, reused, t_end, comm.size, t0)
        except Exception as err:  # say so on every rank rather than leave them waiting
            failure = f"writing the results failed: {type(err).__name__}: {err}"
            raise
        finally:
            comm.bcast(failure, root=0)
    elif comm.bcast(None, root=0):
        raise RuntimeError("rank 0 failed to write the results")
    return comm.bcast(doc, root=0)


def _write(args, gathered, reused, t_end, ranks, t0) -> dict:
    """Rank 0: assemble, write stability.json/.md/.png, print the counts."""
    import stability_report as report  # benchmarks/ is this script's directory (and on pytest's path)

    new = {r["key"]: r for part in gathered for r in part}
    order = [key_of(p) for p in design(args.smoke)]
    records = [new.get(k) or reused[k] for k in order]
    by_key = {r["key"]: r for r in records}
    design_recs = [r for r in records if not r.get("dt_factor")]
    unstable = [r for r in records if r.get("dt_factor")]
    base = load_scene(BASE)
    c_l = base.material.speeds()["c_l"]
    ok = [r for r in records if r["kind"] == "ok"]
    ran = [r for r in new.values() if r["kind"] != "rejected"]
    try:  # keep the record of earlier calls: a resumed study's own wall time is small
        before = json.loads((args.out / "stability.json").read_text())
        calls = before.get("calls", []) if before.get("t_end_s") == t_end and before.get("smoke") == args.smoke else []
    except (FileNotFoundError, json.JSONDecodeError):
        calls = []
    if ran or not calls:  # a call that only re-reads the records adds no line
        calls.append({"finished": time.strftime("%Y-%m-%d %H:%M"), "ranks": ranks, "wall_s": time.perf_counter() - t0,
                      "runs": len(ran), "run_wall_sum_s": sum(r["wall_s"] or 0.0 for r in ran),
                      "load_avg": os.getloadavg()[0] if hasattr(os, "getloadavg") else None})
    doc = {
        "study": "stability stress test", "base": BASE, "preset": "coarse", "t_end_s": t_end,
        "smoke": args.smoke, "ranks": ranks, "finished": time.strftime("%Y-%m-%d %H:%M"),
        "wall_s": time.perf_counter() - t0, "computed": len(ran), "reused": len(records) - len(new),
        "calls": calls, "point_wall_sum_s": sum(r["wall_s"] or 0.0 for r in records),
        "levels": {f: list(v) for f, v in LEVELS.items()}, "centre": CENTRE, "defaults": DEFAULT,
        "gamma_dt_loadings": [list(x) for x in GAMMA_DT_LOADINGS], "sigma_v_k": list(SIGMA_V_K),
        "lhs": {"points": LHS_POINTS, "seed": LHS_SEED},
        "unstable_factors": list(UNSTABLE_FACTORS), "unstable_loadings": [list(x) for x in UNSTABLE_LOADINGS],
        "spike_threshold_m_s": base.watchdog.max_slip_rate,  # resolved by the scene: 0 written is c_l
        "counts": counts(design_recs), "unstable_counts": counts(unstable),
        "per_level": per_level(design_recs),
        "gamma_dt": gamma_dt(by_key, c_l),
        "rejection_message": next((r["outcome"].partition(": ")[2] for r in records if r["kind"] == "rejected"), ""),
        "spikes": spikes(design_recs, c_l),
        "contrast": contrast(records, by_key),
        "silent_nonfinite": [r["key"] for r in records if r["outcome"].startswith("error: silent non-finite")],
        "silent_divergence": [r["key"] for r in records if r["outcome"].startswith("error: silent divergence")],
        "energy_calibration": {
            "balance_rel_max_ok": max((r["balance_rel"] for r in ok), default=0.0),
            "kinetic_min_ok": min((r["kinetic_min_J_m"] for r in ok), default=0.0),
            "kinetic_min_rel_ok": min((r["kinetic_min_rel"] for r in ok), default=0.0),
            "energy_rel_bound": ENERGY_REL},
        "machine": {"node": platform.node(), "python": sys.version.split()[0]},
        "points": records,
    }
    doc["unstable_all_stopped_by_watchdog"] = all(c["stopped_naming_step"] for c in doc["contrast"])
    if args.compare:
        doc["changed"] = changed(json.loads(args.compare.read_text()), records, str(args.compare))
    doc["stable_text"] = report.stable_text(doc)
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = args.out / "stability.json.tmp"
    tmp.write_text(json.dumps(doc, indent=1, allow_nan=False))
    tmp.replace(args.out / "stability.json")
    (args.out / "stability.md").write_text(report.markdown(doc))
    report.figure(doc, args.out / "stability.png")
    c, u = doc["counts"], doc["unstable_counts"]
    print(f"design points: {sum(c.values())}  " + "  ".join(f"{k} {c[k]}" for k in KINDS))
    print(f"unstable contrast: {sum(u.values())}  " + "  ".join(f"{k} {u[k]}" for k in KINDS)
          + f"  (all stopped by the watchdog naming the step: {doc['unstable_all_stopped_by_watchdog']})")
    print(doc["stable_text"])
    print(f"wall {doc['wall_s']:.0f} s on {ranks} rank(s); {args.out / 'stability.md'}")
    return doc


if __name__ == "__main__":
    main()
