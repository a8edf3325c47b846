#!/usr/bin/env python3
"""The peer's runs of each problem side by side, as README "Results" prints them:
rupture time, peak slip rate and final slip at every station for every
resolution, then each run's largest differences from the finest
(`<problem>/sem2dpack_summary.json`, made by make_tables.py and
compare_resolutions.py).

usage: resolution_tables.py [problem ...]      (markdown on stdout)
"""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ORDER = ("h0.25mm", "h0.1mm", "h0.05mm", "p8_h0.125mm", "p8_h0.0625mm")
FINEST = "p8_h0.0625mm"


def _cell(v, scale, digits, small=None):
    if v is None:
        return "—"
    if small is not None and v < small:
        return f"<{small:g}"
    return f"{v * scale:.{digits}f}" if isinstance(digits, int) else f"{v * scale:{digits}}"


def tables(problem: str) -> str:
    res = json.load(open(os.path.join(HERE, problem, "sem2dpack_summary.json")))
    runs = res["resolutions"]
    labels = [lab for lab in ORDER if lab in runs]
    head = "| x [mm] | " + " | ".join(f"`{lab}`" for lab in labels) + " |\n|---|" + "---|" * len(labels)
    st = {lab: runs[lab]["stations"] for lab in labels}
    xs = [s["x_mm"] for s in st[labels[0]]]
    out = [f"**{problem}**", ""]
    for title, key, scale, digits, small in (
            ("rupture time t_r [µs] (first V > 1e-3 m/s; — = never):", "rupture_time_s", 1e6, 3, None),
            ("peak slip rate [m/s]:", "peak_slip_rate_mps", 1.0, ".3g", 1e-3),
            ("slip at end time [µm]:", "final_slip_m", 1e6, 3, None)):
        out += [title, "", head]
        for i, x in enumerate(xs):
            out.append(f"| {x:g} | " + " | ".join(_cell(st[lab][i][key], scale, digits, small) for lab in labels)
                       + " |")
        out.append("")
    comp = res.get("resolution_comparison", {})
    rows = [(lab, comp[f"{lab}_vs_{FINEST}"]) for lab in ("h0.05mm", "p8_h0.125mm", "h0.1mm", "h0.25mm")
            if f"{lab}_vs_{FINEST}" in comp]
    if rows:
        out += ["Differences from the finest run, stations that ruptured (t_r % only for t_r > 1 µs):", "",
                "| run vs reference | max abs Δt_r [µs] | max abs Δt_r [%] | max abs ΔV_peak [%] "
                "| max abs Δslip_end [%] |", "|---|---|---|---|---|"]
        for lab, c in rows:
            out.append(f"| {lab} vs {FINEST} | {c['max_abs_dtr_s'] * 1e6:.3f} | {c['max_abs_dtr_pct']:.2f} | "
                       f"{c['max_abs_dVpeak_pct']:.1f} | {c['max_abs_dslip_pct']:.2f} |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    for p in sys.argv[1:] or ("tpv205_2d", "rsf_aging_2d", "rsf_slip_2d"):
        print(tables(p))
