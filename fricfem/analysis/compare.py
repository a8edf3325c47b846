"""``fricfem compare RUN_A RUN_B``: two runs of one problem side by side, one
line per station they share (rupture time, final slip, peak slip rate and the
relative L2 distance of the slip-rate histories) and one for the leading tip
(V_tip, and the largest distance between the two fronts of sliding).

B is the reference: distances are relative to B, as in a convergence study
where B is the finer run.  The metrics are :mod:`fricfem.analysis.convergence`'s.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..output.rundir import open_run
from . import convergence as conv


def _open(rundir):
    rundir = Path(rundir)
    if not (rundir / "interface.h5").is_file():
        raise ValueError(f"{rundir}: not a run directory (no interface.h5)")
    return open_run(rundir)


def compare(run_a, run_b, threshold: float = conv.RUPTURE_THRESHOLD) -> dict:
    """The comparison of two run directories as plain data (SI units): ``stations``
    [{name, x1_m, a: {...}, b: {...}, l2_rel}], ``only_a``/``only_b`` (station names in one
    run only), ``tip`` {a: {...}, b: {...}, front_distance_max_m}, ``rupture_time_error_s``."""
    ra, rb = _open(run_a), _open(run_b)
    rec_a, rec_b = conv.record(run_a), conv.record(run_b)
    common = [n for n in rb.stations if n in ra.stations]
    if not common:
        raise ValueError(f"{run_a} and {run_b}: no station in common (A has {', '.join(ra.stations) or 'none'}, "
                         f"B has {', '.join(rb.stations) or 'none'}); stations are output.stations of the scene")
    tr_a, tr_b = conv.rupture_times(rec_a, threshold), conv.rupture_times(rec_b, threshold)

    def side(run, rec, name, tr):
        st = run.stations[name]
        slip = st.get("slip", np.zeros(0))
        # the slip rate against the times it holds (a rigid pair's: t^{n+½}; the record's ``t``)
        t_v, v = rec["stations"][name]["t"], rec["stations"][name]["v"]
        k = int(np.argmax(v)) if len(v) else None
        return {"rupture_time_s": tr[name], "final_slip_m": float(slip[-1]) if len(slip) else math.nan,
                "peak_slip_rate_m_s": float(v[k]) if k is not None else math.nan,
                "peak_time_s": float(t_v[k]) if k is not None else math.nan,
                "t_last_s": float(st["time"][-1]) if len(st["time"]) else math.nan}

    rows = []
    for name in common:
        one_a = {**rec_a, "stations": {name: rec_a["stations"][name]}}
        one_b = {**rec_b, "stations": {name: rec_b["stations"][name]}}
        rows.append({"name": name, "x1_m": float(rb.stations[name]["x1"]),
                     "x1_a_m": float(ra.stations[name]["x1"]),
                     "a": side(ra, rec_a, name, tr_a), "b": side(rb, rec_b, name, tr_b),
                     "l2_rel": conv.station_l2(one_a, one_b)})

    def tip(run):
        t = run.summary.get("tip") or {}
        return {"v_tip_median_m_s": t.get("v_tip_median_m_s"), "v_tip_max_m_s": t.get("v_tip_max_m_s"),
                "last_x1_m": t.get("last_x1_m"), "mode": (run.summary.get("mode") or {}).get("label")}

    return {"a": str(run_a), "b": str(run_b), "threshold_m_s": threshold, "stations": rows,
            "only_a": [n for n in ra.stations if n not in rb.stations],
            "only_b": [n for n in rb.stations if n not in ra.stations],
            "tip": {"a": tip(ra), "b": tip(rb), "front_distance_max_m": conv.tip_error(rec_a, rec_b)},
            "rupture_time_error_s": conv.rupture_time_error(rec_a, rec_b),
            "runs": {k: {"scene": r.summary.get("scene"), "dt_s": r.summary.get("dt_s"), "dofs": r.summary.get("dofs"),
                         "complete": r.summary.get("complete"), "t_end_s": r.summary.get("t_end_s")}
                     for k, r in (("a", ra), ("b", rb))}}


def _f(v, scale=1.0, fmt=".3f", none="-") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return none
    return format(v * scale, fmt)


def text(cmp: dict) -> str:
    """The comparison as lines for people (µs, µm, m/s, mm)."""
    out = []
    for k in ("a", "b"):
        r = cmp["runs"][k]
        out.append(f"{k.upper()} = {cmp[k]}: {r['scene']}, dt {_f(r['dt_s'], 1e9, '.1f')} ns, {r['dofs']} dofs, "
                   f"to {_f(r['t_end_s'], 1e6, '.2f')} µs{'' if r['complete'] else ' (incomplete)'}")
    out.append(f"B is the reference; rupture: slip rate > {cmp['threshold_m_s']:g} m/s; L2: ‖v_A − v_B‖/‖v_B‖ of "
               f"the slip-rate history (A interpolated at B's times)")
    head = (f"{'station':>12s} {'x1 mm':>7s} | {'t_rupt A':>8s} {'B µs':>8s} {'ΔA−B':>7s} | {'slip A':>9s} "
            f"{'B µm':>9s} | {'peak A':>7s} {'B m/s':>7s} | {'L2 rel':>7s}")
    out += [head, "-" * len(head)]
    for s in cmp["stations"]:
        a, b = s["a"], s["b"]
        d = a["rupture_time_s"] - b["rupture_time_s"]
        out.append(f"{s['name']:>12s} {s['x1_m'] * 1e3:7.2f} | {_f(a['rupture_time_s'], 1e6, '8.3f', 'never'):>8s} "
                   f"{_f(b['rupture_time_s'], 1e6, '8.3f', 'never'):>8s} {_f(d, 1e6, '7.3f'):>7s} | "
                   f"{_f(a['final_slip_m'], 1e6, '9.4f'):>9s} {_f(b['final_slip_m'], 1e6, '9.4f'):>9s} | "
                   f"{_f(a['peak_slip_rate_m_s'], 1, '7.3f'):>7s} {_f(b['peak_slip_rate_m_s'], 1, '7.3f'):>7s} | "
                   f"{_f(s['l2_rel'], 1, '7.4f'):>7s}")
    ta, tb = cmp["tip"]["a"], cmp["tip"]["b"]
    out.append(f"tip: V_tip median A {_f(ta['v_tip_median_m_s'], 1, '.0f')} B {_f(tb['v_tip_median_m_s'], 1, '.0f')} "
               f"m/s, max A {_f(ta['v_tip_max_m_s'], 1, '.0f')} B {_f(tb['v_tip_max_m_s'], 1, '.0f')} m/s; last x1 "
               f"A {_f(ta['last_x1_m'], 1e3, '.2f')} B {_f(tb['last_x1_m'], 1e3, '.2f')} mm; fronts of sliding at most "
               f"{_f(cmp['tip']['front_distance_max_m'], 1e3, '.3f')} mm apart; mode A {ta['mode']} B {tb['mode']}")
    out.append(f"largest rupture-time difference over the stations: {_f(cmp['rupture_time_error_s'], 1e6, '.3f')} µs")
    for k in ("only_a", "only_b"):
        if cmp[k]:
            out.append(f"stations only in {k[-1].upper()}: {', '.join(cmp[k])}")
    return "\n".join(out)
