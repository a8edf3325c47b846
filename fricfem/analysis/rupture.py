"""Rupture diagnostics of a nucleated rupture: the rupture-time field, the
rupture speed along the fault and between stations, the supershear transition.

The definitions are those of the SCEC/USGS dynamic-rupture exercises (Harris
et al. 2009, 2018): the rupture time of a point is the first time its slip
rate reaches a threshold (1 mm/s by default, the scene key
``output.rupture_threshold``), and the rupture speed is the inverse of the
gradient of that field along the fault, V_r = 1 / |dt_r/dx1|.

* :func:`rupture_times` — t_r(x1) from the interface snapshots: the first row
  whose |Δu̇_slip| reaches the threshold, with the crossing interpolated
  between that row and the one before (log-linear where both rates are
  positive: a rate-and-state rate grows exponentially before the front,
  and a log-linear interpolation of an exponential is exact; where the
  earlier rate is zero, as ahead of a slip-weakening front, from the slip
  accumulated in the interval: :func:`rupture_times`).  A rate that is the
  mean over its step (the rigid kind's V^{n+½}, :func:`step_width`) and is
  zero in a row was zero over the whole of that row's step, so a crossing out
  of it starts where that step ends, not at the row's time.
* :func:`nucleation` — the earliest point, and the patch around it that
  ruptured within ``patch_tol`` of it (an overstressed patch breaks at once).
* :func:`front_speeds` — along each direction apart (a nucleated rupture runs
  both ways), from the nucleation point outward over the contiguous ruptured
  points: the slope of a least-squares line t_r ≈ a + s / V_r over a centred
  window of ``npts`` points (s the distance from nucleation), so the speed is
  the smoothed derivative of x1(t_r).
* :func:`transition` — where the front, once sub-shear, first exceeds a speed
  (c_s, √2 c_s) and stays above it for ``npts`` points or to its end; the
  break-out of the nucleation patch (V_r → ∞ there) is not a transition.
* :func:`diagnose` — all of it as summary.json's ``rupture`` block (units in
  the names), with the stations' own threshold crossings (every step) and the
  speed between consecutive stations outward from nucleation.

Pure numpy on gathered histories; :func:`from_run` reads a run directory.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..output.record import jsonable
from ..output.rundir import open_interface
from .speeds import check_speeds

#: the slip rate whose first crossing is a point's rupture time [m/s]: the default of the
#: scene key output.rupture_threshold (declared with its unit and range in scene/schema.py)
THRESHOLD = 1e-3
#: points in the centred least-squares window of the rupture speed
NPTS = 9
#: how far from the struck edge (x1 = 0), in point spacings, sliding must start for a rupture block
AWAY = 10


def step_width(shift: float) -> float:
    """The interval [s] a rate row is the mean over, centred on the time it holds, from
    its ``time_shift_s``: a rate held half a step off the row's t^n is its step's mean
    (the rigid kind's slip rate V^{n+½}, the elastic kind's jump rate V^{n−½}:
    :data:`fricfem.output.quantities.TIME_SHIFT_STEPS`), a step wide; 0 (a value at an
    instant) for one held at t^n."""
    return 2.0 * abs(float(shift))


def rupture_times(times, slip_rate, threshold: float = THRESHOLD, slip=None, width: float = 0.0) -> np.ndarray:
    """t_r float64[n_p] [s]: the first time |slip_rate| (float64[n_t, n_p], m/s, at
    ``times`` float64[n_t], s) reaches ``threshold`` [m/s], interpolated between the
    row that reaches it and the row before (module docstring); NaN where it never
    does; ``times[0]`` where the first row already does.

    ``slip`` (float64[n_t, n_p], m, optional) places a crossing out of stick (rate 0
    in the row before, as ahead of a slip-weakening front) by the slip of the
    interval: a rate that left stick at t_s and reached V₁ at the row t₁ slipped
    between V₁ (t₁ − t_s)/2 (a linear rise) and V₁ (t₁ − t_s) (a jump), so t_s
    lies between t₁ − 2|Δslip|/V₁ and t₁ − |Δslip|/V₁; the midpoint,
    t₁ − 1.5|Δslip|/V₁ (within the interval: off by at most a third of it
    for either shape), and the crossing t_s + (threshold/V₁)(t₁ − t_s).  On tpv205_2d (1 and 0.5 mm, rows 0.6 µs apart)
    this is within 0.10 µs of the stations' step-by-step crossings, where the
    linear interpolation from the stick row (used without ``slip``) was 0.40 µs
    early.

    ``width`` [s]: each row's rate is the mean over an interval this long centred on
    its time (:func:`step_width`; 0: rates at instants).  A row of rate 0 then means
    no slip until its interval ends, so a crossing out of it is interpolated from
    (t₀ + width/2, 0) to (t₁, V₁), not from (t₀, 0): the linear interpolation from t₀
    would put a rate where the run's own slip stands still.  For the rigid kind's
    step rates every step this is what the peer's reading of its whole-step rates
    gives, the crossing at about the last time known to stick; on tpv205_2d (degree
    4, 1 mm) it halves the change of the rupture times between dt_safety 0.9 and
    0.1125 (44 → 26 ns worst; docs/elements.md, "Reading a rupture time")."""
    t = np.asarray(times, dtype=np.float64)
    v = np.abs(np.asarray(slip_rate, dtype=np.float64))
    if v.ndim != 2 or v.shape[0] != t.size:
        raise ValueError(f"slip_rate: shape {v.shape}, expected ({t.size}, n_points)")
    if not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold = {threshold!r} m/s: must be positive")
    above = v >= threshold
    hit = above.any(axis=0)
    k = np.argmax(above, axis=0)
    out = np.full(v.shape[1], np.nan)
    first = hit & (k == 0)
    out[first] = t[0]
    j = np.flatnonzero(hit & (k > 0))
    k1 = k[j]
    t0, t1 = t[k1 - 1], t[k1]
    v0, v1 = v[k1 - 1, j], v[k1, j]
    if width > 0.0:
        t0 = np.where(v0 == 0.0, np.minimum(t0 + 0.5 * width, t1), t0)
    with np.errstate(divide="ignore", invalid="ignore"):
        log = (v0 > 0) & (v1 > v0)
        frac = np.where(log, np.log(threshold / v0) / np.log(v1 / v0), (threshold - v0) / (v1 - v0))
    out[j] = t0 + np.clip(np.nan_to_num(frac, nan=1.0), 0.0, 1.0) * (t1 - t0)
    if slip is not None:
        d = np.asarray(slip, dtype=np.float64)
        if d.shape != v.shape:
            raise ValueError(f"slip: shape {d.shape}, expected {v.shape}")
        stick = (v0 == 0) & (v1 > 0)
        js, ks = j[stick], k1[stick]
        ds = np.abs(d[ks, js] - d[ks - 1, js])
        ok = np.isfinite(ds)
        ts = np.clip(t1[stick] - 1.5 * ds / v1[stick], t0[stick], t1[stick])
        cross = ts + (threshold / v1[stick]) * (t1[stick] - ts)
        out[js[ok]] = cross[ok]
    return out


def nucleation(x1, t_r, patch_tol: float = 0.0) -> dict | None:
    """The earliest ruptured point and the patch around it: ``{"time_s", "x1_m",
    "patch_x1_m": [a, b], "index", "patch": (i0, i1)}``, the patch being the
    contiguous points whose t_r is within ``patch_tol`` [s] of the earliest (its
    centre is the nucleation point); None when no point ruptured."""
    x1 = np.asarray(x1, dtype=np.float64)
    ok = np.isfinite(t_r)
    if not ok.any():
        return None
    t0 = float(np.nanmin(t_r))
    first = np.flatnonzero(t_r == t0)
    i = int(first[len(first) // 2])
    near = ok & (t_r <= t0 + patch_tol)
    i0 = i
    while i0 > 0 and near[i0 - 1]:
        i0 -= 1
    i1 = i
    while i1 < len(x1) - 1 and near[i1 + 1]:
        i1 += 1
    return {"time_s": t0, "x1_m": 0.5 * (x1[i0] + x1[i1]), "patch_x1_m": [float(x1[i0]), float(x1[i1])],
            "index": i, "patch": (i0, i1)}


def _window_slopes(s, t, npts: int) -> np.ndarray:
    """Least-squares slope dt/ds over a centred window of ``npts`` points (shrunk at
    the ends, at least 3): float64[n]; NaN where fewer than 3 points."""
    n = len(s)
    out = np.full(n, np.nan)
    half = max(1, npts // 2)
    for i in range(n):  # one front of at most a few thousand points, once per run
        a, b = max(0, i - half), min(n, i + half + 1)
        if b - a < 3:
            continue
        ss, tt = s[a:b], t[a:b]
        ds = ss - ss.mean()
        den = float(ds @ ds)
        if den > 0:
            out[i] = float(ds @ (tt - tt.mean())) / den
    return out


def front_speeds(x1, t_r, start: int, direction: int, npts: int = NPTS) -> dict:
    """The front running from point ``start`` in ``direction`` (+1: toward +x1, −1:
    toward −x1) over the contiguous ruptured points: ``{"index": int64[m],
    "x1_m", "time_s", "v_r_m_s": float64[m]}``, V_r = 1/(dt_r/ds) of the centred
    ``npts``-point least-squares slope (NaN where t_r does not increase outward:
    a front arriving from ahead, or the patch that broke at once)."""
    x1 = np.asarray(x1, dtype=np.float64)
    idx = []
    i = start
    while 0 <= i < len(x1) and np.isfinite(t_r[i]):
        idx.append(i)
        i += direction
    idx = np.asarray(idx, dtype=np.int64)
    s = np.abs(x1[idx] - x1[start]) if len(idx) else np.zeros(0)
    tt = np.asarray(t_r)[idx] if len(idx) else np.zeros(0)
    slope = _window_slopes(s, tt, npts)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(slope > 0, 1.0 / slope, np.nan)
    return {"index": idx, "x1_m": x1[idx], "time_s": tt, "v_r_m_s": v}


def transition(front: dict, speed: float, npts: int = NPTS) -> dict | None:
    """Where ``front`` (:func:`front_speeds`), after a point below ``speed`` [m/s],
    first exceeds it and stays above (or has no speed: a front from ahead) for
    ``npts`` points or to its end: ``{"x1_m", "time_s", "v_r_m_s"}``; None if never."""
    v = front["v_r_m_s"]
    fast = ~(v <= speed)  # NaN (t_r not increasing outward) counts as fast
    slow = np.flatnonzero(~fast)
    if not len(slow):
        return None
    n = len(v)
    for i in range(int(slow[0]) + 1, n):
        if fast[i] and fast[i:min(n, i + npts)].all() and np.isfinite(v[i]):
            return {"x1_m": float(front["x1_m"][i]), "time_s": float(front["time_s"][i]),
                    "v_r_m_s": float(v[i])}
    return None


def _mean_speed(front: dict, patch: tuple) -> float:
    """Least-squares slope of distance against t_r over the front outside the patch [m/s]."""
    keep = (front["index"] < patch[0]) | (front["index"] > patch[1])
    s, t = np.abs(front["x1_m"][keep] - front["x1_m"][0]), front["time_s"][keep]
    if np.size(t) < 2 or np.ptp(t) <= 0:
        return math.nan
    dt = t - t.mean()
    return float(dt @ (s - s.mean()) / (dt @ dt))


def station_times(stations: dict, threshold: float = THRESHOLD) -> dict:
    """{name: (x1 [m], t_r [s] or NaN)} of each station's own history (every step):
    ``stations`` {name: (x1, time float64[n], slip_rate float64[n][, width [s]])}
    (``width``: :func:`rupture_times`, 0 when not given)."""
    out = {}
    for name, (x, t, v, *width) in stations.items():
        t = np.asarray(t, dtype=np.float64)
        w = float(width[0]) if width else 0.0
        tr = rupture_times(t, np.asarray(v, dtype=np.float64)[:, None], threshold, width=w)[0] if len(t) else math.nan
        out[name] = (float(x), float(tr))
    return out


def station_histories(itf) -> dict:
    """{name: (x1 [m], time [s], slip_rate [m/s], width [s])} of an open interface file's
    stations that record a slip rate: each rate at the times it holds (``Station.time_of``:
    the rigid kind's V^{n+½} at t^{n+½}) with the interval it is the mean over
    (:func:`step_width`), as :func:`station_times` takes them."""
    return {n: (s.x1, s.time_of("slip_rate"), s.data["slip_rate"], step_width(s.shift.get("slip_rate", 0.0)))
            for n, s in itf.stations().items() if "slip_rate" in s.data}


def diagnose(times, x1, slip_rate, speeds: dict, *, threshold: float = THRESHOLD, stations=None,
             struck: bool = False, npts: int = NPTS, slip=None, width: float = 0.0) -> dict | None:
    """summary.json's ``rupture`` block, or None for a run struck at x1 = 0 whose
    sliding starts there (the impact's own diagnostics apply: tip, fronts, mode).

    times float64[n_t] [s], x1 float64[n_p] [m] (sorted), slip_rate float64[n_t,
    n_p] [m/s], speeds the reference wave speeds (:func:`fricfem.analysis.speeds.check_speeds`),
    stations {name: (x1, time, slip_rate[, width])} every step (optional), struck: the
    scene has an impact on the edge x1 = 0, slip float64[n_t, n_p] [m] (optional:
    :func:`rupture_times`), width [s] the interval each rate row is the mean over
    (:func:`step_width`)."""
    sp = check_speeds(speeds)
    x1 = np.asarray(x1, dtype=np.float64)
    t = np.asarray(times, dtype=np.float64)
    t_r = rupture_times(t, slip_rate, threshold, slip, width)
    row = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    nuc = nucleation(x1, t_r, patch_tol=row)
    spacing = float(np.median(np.diff(x1))) if len(x1) > 1 else 0.0
    if struck and (nuc is None or nuc["x1_m"] - x1[0] <= AWAY * spacing):
        return None
    block = {"threshold_m_s": threshold, "c_s_m_s": sp["c_s"], "sqrt2_c_s_m_s": sp["sqrt2_c_s"],
             "snapshot_interval_s": row, "ruptured": nuc is not None, "nucleation": None, "directions": []}
    field = {"x1_m": x1, "time_s": t_r}
    v_field = np.full(len(x1), np.nan)
    if nuc is not None:
        block["nucleation"] = {k: nuc[k] for k in ("time_s", "x1_m", "patch_x1_m")}
        i = nuc["index"]
        for direction, name in ((+1, "+x1"), (-1, "-x1")):
            front = front_speeds(x1, t_r, i, direction, npts)
            v_field[front["index"][1:]] = front["v_r_m_s"][1:]
            if len(front["index"]) < 2:
                continue
            block["directions"].append({
                "direction": name,
                "reached_x1_m": float(front["x1_m"][-1]), "reached_time_s": float(front["time_s"][-1]),
                "mean_v_r_m_s": _mean_speed(front, nuc["patch"]),
                "supershear": transition(front, sp["c_s"], npts),
                "above_sqrt2_c_s": transition(front, sp["sqrt2_c_s"], npts),
            })
    field["v_r_m_s"] = v_field
    block["field"] = field
    if stations:
        st = station_times(stations, threshold)
        block["stations"] = [{"name": n, "x1_m": x, "time_s": tr} for n, (x, tr) in
                             sorted(st.items(), key=lambda kv: kv[1][0])]
        block["between_stations"] = _between(st, nuc)
    return jsonable(block)


def _between(st: dict, nuc) -> list:
    """The rupture speed between consecutive ruptured stations on each side of the
    nucleation point (:func:`nucleation`), outward: [{"from", "to", "x1_m": [a, b],
    "v_r_m_s", "in_patch"}]; ``in_patch``: both stations in the patch that broke
    at once (their speed is no front's)."""
    out = []
    if nuc is None:
        return out
    x_nuc = nuc["x1_m"]
    lo, hi = nuc["patch_x1_m"]
    for side in (+1, -1):
        names = sorted((n for n, (x, tr) in st.items() if side * (x - x_nuc) >= 0 and math.isfinite(tr)),
                       key=lambda n: side * st[n][0])
        for a, b in zip(names, names[1:]):
            (xa, ta), (xb, tb) = st[a], st[b]
            v = abs(xb - xa) / (tb - ta) if tb > ta else math.nan
            out.append({"from": a, "to": b, "x1_m": [xa, xb], "v_r_m_s": v,
                        "in_patch": bool(lo <= xa <= hi and lo <= xb <= hi)})
    return out


def threshold_of(raw: dict) -> float:
    """``output.rupture_threshold`` of a scene's merged tables (summary.json ``input``), or the default."""
    value = ((raw or {}).get("output") or {}).get("rupture_threshold", THRESHOLD)
    return float(value)


def from_run(rundir, threshold: float | None = None) -> dict:
    """``{"rupture": block}`` of a run directory (its interface.h5 and the scene in its
    summary.json), or ``{}`` for a run struck at x1 = 0 that slid from there or has no
    rows (:func:`diagnose`).  ``threshold`` [m/s]: the scene's when None."""
    rundir = Path(rundir)
    if threshold is None:
        try:
            raw = json.loads((rundir / "summary.json").read_text()).get("input")
        except (OSError, ValueError):
            raw = None
        threshold = threshold_of(raw)
    with open_interface(rundir) as itf:
        if itf.n_time < 2 or not itf.has("slip_rate"):
            return {}
        speeds = {k: float(itf.attrs[k]) for k in ("c_R", "c_s", "sqrt2_c_s", "c_l")}
        struck = float(itf.attrs.get("v_imp", 0.0)) != 0.0
        # each at the time its rows hold (the rigid kind's slip rate: t^{n+½}, its step's mean; InterfaceFile.time_of)
        block = diagnose(itf.time_of("slip_rate"), itf.x1, itf.all("slip_rate"), speeds, threshold=threshold,
                         stations=station_histories(itf), struck=struck, slip=itf.all("slip") if itf.has("slip") else None,
                         width=step_width(itf.time_of("slip_rate")[0] - itf.time[0]) if itf.n_time else 0.0)
    return {} if block is None else {"rupture": block}
