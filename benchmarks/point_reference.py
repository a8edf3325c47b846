"""fricfem's point-law integrators against independent scipy references, and the
stability of the Povirk–Needleman spring–slider.

    .venv/bin/python benchmarks/point_reference.py            # ~3 min, serial
    .venv/bin/python benchmarks/point_reference.py --quick    # smaller stability grid
    .venv/bin/python benchmarks/point_reference.py --only-rigid   # section 3 alone (the others kept)

Writes ``benchmarks/results/point_reference.{json,md,png}`` (``--out`` changes the
directory) and prints the tables.  Every reference is
tests/reference/laws: Radau (rtol 1e-11 unless said) on the laws'
continuous equations, exact piecewise solutions for slip weakening.

1. Ladders of bulk steps (200 … 5 ns) of ``advance`` for each law and regime
   against its reference: T_s at the step times, the T_s extremes of each slip
   cycle, the sampled slip-rate peak, the final slip, the state; observed orders.
2. Povirk–Needleman's plain rate-tangent update in regime (i).
3. ``rigid`` in the split-node step against the block slider, 100 … 5 ns.
4. The spring–slider's stability: linearised growth rates against the
   integration, and a grid of normal tractions and drive rates from the stick
   start (peak slip rate, settling or sustained oscillation) against the
   threshold T_n,c(v) = C_s L0 / (B |dμ_ss/d ln v|) (docs/friction_reference.md).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

from fricfem.friction import defaults, get_law, pack, validate
from fricfem.friction import povirk_needleman as pn
from fricfem.friction import povirk_needleman_rate_tangent as rt
from fricfem.friction import rate_state as rs
from fricfem.friction.driver import drive_jump_rate, ramp_jump, step_rates

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the scipy references (tests/reference)
from reference import laws as ref  # noqa: E402

MPa = 1e6
CS = 1e11
DTS = (200e-9, 100e-9, 50e-9, 20e-9, 10e-9, 5e-9)
PN = get_law("povirk_needleman")
P_PN = pack(PN, defaults(PN))


def ramp(vmax, tr):
    return lambda t: vmax * min(t / tr, 1.0)


def extrema(T):
    """Indices of the local maxima and minima of a sampled history."""
    imx = [i for i in range(1, len(T) - 1) if T[i] >= T[i - 1] and T[i] > T[i + 1]]
    imn = [i for i in range(1, len(T) - 1) if T[i] <= T[i - 1] and T[i] < T[i + 1]]
    return np.array(imx, dtype=int), np.array(imn, dtype=int)


def orders(dts, errs):
    """Observed orders between consecutive steps (None where an error is 0 or not finite)."""
    out = []
    for (d0, e0), (d1, e1) in zip(zip(dts, errs), zip(dts[1:], errs[1:])):
        out.append(math.log(e0 / e1) / math.log(d0 / d1) if e0 > 0 and e1 > 0 and np.isfinite(e0 + e1) else None)
    return out


def compare(h, r, k, Tn, Tn_scale=None):
    """Errors of a fricfem history ``h`` against the reference ``r`` sampled every k-th point."""
    Tsc = Tn_scale or Tn
    rT, rs_, rv, rst = r.Ts[::k], r.slip[::k], r.slip_rate[::k], r.state[::k]
    out = {
        "Ts_max_err": float(np.abs(h.Ts - rT).max() / Tsc),
        "slip_end_rel_err": float(abs(h.slip[-1] / rs_[-1] - 1.0)) if rs_[-1] > 0 else None,
        "rate_peak_sampled_rel_err": float(abs(h.slip_rate.max() / rv.max() - 1.0)) if rv.max() > 0 else None,
        "state_err": [float(np.abs(h.state[:, i] - rst[:, i]).max() / max(np.abs(rst[:, i]).max(), 1e-300))
                      for i in range(rst.shape[1])],
        "nsub": int(h.nsub.sum()),
    }
    # T_s extremes of the slip cycles (reference's extrema, matched in order)
    imx, imn = extrema(r.Ts)
    hx, hn = extrema(h.Ts)
    if len(imx):
        n = min(len(imx), len(hx))
        out["Ts_peaks_err"] = float(np.abs(h.Ts[hx[:n]] - r.Ts[imx[:n]]).max() / Tsc) if n else None
        n = min(len(imn), len(hn))
        out["Ts_troughs_err"] = float(np.abs(h.Ts[hn[:n]] - r.Ts[imn[:n]]).max() / Tsc) if n else None
    return out


# --- 1. ladders --------------------------------------------------------------------------


def ladder_ramp(law, name, Tn, vmax, tr, t_end, ref_dt=5e-9, params=None, dts=DTS, rtol=1e-11):
    t0 = time.perf_counter()
    tt = np.linspace(0.0, t_end, int(round(t_end / ref_dt)) + 1)
    r = ref.spring_slider(law, params, tt, ramp(vmax, tr), Tn, CS, breaks=(tr,), rtol=rtol)
    tref = time.perf_counter() - t0
    rows = []
    for dt in dts:
        t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
        h = drive_jump_rate(law, t, step_rates(t, ramp_jump(t, vmax, tr)), Tn, CS, params=params)
        rows.append({"dt_ns": dt * 1e9, **compare(h, r, int(round(dt / ref_dt)), Tn)})
    return {"case": name, "law": law.name, "Tn_MPa": Tn / MPa, "jump_rate": vmax, "ramp_us": tr * 1e6,
            "t_end_us": t_end * 1e6, "ref_peak_rate": r.peak_rate, "ref_t_peak_us": r.t_peak * 1e6,
            "ref_seconds": tref, "ref_nfev": r.nfev, "rows": rows}, r


def ladder_rs_step(name, Tn=5 * MPa, v1=1.0, v2=10.0, dts=DTS):
    law = get_law(name)
    p = pack(law, defaults(law))
    kind = rs.AGING if name.endswith("aging") else rs.SLIP
    ts = (0.2e-6, 1.2e-6)
    t_end = 2.6e-6
    psi0 = rs.psi_ss_py(kind, p, v1)
    Ts0 = rs.mu(p, v1, psi0) * Tn
    tt = np.linspace(0.0, t_end, 2601)
    t0 = time.perf_counter()
    r = ref.spring_slider(law, None, tt, lambda t: v2 if ts[0] <= t < ts[1] else v1, Tn, CS, Ts0=Ts0,
                          state0=[psi0], breaks=ts, rtol=1e-12)
    tref = time.perf_counter() - t0
    rows = []
    for dt in dts:
        t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
        mid = 0.5 * (t[:-1] + t[1:])
        h = drive_jump_rate(law, t, np.where((mid >= ts[0]) & (mid < ts[1]), v2, v1), Tn, CS, Ts0=Ts0,
                            state0=[psi0])
        c = compare(h, r, int(round(dt / 1e-9)), Tn)
        c["state_err"] = [float(np.abs(h.state[:, 0] - r.state[:: int(round(dt / 1e-9)), 0]).max())]  # absolute in Ψ
        rows.append({"dt_ns": dt * 1e9, **c})
    return {"case": f"{name}: steady 1 m/s, jump rate 1 → 10 → 1 m/s, 5 MPa", "law": name, "Tn_MPa": Tn / MPa,
            "ref_peak_rate": r.peak_rate, "ref_seconds": tref, "rows": rows}


def ladder_pn_smooth():
    """Povirk–Needleman, smooth history, fine steps: the integrator's order."""
    Tn0, T = 1 * MPa, 1e-6
    s0 = pn.steady_state(P_PN, 10.0, Tn0)
    Ts0 = PN.steady_mu(P_PN, 10.0) * Tn0
    Tnf = lambda t: Tn0 * (1.0 - 0.3 * t / T)  # noqa: E731
    tt = np.linspace(0.0, T, 1025)
    r = ref.spring_slider(PN, None, tt, lambda t: 10.0 + 90.0 * t / T, Tnf, CS, Ts0=Ts0, state0=s0, rtol=1e-12)
    rows = []
    for n in (16, 32, 64, 128, 256, 512, 1024):
        t = np.linspace(0.0, T, n + 1)
        h = drive_jump_rate(PN, t, step_rates(t, 10.0 * t + 45.0 * t * t / T), Tnf(t), CS, Ts0=Ts0, state0=s0)
        rows.append({"dt_ns": T / n * 1e9, **compare(h, r, 1024 // n, Tn0)})
    return {"case": "povirk_needleman: smooth (10 → 100 m/s, T_n 1 → 0.7 MPa over 1 µs, from steady sliding)",
            "law": "povirk_needleman", "rows": rows}


def ladder_sw():
    rows = []
    for Dc, label in ((1e-4, "weakening branch"), (1e-6, "snap-back")):
        prm = {"Dc": Dc}
        for dt in DTS:
            t = np.linspace(0.0, 12e-6, int(round(12e-6 / dt)) + 1)
            jump = ramp_jump(t, 21.0, 1e-6)  # 21: the onset falls between steps
            h = drive_jump_rate(get_law("slip_weakening"), t, step_rates(t, jump), 10 * MPa, CS, params=prm)
            e = ref.slip_weakening_spring(prm, t, jump, 10 * MPa, CS)
            rows.append({"Dc_m": Dc, "branch": label, "dt_ns": dt * 1e9,
                         "Ts_max_err": float(np.abs(h.Ts - e.Ts).max() / (10 * MPa)),
                         "slip_max_err": float(np.abs(h.slip - e.slip).max() / e.slip[-1])})
    return {"case": "slip_weakening: exact piecewise solution, 10 MPa, ramp to 21 m/s in 1 µs", "rows": rows}


def rate_tangent_regime_i(r, Tn=30 * MPa, t_end=20e-6, ref_dt=5e-9):
    out = []
    for dt in DTS:
        t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
        with np.errstate(all="ignore"):
            h = drive_jump_rate(PN, t, step_rates(t, ramp_jump(t, 20.0, 2e-6)), Tn, CS,
                                advance=rt.rate_tangent_advance)
        k = int(round(dt / ref_dt))
        err = np.abs(h.Ts - r.Ts[::k]) / Tn
        bad = ~np.isfinite(h.Ts) | ~(h.state[:, 0] > 0.0)
        ib = int(np.argmax(bad)) if bad.any() else None
        over = err > 0.01
        out.append({"dt_ns": dt * 1e9,
                    "fails_at_us": float(t[ib] * 1e6) if ib is not None else None,
                    "departs_1pc_at_us": float(t[int(np.argmax(over))] * 1e6) if over.any() else None,
                    "max_err_before_failure": float(np.nanmax(err[:ib] if ib else err))})
    return out


# --- 3. rigid ------------------------------------------------------------------------------


def _rigid_errors(r, V, T, slip, dt, g):
    """Errors of ``drive_rigid``'s history against the block reference ``r`` sampled every
    ``g``: the velocity at the half steps (max / reference peak), the final slip
    (relative), the traction of the steps that slide away from a change of regime
    (max / T_n; a step on the other side of a switch is off by the jump)."""
    k = int(round(dt / g))
    rv = r.slip_rate[::k][:len(T)]
    inside = np.zeros(len(T), bool)
    inside[1:-1] = (V[1:-1] != 0) & (V[:-2] != 0) & (rv[:-2] != 0) & (rv[1:-1] != 0) & (rv[2:] != 0)
    return {"V_err": float(np.abs(V - r.slip_rate[k // 2::k][:len(V)]).max() / r.peak_rate),
            "slip_end_rel_err": float(abs(slip[-1] / r.slip[-1] - 1.0)),
            "Ts_sliding_err": float(np.abs(T[inside] - r.Ts[::k][:len(T)][inside]).max() / r.Tn[0])}


def ladder_rigid():
    """``rigid`` in the split-node step (:func:`reference.drive_rigid`: velocity at the
    half steps, the traction of tⁿ) against the block reference at the half steps."""
    cases = []
    m, tF = 0.1, 4e-6
    specs = [("povirk_needleman", {}, None), ("slip_weakening", {"Dc": 1e-5}, None),
             ("rate_state_aging", {}, 1e-3), ("rate_state_slip", {}, 1e-3)]
    g = 2.5e-9  # the reference's grid: the half steps of the finest run
    for name, prm, Vi in specs:
        law = get_law(name)
        p = pack(law, validate(law, prm))
        Tn = 10 * MPa
        if Vi is None:
            t_end, s0, F0, dF = 5e-6, None, 0.0, 8 * MPa
        else:
            kind = rs.AGING if name.endswith("aging") else rs.SLIP
            psi0 = rs.psi_ss_py(kind, p, Vi)
            t_end, s0, F0, dF = 6e-6, [psi0], rs.mu(p, Vi, psi0) * Tn, 3 * MPa
        F = lambda t, F0=F0, dF=dF: F0 + dF * math.sin(math.pi * t / tF) ** 2 if t < tF else F0  # noqa: E731
        tt = np.linspace(0.0, t_end, int(round(t_end / g)) + 1)
        t0 = time.perf_counter()
        r = ref.block_slider(law, prm, tt, F, m, Tn, V_init=Vi or 0.0, state0=s0, max_step=2 * g)
        tref = time.perf_counter() - t0
        rows = []
        for dt in (100e-9, 50e-9, 20e-9, 10e-9, 5e-9):
            t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
            V, T, slip, work, st, nit = ref.drive_rigid(law, prm, t, F, m, Tn, V_init=Vi or 0.0, state0=s0)
            rows.append({"dt_ns": dt * 1e9, **_rigid_errors(r, V, T, slip, dt, g),
                         "iterations_per_step": float(nit.mean())})
        cases.append({"law": name, "params": prm, "mass": m, "Tn_MPa": 10.0, "V_init": Vi or 0.0,
                      "force": f"{F0 / MPa:.3f} MPa + {dF / MPa:g} MPa sin²(π t / 4 µs), t < 4 µs",
                      "ref_peak_V": r.peak_rate, "ref_seconds": tref, "rows": rows})
    return cases


# --- 4. stability of the Povirk–Needleman spring–slider ---------------------------------


def dmu_dlnv(v):
    """−dμ_ss/d ln v = (μs − μd) p y e^(−y), y = (v/V1)^p."""
    p = P_PN
    y = (v / p[pn.V1]) ** p[pn.P]
    return (p[pn.MU_S] - p[pn.MU_D]) * p[pn.P] * y * math.exp(-y)


def tn_crit(v, Cs=CS):
    """Hopf threshold of steady sliding at v: T_n,c = C_s L0 / (B (−dμ_ss/d ln v))."""
    return Cs * P_PN[pn.L0] / (P_PN[pn.B] * dmu_dlnv(v))


def kappa(th0):
    """κ(θ0) = d ln g / d ln θ0 (central difference of the plain-Python g)."""
    h = 1e-5
    return (math.log(pn._g_plain(P_PN, th0 * (1 + h))) - math.log(pn._g_plain(P_PN, th0 * (1 - h)))) / (
        math.log(1 + h) - math.log(1 - h))


def eigen(vs, Tn, Cs=CS):
    """Eigenvalues of the spring–slider linearised about steady sliding at vs (T_n const)."""
    p = P_PN
    th = p[pn.L0] / vs
    T = PN.steady_mu(p, vs) * Tn
    g = pn._g_plain(p, th)
    dg = kappa(th) * g / th
    m, V0, B, L0 = p[pn.M], p[pn.V0], p[pn.B], p[pn.L0]
    vT = m * (V0 + vs) / T
    vth = -m * (V0 + vs) * dg / g
    J = np.array([[-Cs * vT, -Cs * vth], [-B * th * vT / L0, -B * vs / L0 - B * th * vth / L0]])
    return np.linalg.eigvals(J)


def linear_checks():
    rows = []
    for vs, Tn in [(20.0, 8.0), (20.0, 9.5), (20.0, 10.3), (20.0, 11.0), (20.0, 12.0),
                   (100.0, 40.0), (100.0, 60.0), (100.0, 100.0), (100.0, 120.0)]:
        Tn *= MPa
        lam = eigen(vs, Tn)[0]
        per = 2 * math.pi / abs(lam.imag)
        t = np.linspace(0.0, 6 * per, 3001)
        r = ref.spring_slider(PN, None, t, lambda _: vs, Tn, CS, Ts0=PN.steady_mu(P_PN, vs) * Tn * (1 + 1e-4),
                              state0=pn.steady_state(P_PN, vs, Tn), rtol=1e-12)
        d = np.abs(r.slip_rate - vs)
        pk = [i for i in range(1, len(d) - 1) if d[i] >= d[i - 1] and d[i] > d[i + 1]][1:]
        sig = float(np.polyfit(t[pk], np.log(d[pk]), 1)[0])
        rows.append({"v": vs, "Tn_MPa": Tn / MPa, "Tn_crit_MPa": tn_crit(vs) / MPa, "Re_lambda": float(lam.real),
                     "measured_growth_rate": sig, "period_ns": per * 1e9,
                     "measured_period_ns": float(2 * np.mean(np.diff(t[pk])) * 1e9)})
    return rows


def stick_start(vs, Tn, t_end, tr=2e-6):
    """From the initial state (θ0 = L0/(10 V1), T_s = 0), jump rate ramped to vs in tr."""
    tt = np.linspace(0.0, t_end, int(round(t_end / 10e-9)) + 1)
    t0 = time.perf_counter()
    r = ref.spring_slider(PN, None, tt, ramp(vs, tr), Tn, CS, breaks=(tr,), rtol=1e-10)
    v = r.slip_rate
    late = tt > 0.75 * t_end
    mid = (tt > 0.5 * t_end) & ~late
    amp_late = float((v[late].max() - v[late].min()) / vs)
    amp_mid = float((v[mid].max() - v[mid].min()) / vs)
    sticks = bool((v[late] == 0.0).any())
    if sticks:
        kind = "stick-slip"
    elif amp_late < 1e-3 or amp_late < 0.3 * amp_mid:
        kind = "settles"
    else:
        kind = "oscillates"
    # the onset event: T_s, θ0 and θ0 v/L0 at the slip-rate peak (sampled grid)
    i = int(np.argmax(v))
    th0 = r.state[i, 0]
    return {"v": vs, "Tn_MPa": Tn / MPa, "Tn_crit_MPa": tn_crit(vs) / MPa, "peak_rate": r.peak_rate,
            "t_peak_us": r.t_peak * 1e6, "amp_mid": amp_mid, "amp_late": amp_late, "sticks_late": sticks,
            "outcome": kind, "at_sampled_peak": {"Ts_MPa": float(abs(r.Ts[i]) / MPa), "theta0_v_over_L0":
                                                  float(th0 * v[i] / P_PN[pn.L0]),
                                                  "growth_threshold_MPa": float(CS * P_PN[pn.L0] / (
                                                      P_PN[pn.B] * kappa(th0)) / MPa)},
            "t_end_us": t_end * 1e6, "segments": r.segments, "seconds": time.perf_counter() - t0}


def stability(quick):
    vss = (10.0, 20.0, 50.0, 100.0) if quick else (10.0, 20.0, 26.0, 50.0, 100.0)
    tns = (4.0, 8.0, 12.0, 20.0, 40.0) if quick else (4.0, 8.0, 9.5, 10.5, 11.0, 12.0, 20.0, 30.0, 40.0, 60.0)
    grid = []
    for vs in vss:
        for tn in tns:
            if not quick and ((vs in (10.0, 50.0, 26.0) and tn in (9.5, 10.5, 11.0, 30.0, 60.0))
                              or (vs == 20.0 and tn == 60.0) or (vs == 100.0 and tn == 10.5)):
                continue
            grid.append(stick_start(vs, tn * MPa, 30e-6))
            g = grid[-1]
            print(f"  v {vs:5.0f} m/s  T_n {tn:5.1f} MPa  (T_n,c {g['Tn_crit_MPa']:6.2f})  "
                  f"peak {g['peak_rate']:9.4g} m/s  {g['outcome']:10s} "
                  f"amp {g['amp_mid']:.2e} → {g['amp_late']:.2e}  {g['seconds']:.1f} s", flush=True)
    regime_ii = [stick_start(100.0, tn * MPa, 8e-6) for tn in (6.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)]
    for r in regime_ii:  # the same with the jump rate stepped to 100 m/s at t = 0 instead of ramped
        tt = np.linspace(0.0, 8e-6, 801)
        r["peak_rate_step_loading"] = ref.spring_slider(PN, None, tt, lambda t: 100.0, r["Tn_MPa"] * MPa, CS,
                                                        rtol=1e-10).peak_rate
    th = np.geomspace(1e-11, 1e-4, 400)
    kap = np.array([kappa(x) for x in th])
    theory = {
        "m_L0_Cs_MPa": P_PN[pn.M] * P_PN[pn.L0] * CS / MPa,
        "m_L0_Cs_over_B_MPa": P_PN[pn.M] * P_PN[pn.L0] * CS / P_PN[pn.B] / MPa,
        "Tn_crit_MPa": {f"{v:g}": tn_crit(v) / MPa for v in (5, 10, 20, 26, 50, 100, 200)},
        "Tn_crit_min_MPa": tn_crit(P_PN[pn.V1]) / MPa,
        "kappa_max": float(kap.max()), "theta0_at_kappa_max": float(th[np.argmax(kap)]),
        "kappa_small_theta0": float(kap[0]), "growth_threshold_min_MPa": float(
            CS * P_PN[pn.L0] / (P_PN[pn.B] * kap.max()) / MPa),
    }
    return theory, grid, regime_ii


# --- output ----------------------------------------------------------------------------------


def fmt(x, f="{:.2e}"):
    return "—" if x is None else f.format(x)


def markdown(doc):
    L = ["# Point laws against independent references", "",
         f"`.venv/bin/python benchmarks/point_reference.py` — {doc['seconds']:.0f} s on {doc['host']}, "
         f"{doc['date']}" + (f" (section 3, the rigid verb: `--only-rigid`, {doc['rigid_date']})"
                             if "rigid_date" in doc else "")
         + ". Errors of T_s relative to T_n; references: `tests/reference/laws/`.", ""]
    L += ["## Ladders of bulk steps (`advance`)", ""]
    for c in doc["ladders"]:
        L += [f"### {c['case']}", ""]
        if "ref_peak_rate" in c:
            L += [f"Reference peak slip rate {c['ref_peak_rate']:.4g} m/s"
                  + (f" at {c['ref_t_peak_us']:.3f} µs" if "ref_t_peak_us" in c else "") + ".", ""]
        L += ["| dt [ns] | T_s at steps | T_s peaks | T_s troughs | sampled peak rate | final slip "
              "| state (max error / max) | sub-steps |",
              "|---|---|---|---|---|---|---|---|"]
        for r in c["rows"]:
            L.append(f"| {r['dt_ns']:g} | {fmt(r['Ts_max_err'])} | {fmt(r.get('Ts_peaks_err'))} | "
                     f"{fmt(r.get('Ts_troughs_err'))} | {fmt(r['rate_peak_sampled_rel_err'])} | "
                     f"{fmt(r['slip_end_rel_err'])} | {', '.join(fmt(x) for x in r['state_err'])} | {r['nsub']} |")
        o = orders([r["dt_ns"] for r in c["rows"]], [r["Ts_max_err"] for r in c["rows"]])
        L += ["", "Observed orders (T_s): " + ", ".join(fmt(x, "{:.2f}") for x in o), ""]
    L += ["### slip weakening: exact solution", "", "| Dc | branch | dt [ns] | T_s | slip |", "|---|---|---|---|---|"]
    for r in doc["slip_weakening"]["rows"]:
        L.append(f"| {r['Dc_m']:g} m | {r['branch']} | {r['dt_ns']:g} | {fmt(r['Ts_max_err'])} | "
                 f"{fmt(r['slip_max_err'])} |")
    L += ["", "## Plain rate-tangent update, regime (i)", "",
          "| dt [ns] | fails (θ0 <= 0 / NaN) at [µs] | departs by 1 % T_n at [µs] | max error before |", "|---|---|---|---|"]
    for r in doc["rate_tangent_regime_i"]:
        L.append(f"| {r['dt_ns']:g} | {fmt(r['fails_at_us'], '{:.2f}')} | {fmt(r['departs_1pc_at_us'], '{:.2f}')} | "
                 f"{fmt(r['max_err_before_failure'])} |")
    L += ["", "## Rigid verb: block sliders (`rigid`)", "",
          "fricfem's split-node step on a block (`reference.drive_rigid`: the velocity at the half steps "
          "V^{n+½}, the friction traction of the step at tⁿ, the slip and the state at whole steps, a half "
          "step to start) against the block's reference sampled at the same times.  V: max |V^{n+½} − "
          "V(t^{n+½})| / peak; T_s: max |Tⁿ − T(tⁿ)| / T_n over the steps that slide, away from a change "
          "of regime (a step on the other side of a stick/slip switch is off by the jump there).", ""]
    for c in doc["rigid"]:
        L += [f"**{c['law']}** {c['params'] or ''}: m = {c['mass']} kg/m², T_n = 10 MPa, V(0) = {c['V_init']:g} m/s, "
              f"F = {c['force']}; reference peak V {c['ref_peak_V']:.4g} m/s", "",
              "| dt [ns] | V error / peak | T_s sliding / T_n | final slip | iterations / step |",
              "|---|---|---|---|---|"]
        for r in c["rows"]:
            L.append(f"| {r['dt_ns']:g} | {fmt(r['V_err'])} | {fmt(r.get('Ts_sliding_err'))} | "
                     f"{fmt(r['slip_end_rel_err'])} | {r['iterations_per_step']:.2f} |")
        dts = [r["dt_ns"] for r in c["rows"]]
        L += ["", "Observed orders, V: " + ", ".join(fmt(x, "{:.2f}") for x in orders(dts, [r["V_err"] for r in
                                                                                         c["rows"]]))
              + "; final slip: " + ", ".join(fmt(x, "{:.2f}") for x in orders(dts, [r["slip_end_rel_err"] for r in
                                                                                    c["rows"]]))
              + f"; V over the whole ladder ({dts[0]:g} → {dts[-1]:g} ns): "
              + fmt(math.log(c["rows"][0]["V_err"] / c["rows"][-1]["V_err"]) / math.log(dts[0] / dts[-1]), "{:.2f}"),
              ""]
    th = doc["stability"]["theory"]
    L += ["## Stability of the Povirk–Needleman spring–slider (C_s = 1e11 Pa/m, Table 1)", "",
          f"m L0 C_s = {th['m_L0_Cs_MPa']:.2f} MPa, m L0 C_s / B = {th['m_L0_Cs_over_B_MPa']:.3f} MPa, "
          f"κ = d ln g/d ln θ0 ≤ {th['kappa_max']:.4f} (→ 1/m = {th['kappa_small_theta0']:.4f} as θ0 → 0): "
          f"transient growth needs |T_s| > C_s L0/(B κ) ≥ {th['growth_threshold_min_MPa']:.3f} MPa.", "",
          "T_n,c(v) = C_s L0 / (B |dμ_ss/d ln v|): " + ", ".join(
              f"{v} m/s: {x:.2f} MPa" for v, x in th["Tn_crit_MPa"].items())
          + f" (minimum {th['Tn_crit_min_MPa']:.2f} MPa at v = V1).", "",
          "### Linearised growth rate against the integration (perturbation 1e-4 of T_s)", "",
          "| v [m/s] | T_n [MPa] | T_n,c [MPa] | Re λ [1/s] | measured [1/s] | period [ns] | measured |",
          "|---|---|---|---|---|---|---|"]
    for r in doc["stability"]["linear"]:
        L.append(f"| {r['v']:g} | {r['Tn_MPa']:g} | {r['Tn_crit_MPa']:.2f} | {r['Re_lambda']:.5g} | "
                 f"{r['measured_growth_rate']:.5g} | {r['period_ns']:.1f} | {r['measured_period_ns']:.1f} |")
    L += ["", "### From the stick start (2 µs ramp, 30 µs)", "",
          "| v [m/s] | T_n [MPa] | T_n,c [MPa] | peak slip rate [m/s] | outcome | rate amplitude / v, 15–22.5 µs → 22.5–30 µs |",
          "|---|---|---|---|---|---|"]
    for r in doc["stability"]["grid"]:
        L.append(f"| {r['v']:g} | {r['Tn_MPa']:g} | {r['Tn_crit_MPa']:.2f} | {r['peak_rate']:.4g} | {r['outcome']} | "
                 f"{r['amp_mid']:.2e} → {r['amp_late']:.2e} |")
    L += ["", "### Regime (ii): 100 m/s (2 µs ramp), onset events", "",
          "| T_n [MPa] | peak slip rate [m/s] | at [µs] | outcome (8 µs) | |T_s| at sampled peak [MPa] | θ0 v/L0 there "
          "| peak with a step to 100 m/s at t = 0 |",
          "|---|---|---|---|---|---|---|"]
    for r in doc["stability"]["regime_ii"]:
        a = r["at_sampled_peak"]
        L.append(f"| {r['Tn_MPa']:g} | {r['peak_rate']:.4g} | {r['t_peak_us']:.3f} | {r['outcome']} | "
                 f"{a['Ts_MPa']:.2f} | {a['theta0_v_over_L0']:.3g} | {r['peak_rate_step_loading']:.4g} |")
    L.append("")
    return "\n".join(L)


def figure(doc, r_i, hist, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(14, 9))
    ax1 = fig.add_subplot(2, 2, 1)
    styles = {"Ts_max_err": "-", "slip_end_rel_err": "--"}
    colors = plt.get_cmap("tab10")
    for i, c in enumerate(doc["ladders"]):
        dts = [r["dt_ns"] for r in c["rows"]]
        for q, ls in styles.items():
            e = [r[q] for r in c["rows"]]
            if all(x is not None and x > 1e-12 for x in e):  # (a slip exact to round-off is not drawn)
                ax1.loglog(dts, e, ls, color=colors(i), marker="o", ms=3,
                           label=f"{c['case'][:38]} · {'T_s' if q[0] == 'T' else 'slip'}")
    ax1.set(xlabel="bulk step dt [ns]", ylabel="error (T_s / T_n, slip relative)",
            title="advance against the scipy references")
    ax1.legend(fontsize=5.5, loc="lower right")
    ax1.grid(True, which="both", alpha=0.3)
    ax2 = fig.add_subplot(2, 2, 2)
    for c in doc["rigid"]:
        ax2.loglog([r["dt_ns"] for r in c["rows"]], [r["V_err"] for r in c["rows"]], "-o", ms=3, label=c["law"])
    d = np.array([5, 100])
    ax2.loglog(d, 0.01 * d / 50, "k:", label="order 1")
    ax2.loglog(d, 1e-3 * (d / 50) ** 2, "k--", lw=0.8, label="order 2")
    ax2.set(xlabel="dt [ns]", ylabel="max |V − V_ref| / peak", title="rigid in the split-node step (block slider) against scipy")
    ax2.legend(fontsize=7)
    ax2.grid(True, which="both", alpha=0.3)
    ax3 = fig.add_subplot(2, 2, 3)
    h50, rt50 = hist
    ax3.plot(r_i.t * 1e6, r_i.Ts / MPa, "k-", lw=1.2, label="reference (Radau)")
    ax3.plot(h50.t * 1e6, h50.Ts / MPa, "C0.", ms=3, label="fricfem advance, 50 ns")
    ok = np.isfinite(rt50.Ts) & (rt50.state[:, 0] > 0)
    n = int(np.argmin(ok)) if not ok.all() else len(ok)
    ax3.plot(rt50.t[:n] * 1e6, rt50.Ts[:n] / MPa, "C3x", ms=4, label="rate tangent, 50 ns (fails at ×)")
    ax3.set(xlabel="t [µs]", ylabel="T_s [MPa]", title="regime (i): T_n = 30 MPa, jump rate → 20 m/s in 2 µs",
            xlim=(9.5, 20))
    ax3b = ax3.twinx()
    ax3b.semilogy(r_i.t * 1e6, np.maximum(r_i.slip_rate, 1e-3), "0.6", lw=0.8)
    ax3b.set_ylabel("reference slip rate [m/s] (grey)")
    ax3.legend(fontsize=7, loc="lower left")
    ax4 = fig.add_subplot(2, 2, 4)
    vv = np.geomspace(3, 300, 200)
    ax4.loglog(vv, [tn_crit(v) / MPa for v in vv], "k-", label="T_n,c(v): steady sliding unstable above")
    mk = {"settles": ("o", "C2"), "oscillates": ("s", "C1"), "stick-slip": ("^", "C3")}
    seen = set()
    for r in doc["stability"]["grid"]:
        m, col = mk[r["outcome"]]
        ax4.loglog(r["v"], r["Tn_MPa"], m, color=col, ms=7, label=None if r["outcome"] in seen else r["outcome"])
        seen.add(r["outcome"])
    ax4.axhline(doc["stability"]["theory"]["m_L0_Cs_MPa"], color="0.5", ls=":", lw=1)
    ax4.text(3.2, doc["stability"]["theory"]["m_L0_Cs_MPa"] * 1.05,
             "m L0 C_s = 10 MPa (the old 'runaway' bound, on |T_s|)", fontsize=7)
    ax4.annotate("stick–slip below T_n,c: coexists\nwith stable steady sliding", xy=(100, 45), xytext=(8, 110),
                 fontsize=7, arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax4.set(xlabel="drive (jump) rate [m/s]", ylabel="T_n [MPa]", title="spring–slider from the stick start, 30 µs",
            ylim=(0.8, 300))
    ax4.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def _histories():
    """Regime (i) at 50 ns: fricfem's advance and the plain rate-tangent update."""
    t = np.linspace(0.0, 20e-6, 401)
    h50 = drive_jump_rate(PN, t, step_rates(t, ramp_jump(t, 20.0, 2e-6)), 30 * MPa, CS)
    with np.errstate(all="ignore"):
        rt50 = drive_jump_rate(PN, t, step_rates(t, ramp_jump(t, 20.0, 2e-6)), 30 * MPa, CS,
                               advance=rt.rate_tangent_advance)
    return h50, rt50


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    ap.add_argument("--quick", action="store_true", help="a smaller stability grid")
    ap.add_argument("--figure-only", action="store_true", help="redraw the figure from the stored JSON")
    ap.add_argument("--only-rigid", action="store_true",
                    help="redo section 3 (the rigid verb) alone, keeping the stored others")
    args = ap.parse_args(argv)
    if args.figure_only or args.only_rigid:
        doc = json.loads((args.out / "point_reference.json").read_text())
        if args.only_rigid:
            t0 = time.perf_counter()
            doc["rigid"] = ladder_rigid()
            doc["rigid_date"] = time.strftime("%Y-%m-%d %H:%M")
            for c in doc["rigid"]:
                print(f"  {c['law']}: " + "  ".join(f"{r['dt_ns']:g} ns {r['V_err']:.2e}" for r in c["rows"]))
            (args.out / "point_reference.json").write_text(json.dumps(doc, indent=1, default=float))
            (args.out / "point_reference.md").write_text(markdown(doc))
            print(f"section 3 in {time.perf_counter() - t0:.0f} s")
        tt = np.linspace(0.0, 20e-6, 4001)
        r_i = ref.spring_slider(PN, None, tt, ramp(20.0, 2e-6), 30 * MPa, CS, breaks=(2e-6,), rtol=1e-11)
        figure(doc, r_i, _histories(), args.out / "point_reference.png")
        return doc
    t_all = time.perf_counter()
    doc = {"date": time.strftime("%Y-%m-%d %H:%M"), "host": platform.node() or "this machine", "Cs": CS}
    print("1. ladders", flush=True)
    lad = []
    c, r_i = ladder_ramp(PN, "povirk_needleman regime (i): 30 MPa, → 20 m/s in 2 µs, 20 µs", 30 * MPa, 20.0, 2e-6,
                         20e-6)
    lad.append(c)
    # tolerance independence of the reference in regime (i)
    tt = np.linspace(0.0, 20e-6, 4001)
    r10 = ref.spring_slider(PN, None, tt, ramp(20.0, 2e-6), 30 * MPa, CS, breaks=(2e-6,), rtol=1e-10)
    r12 = ref.spring_slider(PN, None, tt, ramp(20.0, 2e-6), 30 * MPa, CS, breaks=(2e-6,), rtol=1e-12)
    imx, imn = extrema(r12.Ts)
    doc["regime_i_reference"] = {
        "rtol_1e-10_vs_1e-12": {"Ts": float(np.abs(r10.Ts - r12.Ts).max() / (30 * MPa)),
                                "slip": float(np.abs(r10.slip - r12.slip).max() / r12.slip[-1]),
                                "peak_rate": float(abs(r10.peak_rate / r12.peak_rate - 1))},
        "Ts_peaks_MPa": [float(x) for x in r12.Ts[imx] / MPa], "Ts_troughs_MPa": [float(x) for x in r12.Ts[imn] / MPa],
        "t_peaks_us": [float(x) for x in r12.t[imx] * 1e6], "peak_rate": r12.peak_rate, "t_peak_us": r12.t_peak * 1e6,
        # slip-rate peak of each slip event: the dense maximum of each sliding segment
        "event_peaks": [{"t_us": tp * 1e6, "rate": vp} for tp, vp in r12.segment_peaks if vp > 1.0],
    }
    for Tn in (6.0, 40.0):
        c, _ = ladder_ramp(PN, f"povirk_needleman regime (ii): {Tn:g} MPa, → 100 m/s in 2 µs, 8 µs", Tn * MPa, 100.0,
                           2e-6, 8e-6)
        lad.append(c)
    lad.append(ladder_pn_smooth())
    c, _ = ladder_ramp(get_law("rate_state_aging"), "rate_state_aging: from creep, 5 MPa, → 20 m/s in 2 µs, 10 µs",
                       5 * MPa, 20.0, 2e-6, 10e-6)
    lad.append(c)
    c, _ = ladder_ramp(get_law("rate_state_aging"),
                       "rate_state_aging: from creep, 10 MPa, → 20 m/s in 2 µs, 10 µs (onset at 1.8e6 m/s)",
                       10 * MPa, 20.0, 2e-6, 10e-6)
    lad.append(c)
    for name in ("rate_state_aging", "rate_state_slip"):
        lad.append(ladder_rs_step(name))
    for c in lad:
        print(f"  {c['case']}")
        for r in c["rows"]:
            print(f"    dt {r['dt_ns']:7.3f} ns  T_s {r['Ts_max_err']:.2e}  peaks {fmt(r.get('Ts_peaks_err'))}  troughs "
                  f"{fmt(r.get('Ts_troughs_err'))}  slip {fmt(r['slip_end_rel_err'])}  rate pk "
                  f"{fmt(r['rate_peak_sampled_rel_err'])}  state {', '.join(fmt(x) for x in r['state_err'])}  "
                  f"nsub {r['nsub']}")
        print("    orders (T_s):", ", ".join(fmt(x, "{:.2f}") for x in orders([r["dt_ns"] for r in c["rows"]],
                                                                             [r["Ts_max_err"] for r in c["rows"]])))
    doc["ladders"] = lad
    doc["slip_weakening"] = ladder_sw()
    print("  slip weakening, worst T_s / slip error:",
          max(r["Ts_max_err"] for r in doc["slip_weakening"]["rows"]),
          max(r["slip_max_err"] for r in doc["slip_weakening"]["rows"]))
    print("2. rate tangent, regime (i)", flush=True)
    doc["rate_tangent_regime_i"] = rate_tangent_regime_i(r_i)
    for r in doc["rate_tangent_regime_i"]:
        print("   ", r)
    print("3. rigid", flush=True)
    doc["rigid"] = ladder_rigid()
    for c in doc["rigid"]:
        print(f"  {c['law']}: " + "  ".join(f"{r['dt_ns']:g} ns {r['V_err']:.2e}" for r in c["rows"]))
    print("4. stability", flush=True)
    theory, grid, regime_ii = stability(args.quick)
    doc["stability"] = {"theory": theory, "linear": linear_checks(), "grid": grid, "regime_ii": regime_ii}
    for r in doc["stability"]["linear"]:
        print(f"  linear v {r['v']:g} T_n {r['Tn_MPa']:g}: Re λ {r['Re_lambda']:.5g}, "
              f"measured {r['measured_growth_rate']:.5g}")
    for r in regime_ii:
        print(f"  regime (ii) T_n {r['Tn_MPa']:g}: peak {r['peak_rate']:.4g} m/s, {r['outcome']}")
    doc["seconds"] = time.perf_counter() - t_all
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "point_reference.json").write_text(json.dumps(doc, indent=1, default=float))
    (args.out / "point_reference.md").write_text(markdown(doc))
    figure(doc, r_i, _histories(), args.out / "point_reference.png")
    print(f"wrote {args.out}/point_reference.{{json,md,png}} in {doc['seconds']:.0f} s")
    return doc


if __name__ == "__main__":
    main()
