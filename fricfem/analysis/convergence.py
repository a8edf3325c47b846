"""Distances between two runs of one problem (mesh or step ladders, code-to-code
comparisons): rupture times and slip-rate histories at stations, the front of
sliding, rupture speeds, observed orders.

A run enters as a *record* (:func:`record`): its station slip-rate histories,
its leading-tip track and its timings, read from the run directory.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..output.rundir import open_interface, open_run
from .rupture import station_histories, station_times

RUPTURE_THRESHOLD = 1e-3  # m/s: a station has ruptured once Δu̇_slip exceeds this



def record(rundir, scene=None) -> dict:
    """What the metrics need from a run directory: ``stations`` {name: {"x1",
    "t", "v"}} (slip rate [m/s] against time [s]), the tip track ``tip_t``,
    ``tip_x``, ``t_end_s``, the speeds, the sizes and the timings."""
    r = open_run(Path(rundir))
    s = r.summary
    tip = s.get("tip") or {"time_s": [], "x1_m": []}
    wall = s.get("wall_s") or {}
    return {
        "dofs": s.get("dofs"), "dt_s": s.get("dt_s"), "steps": s.get("steps"), "complete": s.get("complete"),
        "h_m": scene.mesh.dx if scene is not None else None, "wall_loop_s": wall.get("time_loop"),
        "wall_total_s": wall.get("total"), "us_per_step": s.get("us_per_step"), "t_end_s": s.get("t_end_s"),
        "speeds": s.get("speeds"),
        "stations": _stations(rundir),
        "tip_t": np.asarray(tip["time_s"], dtype=float), "tip_x": np.asarray(tip["x1_m"], dtype=float),
    }


def _stations(rundir) -> dict:
    """{name: {"x1", "t", "v", "width"}}: each station's slip rate [m/s] at the times it
    holds and the interval each sample is the mean over
    (:func:`fricfem.analysis.rupture.station_histories`)."""
    with open_interface(Path(rundir)) as itf:
        return {name: {"x1": float(x), "t": t, "v": v, "width": w}
                for name, (x, t, v, w) in station_histories(itf).items()}


def rupture_times(rec: dict, threshold: float = RUPTURE_THRESHOLD) -> dict:
    """Station name -> the first time Δu̇_slip reaches ``threshold`` [s], interpolated
    between samples as the summary's (:func:`fricfem.analysis.rupture.station_times`:
    a step rate out of stick from where its stuck step ended); NaN if never."""
    st = station_times({name: (s["x1"], s["t"], s["v"], s.get("width", 0.0))
                        for name, s in rec["stations"].items()}, threshold)
    return {name: tr for name, (_, tr) in st.items()}


def station_l2(rec: dict, ref: dict) -> float:
    """Relative L2 distance of the station slip-rate histories (all stations together)."""
    num = den = 0.0
    for name, r in ref["stations"].items():
        s = rec["stations"][name]
        v = np.interp(r["t"], s["t"], s["v"], left=0.0)
        w = np.gradient(r["t"]) if len(r["t"]) > 1 else np.ones(1)
        num += float(np.sum(w * (v - r["v"]) ** 2))
        den += float(np.sum(w * r["v"] ** 2))
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


def front_at(rec: dict, t: np.ndarray) -> np.ndarray:
    """The run's front of sliding at times ``t``: the furthest the leading tip has
    reached by t (its first position before it starts sliding; NaN if it never slides)."""
    if len(rec["tip_t"]) == 0:
        return np.full(len(t), np.nan)
    front = np.maximum.accumulate(rec["tip_x"])
    k = np.searchsorted(rec["tip_t"], t, side="right") - 1
    return front[np.maximum(k, 0)]


def tip_error(rec: dict, ref: dict) -> float:
    """max |x_f − x_f,ref| [m] from the reference's initiation to the end."""
    if len(ref["tip_t"]) == 0:
        return 0.0 if len(rec["tip_t"]) == 0 else float("nan")
    t = ref["tip_t"]
    return float(np.nanmax(np.abs(front_at(rec, t) - front_at(ref, t))))


def rupture_time_error(rec: dict, ref: dict) -> float:
    """max over stations |t_r − t_r,ref| [s]; a station broken in only one of them counts as
    the time from its rupture to the end."""
    a, b = rupture_times(rec), rupture_times(ref)
    errs = []
    for name, tb in b.items():
        ta = a[name]
        if np.isnan(ta) and np.isnan(tb):
            continue
        if np.isnan(ta) or np.isnan(tb):
            errs.append(ref["t_end_s"] - (tb if np.isnan(ta) else ta))
        else:
            errs.append(abs(ta - tb))
    return float(max(errs)) if errs else 0.0


def rupture_speeds(rec: dict, x_centre: float, r_min: float = 8e-3, r_max: float = 24e-3) -> dict:
    """Front speeds [m/s] both ways from the patch centre: least-squares slope of the
    station distance against the rupture time over stations r_min <= |x − x_c| <= r_max."""
    tr = rupture_times(rec)
    out = {}
    for side, sgn in (("left", -1.0), ("right", 1.0)):
        pts = [(s["x1"], tr[n]) for n, s in rec["stations"].items()
               if r_min - 1e-4 <= sgn * (s["x1"] - x_centre) <= r_max + 1e-4 and np.isfinite(tr[n])]
        if len(pts) >= 2:
            x, t = np.array(pts).T
            out[side] = float(abs(np.polyfit(t, x, 1)[0]))
        else:
            out[side] = float("nan")
    return out


def order(h, e) -> float:
    """Slope of log e against log h (NaN with fewer than two positive errors)."""
    h, e = np.asarray(h, float), np.asarray(e, float)
    ok = (e > 0) & np.isfinite(e)
    if ok.sum() < 2 or len(set(h[ok])) < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0])
