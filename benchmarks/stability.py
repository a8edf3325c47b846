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
# defaults).  The outcome of a point is one of
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
# Run (parallel over points: each rank runs its share on ``MPI.COMM_SELF``;
# resumable — a point whose ``record.json`` matches is not run again)::
#
#     mpirun -n 2 .venv/bin/python benchmarks/stability.py
#
# writes ``benchmarks/results/stability.json``, ``stability.md`` and
# ``stability.png``; the run directories go to ``runs/stability/points/``.
# ``--smoke`` runs a handful of points to 10 µs (tests); ``--fresh`` ignores
# earlier records.

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import random
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import load_scene
from fricfem import runner
from fricfem.model.build import build_model
from fricfem.scene import SceneError

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BASE = "case1"

# ## The factors
#
# Levels per factor and the Case I centre.  ``k`` scales both interface
# stiffnesses of the base scene (C_n = 0.3 MPa/µm, C_s = 0.1 MPa/µm).

LEVELS = {
    "sigma0_MPa": (0.1, 0.3, 1.0, 3.0, 6.0, 10.0, 30.0, 100.0),
    "v_imp_m_s": (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0),
    "k": (0.01, 0.1, 1.0, 10.0, 100.0),
    "dt_safety": (0.5, 0.6, 0.7, 0.8, 0.9, 0.95),
    "gamma": (0.0, 0.25, 0.45, 0.5, 0.6, 0.75, 1.0),
}
FACTORS = tuple(LEVELS)
CENTRE = {"sigma0_MPa": 6.0, "v_imp_m_s": 2.0, "k": 1.0, "dt_safety": 0.9, "gamma": 0.5}
DEFAULT = {"dt_safety": 0.9, "gamma": 0.5}  # fricfem's defaults (time.dt_safety, friction.params.gamma)
LABELS = {"sigma0_MPa": "Σ0 [MPa]", "v_imp_m_s": "V_imp [m/s]", "k": "C_n, C_s × k",
          "dt_safety": "dt_safety", "gamma": "γ"}

#: Loadings (Σ0 MPa, V_imp m/s, k) of the full γ × dt grid: all slide by 40 µs.
GAMMA_DT_LOADINGS = ((6.0, 10.0, 1.0), (30.0, 100.0, 1.0), (6.0, 20.0, 100.0))
#: Stiffness factors of the full Σ0 × V_imp grids.
SIGMA_V_K = (0.01, 1.0, 100.0)
#: Unstable contrast: time.dt = factor × dt_crit at these loadings (Σ0 MPa, V_imp m/s, k).
UNSTABLE_FACTORS = (1.05, 1.2, 1.5)
UNSTABLE_LOADINGS = ((6.0, 2.0, 1.0), (6.0, 10.0, 1.0), (30.0, 100.0, 1.0), (6.0, 20.0, 100.0))
LHS_POINTS = 40
LHS_SEED = 20240603

KINDS = ("ok", "watchdog", "rejected", "error")


def key_of(pt: dict) -> str:
    """Directory-safe name of a point: s<Σ0>_v<V>_k<k>_d<dt_safety>_g<γ> or ..._dt<f>x."""
    head = f"s{pt['sigma0_MPa']:g}_v{pt['v_imp_m_s']:g}_k{pt['k']:g}"
    if pt.get("dt_factor"):
        return f"{head}_dt{pt['dt_factor']:g}x"
    return f"{head}_d{pt['dt_safety']:g}_g{pt['gamma']:g}"


# ## The design


def design(smoke: bool = False) -> list:
    """Every point: {factor: level, ..., "parts": [...]} (unstable ones carry ``dt_factor``)."""
    points = {}

    def add(part, **pt):
        pt = {f: float(pt[f]) for f in FACTORS} | ({"dt_factor": float(pt["dt_factor"])}
                                                   if pt.get("dt_factor") else {})
        points.setdefault(key_of(pt), pt | {"parts": []})["parts"].append(part)

    if smoke:
        add("ofat", **CENTRE)
        add("corner", sigma0_MPa=100.0, v_imp_m_s=100.0, k=100.0, dt_safety=0.95, gamma=1.0)
        add("corner", sigma0_MPa=0.1, v_imp_m_s=100.0, k=0.01, dt_safety=0.5, gamma=0.5)
        add("ofat", **(CENTRE | {"gamma": 0.25}))
        add("unstable", **CENTRE, dt_factor=1.5)
        return list(points.values())

    lo_hi = {f: (LEVELS[f][0], LEVELS[f][-1]) for f in FACTORS}
    for corner in range(2 ** len(FACTORS)):
        add("corner", **{f: lo_hi[f][(corner >> i) & 1] for i, f in enumerate(FACTORS)})
    for f in FACTORS:
        for level in LEVELS[f]:
            add("ofat", **(CENTRE | {f: level}))
    for s, v, k in GAMMA_DT_LOADINGS:
        for g in LEVELS["gamma"]:
            for d in LEVELS["dt_safety"]:
                add("gamma_dt", sigma0_MPa=s, v_imp_m_s=v, k=k, dt_safety=d, gamma=g)
    for k in SIGMA_V_K:
        for s in LEVELS["sigma0_MPa"]:
            for v in LEVELS["v_imp_m_s"]:
                add("sigma_v", sigma0_MPa=s, v_imp_m_s=v, k=k, **DEFAULT)
    rng = random.Random(LHS_SEED)
    columns = {}
    for f in FACTORS:
        col = [LEVELS[f][i % len(LEVELS[f])] for i in range(LHS_POINTS)]
        rng.shuffle(col)
        columns[f] = col
    for i in range(LHS_POINTS):
        add("lhs", **{f: columns[f][i] for f in FACTORS})
    for s, v, k in UNSTABLE_LOADINGS:
        for fac in UNSTABLE_FACTORS:
            add("unstable", sigma0_MPa=s, v_imp_m_s=v, k=k, **DEFAULT, dt_factor=fac)
    return list(points.values())


def overrides(pt: dict, t_end: float, base_cn: float, base_cs: float) -> list:
    """``--set`` items turning Case I into the point's scene (no ``time.dt``: see :func:`run_point`)."""
    cn = float(f"{base_cn * pt['k']:.12g}")
    cs = float(f"{base_cs * pt['k']:.12g}")
    return [
        "mesh.preset='coarse'",
        "output.fields=[]",
        "output.interface_every=1e-9",  # below any step: a snapshot every step
        f"time.end={t_end!r}",
        f"loading.sigma0={round(pt['sigma0_MPa'] * 1e6, 3)!r}",
        f"loading.v_imp={pt['v_imp_m_s']!r}",
        f"interface.Cn={cn!r}",
        f"interface.Cs={cs!r}",
        f"time.dt_safety={pt['dt_safety']!r}",
        f"friction.params.gamma={pt['gamma']!r}",
        f"name={json.dumps('stability_' + key_of(pt))}",
    ]


def expected_cost(pt: dict) -> float:
    """Relative cost, to deal the heavy points first: steps ∝ 1/dt (the interface
    springs shorten the step from k ≈ 10 on), sub-steps grow with V_imp."""
    return (1.0 + math.sqrt(pt["k"] / 10.0)) / pt["dt_safety"] * (1.0 + pt["v_imp_m_s"] / 20.0)


# ## One point
#
# The run directory keeps ``record.json`` next to the run's own files; it is
# removed before the point runs and written after it, so a killed point is
# rerun on resume.


def finite_check(h5path: Path) -> dict:
    """What ``interface.h5`` says about the run's health.

    ``nonfinite``: names of datasets holding a non-finite value (every float
    dataset, read up to its valid rows: ``n_time`` for snapshots, ``n`` per
    station); ``peak``: the largest finite slip rate [m/s] (snapshots and
    stations); from the energy history (every ``output.energy_every`` steps):
    ``kinetic_min`` [J/m], the smallest kinetic energy, and ``balance_rel``,
    the largest |balance error| over the largest |external work| (t > 0); ``tn_max``
    [Pa], the largest normal traction, and ``open_fraction_max``, the largest
    share of interface points open at one time; ``ts_at_peak`` [Pa], |T_s|
    where and when the snapshots' slip rate peaks.
    """
    import h5py

    bad = []
    peak = 0.0
    with h5py.File(h5path, "r") as f:
        n_time = int(f.attrs.get("n_time", f["time"].shape[0]))

        def visit(name, obj):
            nonlocal peak
            if not isinstance(obj, h5py.Dataset) or obj.dtype.kind != "f":
                return
            if name.startswith("stations/"):
                data = obj[: int(obj.parent.attrs["n"])]
            elif name == "time" or obj.ndim == 2:
                data = obj[:n_time]
            else:  # x1, energy/* (written to their length)
                data = obj[...]
            if not np.isfinite(data).all():
                bad.append(name)
            if name.split("/")[-1] == "slip_rate":
                fin = data[np.isfinite(data)]
                if fin.size:
                    peak = max(peak, float(fin.max()))

        f.visititems(visit)
        e = {k: f["energy"][k][...] for k in ("time", "kinetic", "external", "balance_error")}
        tn = f["normal_traction"][:n_time]
        opened = f["open"][:n_time]
        rate = np.where(np.isfinite(f["slip_rate"][:n_time]), f["slip_rate"][:n_time], -1.0)
        ts_at_peak = 0.0
        if rate.size and rate.max() > 0.0:
            i, q = np.unravel_index(np.argmax(rate), rate.shape)
            ts_at_peak = abs(float(f["shear_traction"][i, q]))
    # The row at t = 0 holds the first step's external work against zero kinetic and
    # strain energy (external work is summed after the step's update): leave it out.
    later = e["time"] > 0.0
    e = {k: v[later] for k, v in e.items()}
    with np.errstate(invalid="ignore"):
        ext = float(np.nanmax(np.abs(e["external"]), initial=0.0))
        health = {
            "nonfinite": bad, "peak": peak,
            "kinetic_min": float(np.nanmin(e["kinetic"], initial=0.0)),
            "external_max": ext,
            "balance_rel": float(np.nanmax(np.abs(e["balance_error"]), initial=0.0)) / max(ext, 1e-12),
            "tn_max": float(np.nanmax(tn, initial=0.0)),
            "open_fraction_max": float(opened.mean(axis=1).max(initial=0.0)) if opened.size else 0.0,
            "ts_at_peak": ts_at_peak,
        }
    return health


#: An energy history that a sound explicit run cannot have: a negative kinetic
#: energy (the staggered ½ m v^{n-½}·v^{n+½} turns negative when v alternates
#: in sign from step to step, the signature of a step beyond the stable one),
#: or a balance error of the order of the input work.
KINETIC_NEG_REL = 1e-3
BALANCE_REL_MAX = 0.5


def silent_divergence(health: dict) -> str:
    """'' when the energy history looks sound, else what is wrong."""
    scale = max(health["external_max"], 1e-12)
    if health["kinetic_min"] < -KINETIC_NEG_REL * scale:
        return (f"kinetic energy {health['kinetic_min']:.3g} J/m < 0 in the energy history, "
                f"external work up to {health['external_max']:.3g} J/m")
    if health["balance_rel"] > BALANCE_REL_MAX:
        return f"energy balance error {health['balance_rel']:.3g} × the external work"
    return ""


def _energy_finite(summary: dict) -> bool:
    e = summary.get("energy") or {}
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in e.values())


def run_point(pt: dict, work: Path, t_end: float) -> dict:
    """Run one point on ``MPI.COMM_SELF``; its record (outcome, peak slip rate, steps, wall)."""
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
    (d / "record.json").unlink(missing_ok=True)
    try:
        if pt.get("dt_factor"):
            _, model = build_model(scene, MPI.COMM_SELF)
            rec["dt_crit_s"] = model.dt_crit
            scene = load_scene(BASE, items + [f"time.dt={pt['dt_factor'] * model.dt_crit!r}", "time.allow_unstable_dt=true"])
            del model
        summary = runner.run_scene(scene, d, MPI.COMM_SELF, overwrite=True, quiet=True)
        rec.update(steps=summary["steps"], t_stop_s=summary["t_s"], dt_s=summary["dt_s"],
                   dt_crit_s=summary["dt_crit_s"], mode=(summary.get("mode") or {}).get("label"),
                   run_wall_s=summary["wall_s"]["total"])
        health = finite_check(d / "interface.h5")
        bad = health["nonfinite"]
        rec.update(peak_slip_rate_m_s=health["peak"], nonfinite_datasets=bad,
                   kinetic_min_J_m=health["kinetic_min"], external_max_J_m=health["external_max"],
                   balance_rel=health["balance_rel"], tn_max_Pa=health["tn_max"],
                   open_fraction_max=health["open_fraction_max"], ts_at_peak_Pa=health["ts_at_peak"])
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
    # runs on COMM_SELF leave PETSc objects to the garbage collector: free them now
    gc.collect()
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None and hasattr(petsc, "garbage_cleanup"):
        petsc.garbage_cleanup(MPI.COMM_SELF)
    if rec["outcome"] != "error: interrupted (SIGTERM)":
        (d / "record.json").write_text(json.dumps(rec | {"point": _identity(pt, t_end)}, indent=1))
    return rec


#: Bumped whenever a record's fields change, so older records are recomputed.
RECORD_VERSION = 3


def _identity(pt: dict, t_end: float) -> dict:
    return {**{f: pt[f] for f in FACTORS}, "dt_factor": pt.get("dt_factor"), "t_end_s": t_end,
            "version": RECORD_VERSION}


def stored(pt: dict, work: Path, t_end: float) -> dict | None:
    """The point's earlier record if it was computed with the same inputs."""
    try:
        rec = json.loads((work / "points" / key_of(pt) / "record.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None
    if rec.pop("point", None) != _identity(pt, t_end):
        return None
    return rec | {"parts": pt["parts"]}


# ## Summaries
#
# Counts per factor level (design points; the unstable contrast apart), the
# γ × dt_safety cells per loading, the Σ0 × V_imp maps, the slip-rate
# runaways and the unstable contrast against the same loading at the default
# step.

#: A γ × dt cell agrees with the default cell when it is ok with the same mode
#: and a peak slip rate within this fraction of the default's.
PEAK_TOL = 0.05


def counts(records: list) -> dict:
    out = {k: 0 for k in KINDS}
    for r in records:
        out[r["kind"]] += 1
    return out


def per_level(records: list) -> dict:
    return {f: {f"{lv:g}": counts([r for r in records if r[f] == lv]) for lv in LEVELS[f]} for f in FACTORS}


def law_scale(k: float) -> float:
    """m L0 C_s [Pa] with Table 1's m, L0 and C_s = k × the base scene's: above this
    |T_s| the slip rate of a sliding point runs away (see :func:`runaways`)."""
    scene = load_scene(BASE)
    return scene.params["m"] * scene.params["L0"] * scene.Cs * k


def gamma_dt(by_key: dict, c_l: float) -> dict:
    """Per γ × dt loading: every accepted cell, the default cell, whether the loading
    runs away (a peak slip rate above c_l); and the cells that agree with the
    default at every loading that does not run away (the stable region)."""
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
                         "runaway": bool(peaks) and max(peaks) > c_l,
                         "peak_range": [min(peaks), max(peaks)] if peaks else None,
                         "counts": counts([{"kind": c["kind"]} for c in cells.values()])})
    region = []
    for g in accepted:
        for d in LEVELS["dt_safety"]:
            good = True
            for ld in loadings:
                c, ref = ld["cells"].get(f"{g:g}/{d:g}"), ld["default"]
                if ld["runaway"] or c is None or ref is None:
                    continue
                good &= (c["kind"] == "ok" and c["mode"] == ref["mode"]
                         and abs(c["peak"] - ref["peak"]) <= PEAK_TOL * max(ref["peak"], 1e-9))
            if good:
                region.append([g, d])
    return {"loadings": loadings, "accepted_gamma": accepted, "stable_cells": region,
            "rejected_gamma": sorted({r["gamma"] for r in by_key.values() if r["kind"] == "rejected"}),
            "peak_tol": PEAK_TOL}


def runaways(records: list, c_l: float) -> dict:
    """Runs (ok or watchdog) whose peak slip rate exceeds c_l, against |T_s| > m L0 C_s.

    With v ≫ V0 the law gives v ≈ V0 β^m, β = |T_s| / (g(θ0)(θ1 + θ2)), and
    during fast slip g ∝ θ0^(1/m) with θ0 → L0/v: d ln β / dt ≈ v (1/(m L0)
    − C_s/|T_s|).  When |T_s| > m L0 C_s the strength falls faster than the
    elastic interface unloads, and v grows without bound (finite-time blow-up
    of the point's equations, whatever the integrator).
    """
    fast = [r for r in records if r["kind"] in ("ok", "watchdog") and (r["peak_slip_rate_m_s"] or 0) > c_l]
    above = [r for r in fast if (r.get("ts_at_peak_Pa") or 0) > law_scale(r["k"])]
    return {"c_l_m_s": c_l, "count": len(fast), "ok": sum(r["kind"] == "ok" for r in fast),
            "watchdog": sum(r["kind"] == "watchdog" for r in fast), "ts_above_m_L0_Cs": len(above),
            "keys": [r["key"] for r in fast],
            "m_L0_Cs_Pa": {f"{k:g}": law_scale(k) for k in LEVELS["k"]},
            "k_of_runaways": {f"{k:g}": sum(r["k"] == k for r in fast) for k in LEVELS["k"]}}


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


# ## Outputs


SYMBOL = {"ok": "·", "watchdog": "W", "rejected": "R", "error": "E"}
COLOUR = {"ok": "tab:green", "watchdog": "tab:orange", "rejected": "0.6", "error": "tab:red"}
MARKER = {"ok": "o", "watchdog": "X", "rejected": "s", "error": "P"}


def _num(x, fmt=".3g") -> str:
    return "" if x is None else format(x, fmt)


def _mpa(x):
    return None if x is None else x / 1e6


def _loading(ld) -> str:
    return f"Σ0 = {ld['sigma0_MPa']:g} MPa, V_imp = {ld['v_imp_m_s']:g} m/s, k = {ld['k']:g}"


def stable_text(doc: dict) -> str:
    gd = doc["gamma_dt"]
    cells = gd["stable_cells"]
    gam = sorted({g for g, _ in cells})
    dts = sorted({d for _, d in cells})
    n_acc = len(gd["accepted_gamma"]) * len(LEVELS["dt_safety"])
    calm = [ld for ld in gd["loadings"] if not ld["runaway"]]
    wild = [ld for ld in gd["loadings"] if ld["runaway"]]
    text = [f"γ = {', '.join(f'{g:g}' for g in gd['rejected_gamma'])} are rejected at validation: "
            f"\"{doc['rejection_message']}\"."]
    if calm:
        spread = "; ".join(f"{_loading(ld)}: {ld['counts']['ok']} of {n_acc} ok, peak slip rate "
                           f"{ld['peak_range'][0]:.3g}–{ld['peak_range'][1]:.3g} m/s" for ld in calm)
        text.append(f"At the loadings that do not run away ({spread}), {len(cells)} of {n_acc} accepted "
                    f"(γ, dt_safety) cells end ok with the default cell's mode and a peak slip rate within "
                    f"{100 * PEAK_TOL:g} % of it.")
    if cells and len(cells) == len(gam) * len(dts):
        text.append(f"Stable region: γ ∈ [{min(gam):g}, {max(gam):g}] × dt_safety ∈ [{min(dts):g}, {max(dts):g}] "
                    f"— every accepted level of both.")
    elif cells:
        text.append("Stable cells: " + ", ".join(f"({g:g}, {d:g})" for g, d in cells) + ".")
    for ld in wild:
        w = [c for c in ld["cells"].values() if c["kind"] == "watchdog"]
        text.append(f"At {_loading(ld)} every accepted cell runs away (peak slip rate "
                    f"{ld['peak_range'][0]:.3g}–{ld['peak_range'][1]:.3g} m/s, far above c_l): "
                    f"{len(w)} of {n_acc} cross the watchdog's {doc['max_slip_rate']:g} m/s bound before "
                    f"{doc['t_end_s'] * 1e6:g} µs"
                    + (" (" + ", ".join(f"γ {c['gamma']:g}, dt {c['dt_safety']:g}" for c in w) + ")" if w else "")
                    + ", the others end ok with peaks just below it; neither γ nor dt_safety removes the runaway "
                      "(a property of the law, see below).")
    if [DEFAULT["gamma"], DEFAULT["dt_safety"]] in cells:
        text.append("The defaults, dt_safety = 0.9 and γ = 0.5, lie inside the region. γ = ½ is the second-order "
                    "(trapezoidal) sub-step, 2–70 × more accurate than backward Euler at equal tolerance "
                    "(docs/friction.md), and γ > ½ gains nothing in stability here. Inside the region the peak slip "
                    "rate does not depend on dt_safety, so the largest safety with a margin is the cheapest: 0.9 "
                    "takes 0.5/0.9 = 0.56 × the steps of 0.5. The margin below 1 covers dt_crit being an estimate "
                    "(power iteration: the Rayleigh quotient approaches λmax from below, so dt_crit from above); "
                    "0.95 also ran without fault, while fixed steps of 1.05–1.5 × dt_crit diverge (contrast below).")
    return " ".join(text)


def markdown(doc: dict) -> str:
    recs = [r for r in doc["points"] if not r.get("dt_factor")]
    by_key = {r["key"]: r for r in doc["points"]}
    c_l = doc["runaways"]["c_l_m_s"]
    lines = [
        "# Stability stress test",
        "",
        f"`mpirun -n {doc['ranks']} .venv/bin/python benchmarks/stability.py`"
        f"{' --smoke' if doc['smoke'] else ''} — {doc['finished']}; "
        f"{len(doc['points'])} points ({len(recs)} design, {len(doc['points']) - len(recs)} unstable contrast) "
        f"on the `{doc['preset']}` mesh to {doc['t_end_s'] * 1e6:g} µs, base scene `{BASE}`; "
        "runs per call: " + "; ".join(f"{c['finished']}: {c['runs']} runs, wall {c['wall_s']:.0f} s on {c['ranks']} "
                                      f"rank(s), load average {_num(c['load_avg'], '.1f')}" for c in doc["calls"])
        + f". The point walls sum to {doc['point_wall_sum_s']:.0f} s (2 cores shared with other jobs: wall times "
        "are upper bounds).",
        "",
        "Factors: Σ0 " + ", ".join(f"{x:g}" for x in LEVELS["sigma0_MPa"]) + " MPa; V_imp "
        + ", ".join(f"{x:g}" for x in LEVELS["v_imp_m_s"]) + " m/s; k (C_n and C_s × k) "
        + ", ".join(f"{x:g}" for x in LEVELS["k"]) + "; dt_safety " + ", ".join(f"{x:g}" for x in LEVELS["dt_safety"])
        + "; γ " + ", ".join(f"{x:g}" for x in LEVELS["gamma"]) + ". Design: the 32 corners, one factor at a time "
        "around Case I (6 MPa, 2 m/s, k = 1, 0.9, 0.5), the full γ × dt_safety grid at "
        + "; ".join(_loading(ld) for ld in doc["gamma_dt"]["loadings"])
        + ", the full Σ0 × V_imp grids at the default step and γ for k = " + ", ".join(f"{k:g}" for k in SIGMA_V_K)
        + f", and a {LHS_POINTS}-point Latin hypercube on the levels.",
        "",
        "Outcomes: `ok` — complete, every dataset of interface.h5 finite and a sound energy history; "
        "`watchdog` — stopped with the watchdog's message; `rejected` — refused by the scene's validation; "
        "`error` — anything else, including a complete run with a non-finite value or an unsound energy "
        f"history (kinetic energy below −{KINETIC_NEG_REL:g} × the external work, or a balance error above "
        f"{BALANCE_REL_MAX:g} × it). Over the ok runs the balance error stays below "
        f"{doc['energy_calibration']['balance_rel_max_ok']:.3g} × the external work and the kinetic energy is "
        f"never below {doc['energy_calibration']['kinetic_min_ok']:.3g} J/m, so the thresholds are far from both.",
        "",
        "## Outcomes",
        "",
        "| | ok | watchdog | rejected | error |",
        "|---|---|---|---|---|",
        "| design points | " + " | ".join(str(doc["counts"][k]) for k in KINDS) + " |",
        "| unstable contrast | " + " | ".join(str(doc["unstable_counts"][k]) for k in KINDS) + " |",
        "",
        f"Complete runs with a non-finite value (silent NaN): {len(doc['silent_nonfinite'])}. "
        f"Complete runs with an unsound energy history (silent divergence): {len(doc['silent_divergence'])}"
        + (f" ({', '.join(f'`{k}`' for k in doc['silent_divergence'])})" if doc["silent_divergence"] else "") + ".",
        "",
        "### Per factor level (design points)",
        "",
    ]
    for f in FACTORS:
        lines += [f"**{LABELS[f]}**", "", "| level | ok | watchdog | rejected | error |", "|---|---|---|---|---|"]
        for lv, c in doc["per_level"][f].items():
            lines.append(f"| {lv} | " + " | ".join(str(c[k]) for k in KINDS) + " |")
        lines.append("")
    lines += ["## Stable region in γ × dt_safety", "", stable_text(doc), ""]
    for ld in doc["gamma_dt"]["loadings"]:
        lines += [f"**{_loading(ld)}** — peak slip rate [m/s] per cell (`W` watchdog, `E` error, `R` rejected)", "",
                  "| γ \\ dt_safety | " + " | ".join(f"{d:g}" for d in LEVELS["dt_safety"]) + " |",
                  "|---|" + "---|" * len(LEVELS["dt_safety"])]
        for g in LEVELS["gamma"]:
            row = []
            for d in LEVELS["dt_safety"]:
                c = ld["cells"].get(f"{g:g}/{d:g}")
                row.append("" if c is None else "R" if c["kind"] == "rejected" else
                           ("" if c["kind"] == "ok" else SYMBOL[c["kind"]] + " ") + _num(c["peak"], ".4g"))
            lines.append(f"| {g:g} | " + " | ".join(row) + " |")
        lines.append("")
    lines += ["## Σ0 × V_imp at dt_safety 0.9, γ 0.5", "",
              "Peak slip rate [m/s]; `W` watchdog, `E` error. Rows V_imp (fastest on top), columns Σ0 [MPa].", ""]
    for k in SIGMA_V_K:
        lines += [f"**k = {k:g}** (C_n = {0.3 * k:g}, C_s = {0.1 * k:g} MPa/µm; m L0 C_s = "
                  f"{law_scale(k) / 1e6:.3g} MPa)", "",
                  "| V_imp \\ Σ0 | " + " | ".join(f"{s:g}" for s in LEVELS["sigma0_MPa"]) + " |",
                  "|---|" + "---|" * len(LEVELS["sigma0_MPa"])]
        for v in reversed(LEVELS["v_imp_m_s"]):
            cells = []
            for s in LEVELS["sigma0_MPa"]:
                r = by_key.get(key_of({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, **DEFAULT}))
                cells.append("" if r is None else ("" if r["kind"] == "ok" else SYMBOL[r["kind"]] + " ")
                             + _num(r["peak_slip_rate_m_s"], ".3g"))
            lines.append(f"| {v:g} | " + " | ".join(cells) + " |")
        lines.append("")
    ra = doc["runaways"]
    lines += [
        "## Slip-rate runaways", "",
        f"{ra['count']} design runs reach a peak slip rate above c_l = {c_l:.0f} m/s ({ra['ok']} end ok, "
        f"{ra['watchdog']} are stopped by the watchdog's {doc['max_slip_rate']:g} m/s bound); by k: "
        + ", ".join(f"k = {k}: {n}" for k, n in ra["k_of_runaways"].items())
        + f". In {ra['ts_above_m_L0_Cs']} of them |T_s| at the peak exceeds m L0 C_s "
        "(" + ", ".join(f"{v / 1e6:.3g} MPa at k = {k}" for k, v in ra["m_L0_Cs_Pa"].items()) + "). "
        "For v ≫ V0 the law gives v ≈ V0 β^m with β = |T_s| / (g(θ0)(θ1 + θ2)), and in fast slip "
        "g ∝ θ0^(1/m) with θ0 → L0/v, so d ln β/dt ≈ v (1/(m L0) − C_s/|T_s|): once |T_s| > m L0 C_s the "
        "strength falls faster than the elastic interface unloads and the slip rate blows up in finite time, "
        "whatever the integrator. The runaways sit where the normal traction behind the struck edge is high "
        "(V_imp ≥ 50 m/s at k = 1) or C_s is small (k = 0.01); at k = 100 (m L0 C_s = 1 GPa) slip rates stay "
        "near V_imp everywhere. The watchdog sees a runaway only when it crosses the bound before the end time.",
        "",
        "## Unstable explicit step (contrast)", "",
        "`time.dt` = factor × dt_crit (`build_model(scene, comm)[1].dt_crit`); the reference is the same "
        "loading at dt_safety 0.9, γ 0.5.", "",
        "| loading | dt / dt_crit | outcome | stopped at [µs] | peak slip rate (ref) [m/s] | max T_n (ref) [MPa] "
        "| max open share (ref) | mode (ref) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in doc["contrast"]:
        r = by_key[c["key"]]
        lines.append(
            f"| {r['sigma0_MPa']:g} MPa, {r['v_imp_m_s']:g} m/s, k = {r['k']:g} | {c['dt_factor']:g} | "
            f"{r['outcome'][:150]}{'…' if len(r['outcome']) > 150 else ''} | "
            f"{_num(r['t_stop_s'] * 1e6 if r['kind'] == 'watchdog' else None, '.2f')} | "
            f"{_num(c['peak'])} ({_num(c['reference_peak'])}) | "
            f"{_num(_mpa(c['tn_max']))} ({_num(_mpa(c['reference_tn_max']))}) | "
            f"{_num(c['open_fraction_max'], '.2f')} ({_num(c['reference_open_fraction_max'], '.2f')}) | "
            f"{c['mode'] or '–'} ({c['reference_mode'] or '–'}) |")
    missed = [c for c in doc["contrast"] if not c["stopped_naming_step"]]
    lines += ["", f"{len(doc['contrast']) - len(missed)} of {len(doc['contrast'])} unstable runs are stopped by the "
              "watchdog with a message naming the step." + (" Not stopped: " + ", ".join(
                  f"`{c['key']}` ({c['kind']})" for c in missed) + "." if missed else ""), ""]
    stops = sorted({round(by_key[c["key"]]["t_stop_s"] / by_key[c["key"]]["dt_s"]) for c in doc["contrast"]
                    if c["stopped_naming_step"]})
    tns = [c["tn_max"] for c in doc["contrast"] if c["stopped_naming_step"] and c["tn_max"] is not None]
    if stops:
        lines += [
            f"Every stop comes from the energy check (steps {', '.join(map(str, stops))}: multiples of "
            "`output.energy_every` + 1), none from the non-finite or slip-rate checks, although max T_n reaches "
            f"{min(tns):.1e}–{max(tns):.1e} Pa in those runs. The energy check is nearly blind to a bulk step "
            "beyond the stable one: the energy it "
            "sums, ½ M v^{n−½}·v^{n+½} + ½ uᵀK u, is exactly conserved by central differences for the linear "
            "bulk at any dt, so for a growing mode the (negative) staggered kinetic energy cancels the strain "
            "energy; only the nonlinear interface breaks the cancellation, and the check fires when the sum "
            "happens to be positive at an energy step (with the external work negative too, `max(external, "
            "1e-9)` makes any positive sum fire). When it is negative at every energy step the run completes: "
            "that is the silent divergence above, which this benchmark catches by the negative kinetic energy in "
            "the energy history. With k = 100 the stable step is set by the interface springs; beyond it the "
            "unstable normal-spring mode is clipped by opening (T_n ≥ 0), so the interface chatters open and "
            "shut with bounded, finite values, a sound energy balance and a different mode label: nothing for "
            "any check to see.", ""]
    bad = [r for r in recs if r["kind"] in ("watchdog", "error")]
    lines += ["## Every design point ending `watchdog` or `error`", ""]
    if bad:
        lines += ["| point | parts | peak slip rate [m/s] | steps | outcome |", "|---|---|---|---|---|"]
        for r in sorted(bad, key=lambda r: r["key"]):
            lines.append(f"| `{r['key']}` | {', '.join(r['parts'])} | {_num(r['peak_slip_rate_m_s'])} | "
                         f"{r['steps']} | {r['outcome']} |")
    else:
        lines.append("None.")
    lines += ["", "<details><summary>Every point</summary>", "",
              "| point | parts | outcome | peak slip rate [m/s] | steps | dt [ns] | wall [s] |",
              "|---|---|---|---|---|---|---|"]
    for r in doc["points"]:
        dt_ns = "" if r["dt_s"] is None else f"{r['dt_s'] * 1e9:.1f}"
        out = r["outcome"] if r["kind"] == "ok" else f"{r['kind']}: {r['outcome'].partition(': ')[2][:90]}…"
        lines.append(f"| `{r['key']}` | {', '.join(r['parts'])} | {out} | {_num(r['peak_slip_rate_m_s'])} | "
                     f"{'' if r['steps'] is None else r['steps']} | {dt_ns} | {r['wall_s']:.2f} |")
    lines += ["", "</details>", ""]
    return "\n".join(lines)


def figure(doc: dict, path: Path) -> None:
    """Top: γ × dt_safety per loading (outcome, peak slip rate); bottom: Σ0 × V_imp per k."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    loadings = doc["gamma_dt"]["loadings"]
    ncol = max(len(loadings), len(SIGMA_V_K), 1)
    fig, axes = plt.subplots(2, ncol, figsize=(5.0 * ncol, 10.0), squeeze=False, layout="constrained")
    gs, ds = LEVELS["gamma"], LEVELS["dt_safety"]
    for ax, ld in zip(axes[0], loadings):
        for c in ld["cells"].values():
            i, j = ds.index(c["dt_safety"]), gs.index(c["gamma"])
            ax.add_patch(plt.Rectangle((i - 0.46, j - 0.46), 0.92, 0.92, color=COLOUR[c["kind"]], alpha=0.4))
            txt = "R" if c["kind"] == "rejected" else _num(c["peak"], ".3g")
            ax.text(i, j, txt, ha="center", va="center", fontsize=7)
        ax.plot(ds.index(DEFAULT["dt_safety"]), gs.index(DEFAULT["gamma"]), marker="s", ms=26, mfc="none",
                mec="k", mew=1.5, ls="none")
        ax.set_xticks(range(len(ds)), [f"{d:g}" for d in ds])
        ax.set_yticks(range(len(gs)), [f"{g:g}" for g in gs])
        ax.set_xlim(-0.6, len(ds) - 0.4)
        ax.set_ylim(-0.6, len(gs) - 0.4)
        ax.set_xlabel("time.dt_safety")
        ax.set_ylabel("friction.params.gamma γ")
        ax.set_title(f"{_loading(ld)}\npeak slip rate [m/s]: green ok, orange watchdog,\n"
                     "grey rejected; framed: the default", fontsize=8)
    for ax in axes[0][len(loadings):]:
        ax.axis("off")
    by_key = {r["key"]: r for r in doc["points"]}
    peaks = [r["peak_slip_rate_m_s"] for r in doc["points"] if r["peak_slip_rate_m_s"]]
    norm = LogNorm(vmin=0.1, vmax=max(peaks + [1.0]))
    sc = None
    for ax, k in zip(axes[1], SIGMA_V_K):
        for kind in KINDS:
            xs, ys, cs = [], [], []
            for s in LEVELS["sigma0_MPa"]:
                for v in LEVELS["v_imp_m_s"]:
                    r = by_key.get(key_of({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, **DEFAULT}))
                    if r and r["kind"] == kind:
                        xs.append(s)
                        ys.append(v)
                        cs.append(max(r["peak_slip_rate_m_s"] or 0.1, 0.1))
            if xs:
                sc = ax.scatter(xs, ys, marker=MARKER[kind], c=cs, cmap="viridis", norm=norm, s=70,
                                edgecolors="k" if kind == "ok" else "r", linewidths=0.6 if kind == "ok" else 1.6,
                                label=kind, zorder=3)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("Σ0 [MPa]")
        ax.set_ylabel("V_imp [m/s]")
        ax.set_title(f"C_n, C_s × {k:g} (m L0 C_s = {law_scale(k) / 1e6:.3g} MPa), dt_safety 0.9, γ 0.5\n"
                     "colour: peak slip rate; o ok, X watchdog", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.5)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="lower left")
    for ax in axes[1][len(SIGMA_V_K):]:
        ax.axis("off")
    if sc is not None:
        fig.colorbar(sc, ax=list(axes[1]), shrink=0.8, label="peak slip rate [m/s]")
    fig.suptitle(f"fricfem stability on the {doc['preset']} mesh to {doc['t_end_s'] * 1e6:g} µs", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


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
    args = ap.parse_args(argv)
    t_end = 10e-6 if args.smoke else args.t_end
    t0 = time.perf_counter()

    todo = reused = None
    if comm.rank == 0:
        points = design(args.smoke)
        reused = {}
        todo = []
        for pt in points:
            rec = None if args.fresh else stored(pt, args.work, t_end)
            if rec is not None:
                reused[rec["key"]] = rec
            else:
                todo.append(pt)
        todo.sort(key=lambda p: -expected_cost(p))
        if not args.quiet:
            print(f"stability: {len(points)} points, {len(reused)} reused, {len(todo)} to run on "
                  f"{comm.size} rank(s)", file=sys.stderr, flush=True)
    todo = comm.bcast(todo, root=0)
    mine = todo[comm.rank::comm.size]
    done = []
    for i, pt in enumerate(mine):
        rec = run_point(pt, args.work, t_end)
        done.append(rec)
        if comm.rank == 0 and not args.quiet:
            print(f"[{i + 1}/{len(mine)}] {rec['key']}: {rec['outcome'][:110]} ({rec['wall_s']:.2f} s)",
                  file=sys.stderr, flush=True)
    gathered = comm.gather(done, root=0)

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
        "max_slip_rate": base.watchdog["max_slip_rate"] or base.material.c_l,  # 0 means the material's c_l
        "counts": counts(design_recs), "unstable_counts": counts(unstable),
        "per_level": per_level(design_recs),
        "gamma_dt": gamma_dt(by_key, c_l),
        "rejection_message": next((r["outcome"].partition(": ")[2] for r in records if r["kind"] == "rejected"), ""),
        "runaways": runaways(design_recs, c_l),
        "contrast": contrast(records, by_key),
        "silent_nonfinite": [r["key"] for r in records if r["outcome"].startswith("error: silent non-finite")],
        "silent_divergence": [r["key"] for r in records if r["outcome"].startswith("error: silent divergence")],
        "energy_calibration": {
            "balance_rel_max_ok": max((r["balance_rel"] for r in ok), default=0.0),
            "kinetic_min_ok": min((r["kinetic_min_J_m"] for r in ok), default=0.0),
            "kinetic_neg_rel": KINETIC_NEG_REL, "balance_rel_max": BALANCE_REL_MAX},
        "machine": {"node": platform.node(), "python": sys.version.split()[0]},
        "points": records,
    }
    doc["unstable_all_stopped_by_watchdog"] = all(c["stopped_naming_step"] for c in doc["contrast"])
    doc["stable_text"] = stable_text(doc)
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = args.out / "stability.json.tmp"
    tmp.write_text(json.dumps(doc, indent=1, allow_nan=False))
    tmp.replace(args.out / "stability.json")
    (args.out / "stability.md").write_text(markdown(doc))
    figure(doc, args.out / "stability.png")
    c, u = doc["counts"], doc["unstable_counts"]
    print(f"design points: {sum(c.values())}  " + "  ".join(f"{k} {c[k]}" for k in KINDS))
    print(f"unstable contrast: {sum(u.values())}  " + "  ".join(f"{k} {u[k]}" for k in KINDS)
          + f"  (all stopped by the watchdog naming the step: {doc['unstable_all_stopped_by_watchdog']})")
    print(doc["stable_text"])
    print(f"wall {doc['wall_s']:.0f} s on {ranks} rank(s); {args.out / 'stability.md'}")
    return doc


if __name__ == "__main__":
    main()
