"""What the experiment demos share: a run of a scene with line gauges, and the
measurements the paper's Section 3 reports, taken the same way for every run.

* :func:`options` — the options every demo here takes (``--preset``, ``--out``,
  ``--work``);
* :func:`run` — run a scene (any communicator) with the gauges of
  :data:`LINES` (the struck edge, a strain-gauge position in the specimen) and
  the projectile's momentum and contact force, saved as ``gauges.npz`` next to
  the run; a finished run of the same input is reused.
* :func:`tip_measures` — the leading tip from the recorded slip rates: its
  mean speed (least-squares line over the window where it runs from
  :data:`TIP_FROM` to :data:`TIP_TO`) and its constancy (the spread of the
  5-point speeds in that window);
* :func:`second_front` — a supersonic front behind the leading tip (the
  paper's second Mach line) and whether it catches the tip;
* :func:`crack_like` — the share of the interface behind the tip that slides
  at given times (the paper's "fringe discontinuity at the interface");
* :func:`loading_wave` — rise time, plateau and plateau length of a gauge's
  particle velocity (the strain-gauge description).

All inputs SI; reports in mm, µs, MPa, m/s.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import math
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem.analysis.fronts import fronts
from fricfem.analysis.tip import lsq_slope, tip_history, tip_speed
from fricfem.model.build import build_model
from fricfem.output.line_gauges import LineGauges
from fricfem.runner import run_scene

#: Line gauges {name: (x1, x2_min, x2_max, h)} [m]: the mean x1 velocity over the
#: struck segment and over the buffer's whole height on x1 = 0 (the specimen's
#: edge), and strain-gauge positions in the specimen 10 and 30 mm from its edge,
#: across the struck segment (the paper does not say where its gauge was).
LINES = {"edge_b": (0.0, -0.025, 0.0, 1e-3), "edge_h": (0.0, -0.0762, 0.0, 1e-3),
         "g10": (0.010, -0.025, 0.0, 1e-3), "g30": (0.030, -0.025, 0.0, 1e-3)}
#: The tip's mean speed is fitted where it runs from TIP_FROM to TIP_TO [m].
TIP_FROM, TIP_TO = 0.010, 0.110


def options(work: str) -> argparse.ArgumentParser:
    """A parser with the options every experiment demo takes: ``--preset`` (the mesh),
    ``--out`` (where the results go) and ``--work`` (its runs, default ``work``);
    fricfem's per-run log lines are silenced (WARNING)."""
    logging.getLogger().setLevel(logging.WARNING)
    ap = argparse.ArgumentParser()
    ap.add_argument("--preset", default="reference")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/experiment"))
    ap.add_argument("--work", type=Path, default=Path(work))
    return ap


def _digest(scene) -> str:
    return hashlib.sha256(json.dumps(scene.raw, sort_keys=True, default=str).encode()).hexdigest()[:16]


def run(scene, out: Path, comm=MPI.COMM_WORLD, lines=LINES) -> dict:
    """Run ``scene`` into ``out`` with the gauges (reused when ``out`` holds a finished
    run of the same input); returns {"summary", "gauges"} (gauges on rank 0 only)."""
    out = Path(out)
    stamp = out / "input.sha"
    done = comm.bcast(stamp.is_file() and stamp.read_text() == _digest(scene)
                      and (out / "gauges.npz").is_file() if comm.rank == 0 else None, root=0)
    if not done:
        holder = {}

        def build(sc, c):
            pm, model = build_model(sc, c)
            holder["g"] = LineGauges(model, lines)
            return pm, model

        run_scene(scene, out, comm, overwrite=True, quiet=True, build=build,
                  on_step=lambda st: holder["g"].record(st))
        res = holder["g"].result()
        if comm.rank == 0:
            np.savez(out / "gauges.npz", **res)
            stamp.write_text(_digest(scene))
    comm.Barrier()
    if comm.rank != 0:
        return {"summary": None, "gauges": None}
    g = dict(np.load(out / "gauges.npz"))
    return {"summary": json.loads((out / "summary.json").read_text()), "gauges": g}


def tip_measures(r, t_from: float = TIP_FROM, t_to: float = TIP_TO) -> dict:
    """The leading tip of run ``r`` (:func:`fricfem.open_run`): its mean speed fitted
    where it runs from ``t_from`` to ``t_to`` [m], the spread of its 5-point speeds
    there (one sample per µs) and when it got there."""
    t, x = tip_history(r.t, r.x1, r.slip_rate)
    out = {"first_slip_us": float(t[0] * 1e6) if len(t) else None}
    if not len(t):
        return {**out, "mean_m_s": None}
    sel = (x >= t_from) & (x <= t_to) & (np.maximum.accumulate(x) <= t_to)
    if sel.sum() < 10:
        return {**out, "mean_m_s": None}
    ts, xs = t[sel], x[sel]
    every = max(1, int(round(1e-6 / np.median(np.diff(r.t)))))
    tv, v = tip_speed(ts[::every], xs[::every])
    mean = lsq_slope(ts, xs)
    resid = xs - (xs.mean() + mean * (ts - ts.mean()))
    return {**out, "mean_m_s": mean, "window_us": [float(ts[0] * 1e6), float(ts[-1] * 1e6)],
            "v5_std_m_s": float(np.std(v)) if len(v) else None,
            "v5_range_m_s": [float(np.min(v)), float(np.max(v))] if len(v) else None,
            "fit_rms_mm": float(np.sqrt(np.mean(resid**2)) * 1e3),
            "x_tip_mm": {f"{k}": float(np.interp(k * 1e-6, t, x) * 1e3) for k in (40, 48, 60) if t[-1] >= k * 1e-6}}


def second_front(r, speeds: dict, min_speed: float | None = None, min_run: float = 5e-3) -> dict:
    """Rupture fronts faster than ``min_speed`` (default c_l) that start behind the
    leading tip and run at least ``min_run`` [m] (shorter ones are regions linking
    up, not a front): the paper's second, supersonic Mach line.  For each: its mean
    speed, where and when it runs, and its distance to the leading tip at its end
    (≤ 1 mm: it caught up)."""
    c_l = speeds["c_l"]
    min_speed = c_l if min_speed is None else min_speed
    found = fronts(r.t, r.x1, r.slip_rate, speeds)
    t_tip, x_tip = tip_history(r.t, r.x1, r.slip_rate)
    out = []
    for f in found:
        if f.kind != "rupture" or f.mean_speed < min_speed or len(f.t) < 2 or f.x[-1] - f.x[0] < min_run:
            continue
        t0, t1, x0, x1 = float(f.t[0]), float(f.t[-1]), float(f.x[0]), float(f.x[-1])
        tip_start = float(np.interp(t0, t_tip, x_tip))
        if x0 >= tip_start - 1e-3:  # the leading tip itself
            continue
        tip_end = float(np.interp(t1, t_tip, x_tip))
        out.append({"mean_speed_m_s": float(f.mean_speed), "t_us": [t0 * 1e6, t1 * 1e6], "x_mm": [x0 * 1e3, x1 * 1e3],
                    "behind_tip_at_start_mm": (tip_start - x0) * 1e3, "behind_tip_at_end_mm": (tip_end - x1) * 1e3,
                    "caught_up": bool(tip_end - x1 <= 1e-3)})
    out.sort(key=lambda f: -(f["x_mm"][1] - f["x_mm"][0]))
    return {"count": len(out), "fronts": out[:5]}


def crack_like(r, times) -> dict:
    """At each time [s]: the share of the interface between x1 = 0 and the leading
    tip that slides, and the number of slipping stretches there."""
    out = {}
    w = np.gradient(r.x1)
    for t in times:
        s = r.profile("slip_rate", t) > 0.0
        if not s.any():
            out[f"{t * 1e6:g}"] = {"sliding_share": 0.0, "stretches": 0, "tip_mm": None}
            continue
        behind = r.x1 <= r.x1[s].max()
        share = float(w[s & behind].sum() / w[behind].sum())
        stretches = int(np.count_nonzero(np.diff(np.concatenate([[0], s[behind].astype(int)])) == 1))
        out[f"{t * 1e6:g}"] = {"sliding_share": share, "stretches": stretches, "tip_mm": float(r.x1[s].max() * 1e3)}
    return out


def loading_wave(t, v, start_frac: float = 0.1, end_frac: float = 0.9, hold: float = 0.8,
                 smooth: float = 2e-6) -> dict:
    """Rise time (``start_frac`` → ``end_frac`` of the plateau), plateau (the median over
    the 40 µs after the rise) and plateau length (from the end of the rise until v
    falls below ``hold`` × plateau) of a particle-velocity history ``v`` [m/s] at
    times ``t`` [s], after a running mean over ``smooth`` [s] (a gauge and its
    recorder do not resolve the waves' ringing; 0: none)."""
    t, v = np.asarray(t), np.asarray(v, dtype=float)
    if not np.isfinite(v).any() or np.nanmax(v) <= 0:
        return {}
    n = max(1, int(round(smooth / np.median(np.diff(t))))) if smooth > 0 else 1
    v = np.convolve(v, np.ones(n) / n, mode="same")
    peak = np.nanmax(v)
    i90 = int(np.argmax(v >= end_frac * peak))
    plateau = float(np.median(v[(t >= t[i90]) & (t <= t[i90] + 40e-6)]))
    i_start = int(np.argmax(v >= start_frac * plateau))
    i_end = int(np.argmax(v >= end_frac * plateau))
    below = np.flatnonzero((t > t[i_end]) & (v < hold * plateau))
    t_drop = float(t[below[0]]) if len(below) else math.nan
    return {"arrival_us": float(t[i_start] * 1e6), "rise_us": float((t[i_end] - t[i_start]) * 1e6),
            "plateau_m_s": plateau, "plateau_length_us": float((t_drop - t[i_end]) * 1e6),
            "peak_m_s": float(peak), "ends_at_us": t_drop * 1e6}
