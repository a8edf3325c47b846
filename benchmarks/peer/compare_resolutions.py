#!/usr/bin/env python3
"""Compare the SEM2DPACK resolutions of one problem (station summaries).

usage: compare_resolutions.py <problem> <fine label> <coarse label> [...]

For each coarse label, compares against the fine label and stores the
result under "resolution_comparison" in <problem>/sem2dpack_summary.json:
  - rupture time: max |tr_c - tr_f| (s) and max |tr_c - tr_f| / tr_f (%),
    over stations that ruptured in both runs with tr_f > 1 us (stations in
    the nucleation patch, which slip from t = 0, are excluded from the %);
  - peak slip rate and final slip: max relative difference (%) over the
    stations that ruptured.
"""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def compare(fine, coarse):
    rows = []
    for sf, sc in zip(fine["stations"], coarse["stations"]):
        assert sf["x_mm"] == sc["x_mm"]
        tf, tc = sf["rupture_time_s"], sc["rupture_time_s"]
        if tf is None and tc is None:
            continue
        row = dict(x_mm=sf["x_mm"], tr_fine_s=tf, tr_coarse_s=tc)
        if tf is not None and tc is not None:
            row["dtr_s"] = tc - tf
            if tf > 1e-6:
                row["dtr_pct"] = 100 * (tc - tf) / tf
        vf, vc = sf["peak_slip_rate_mps"], sc["peak_slip_rate_mps"]
        row["dVpeak_pct"] = 100 * (vc - vf) / vf
        df, dc = sf["final_slip_m"], sc["final_slip_m"]
        row["dslip_pct"] = 100 * (dc - df) / df
        rows.append(row)

    def mx(key):
        vals = [abs(r[key]) for r in rows if key in r]
        return max(vals) if vals else None

    miss = [r["x_mm"] for r in rows if (r["tr_fine_s"] is None) != (r["tr_coarse_s"] is None)]
    return dict(max_abs_dtr_s=mx("dtr_s"), max_abs_dtr_pct=mx("dtr_pct"),
                max_abs_dVpeak_pct=mx("dVpeak_pct"),
                max_abs_dslip_pct=mx("dslip_pct"),
                stations_ruptured_in_only_one=miss, per_station=rows)


def main():
    prob, fine_lab, coarse_labs = sys.argv[1], sys.argv[2], sys.argv[3:]
    fn = os.path.join(HERE, prob, "sem2dpack_summary.json")
    s = json.load(open(fn))
    res = s["resolutions"]
    s["resolution_comparison"] = {}
    for c in coarse_labs:
        r = compare(res[fine_lab], res[c])
        s["resolution_comparison"][f"{c}_vs_{fine_lab}"] = r
        print(f"{prob}: {c} vs {fine_lab}: max|dtr| = {r['max_abs_dtr_s']*1e6:.4f} us "
              f"({r['max_abs_dtr_pct']:.3f} %), max|dVpeak| = "
              f"{r['max_abs_dVpeak_pct']:.2f} %, max|dslip| = {r['max_abs_dslip_pct']:.2f} %"
              f", ruptured in only one: {r['stations_ruptured_in_only_one']}")
        for row in r["per_station"]:
            print("   ", {k: (round(v * 1e6, 4) if k.endswith("_s") and v is not None
                           else (round(v, 3) if isinstance(v, float) else v))
                          for k, v in row.items()})
    with open(fn, "w") as f:
        json.dump(s, f, indent=1)


if __name__ == "__main__":
    main()
