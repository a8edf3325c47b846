# # Figs. 12 and 13 — Case III, a train of pulses (Σ0 = 10 MPa, V_imp = 20 m/s)
#
# At a higher impact velocity the sliding region behind the leading front
# breaks up into a periodic train of pulses: slipping stretches of width w
# separated by stuck stretches, spacing s, all travelling together.  The
# paper's Fig. 12: (a) Δu̇_slip and T_s at 32 and 33 µs (the text and the
# caption agree on 33 µs; the pulses at 33 µs lie one spacing further on,
# which is self-similar propagation at s / 1 µs); (b) Δu̇_s and dT_s at
# 32 µs.  Fig. 13: isochromatics at 32 µs, the first pulse's front at 55 mm.
#
# Pulse geometry as in `demos/reproduction.py`: the regions inside the
# uniform fine mesh (x_end < 60 mm), widths the median over the pulses behind
# the leading one, spacing the median distance between successive starts,
# stick = spacing − width (the paper: w = 1.33 mm, stick 0.92 mm, s = 2.21 mm).
# T_s, μ_app along the train are taken between 5 mm from the edge and the
# start of the leading pulse; T_n over 30–60 mm (the paper: ≈ 14 MPa at
# 45 mm, 11.5 MPa at 30 and 60 mm).
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig12_13_case3.py [--v-scale K] [--direction pull]`

import sys

import numpy as np

import _common as common
from fricfem.plot.interface import interface_distributions
from fricfem.analysis import measures

T_A, T_B = 32e-6, 33e-6  # s, the times of Fig. 12


def train_tractions(r, t):
    """|T_s| [MPa] and μ_app along the train behind the leading pulse, μ_app over
    the leading pulse, and T_n [MPa] over 30–60 mm, at ``t``."""
    regs = common.leading_regions(r, t)
    if not regs:
        return {}
    k, lead = r.at(t), regs[-1]
    train = (r.x1 > 5e-3) & (r.x1 < lead.x_start)
    mu = common.mu_app(r)[k]
    ts = np.abs(r.shear_traction)[k, train] / 1e6
    window = (r.x1 >= 30e-3) & (r.x1 <= 60e-3)
    tn = r.normal_traction[k] / 1e6
    i = np.flatnonzero(window)[np.argmax(tn[window])]
    return {"ts_mean": ts.mean() if ts.size else np.nan, "ts_swing": np.ptp(ts) if ts.size else np.nan,
            "mu_min": mu[train].min() if train.any() else np.nan,
            "mu_max": mu[train].max() if train.any() else np.nan,
            "mu_lead": mu[lead.i0:lead.i1 + 1].max(), "tn_max": tn[i], "x_tn_max": r.x1[i] * 1e3,
            "tn_30": np.interp(30e-3, r.x1, tn), "tn_60": np.interp(60e-3, r.x1, tn)}


def report(args, runs):
    rep = common.Report(args, "Figs. 12 and 13: Case III, a train of pulses")
    d = runs["case3"]
    r = common.load(d)
    rep.add_run("case3", d, r)

    # ## Figures
    rep.figure(interface_distributions(d, [T_A, T_B], args.out / "fig12_interface_32_33us.png",
                                                       info=common.info(d)))
    rep.figure(interface_distributions(d, [T_A, T_B], args.out / "fig12_interface_32_33us_zoom.png",
                                                       info=common.info(d), xlim=(30e-3, 60e-3)))
    for p in common.isochromatics(d, [T_A], args.out):
        rep.figure(p)

    # ## Numbers quoted in the text
    rep.add("sliding mode", "pulse-train", measures.mode(r))
    train = common.pulse_train(r, T_A)
    rep.add("slipping regions at 32 µs", None, train["n_regions"])
    rep.add("pulse width, 32 µs", 1.33, train["width_mm"], "mm")
    rep.add("stick length between pulses, 32 µs", 0.92, train["stick_mm"], "mm")
    rep.add("pulse spacing, 32 µs", 2.21, train["spacing_mm"], "mm")
    rep.add("peak Δu̇_slip, 32 µs", 120.0, float(r.slip_rate[r.at(T_A)].max()), "m/s")
    rep.add("leading front, 32 µs", 55.0, r.tip(T_A) * 1e3, "mm")
    rep.add("V_tip at 32 µs (mean over ±1 µs)", "≈ c_l", common.v_tip(r, T_A), "m/s",
            note=f"c_l = {r.summary['speeds']['c_l']:.0f} m/s; paper: from the 37° shear Mach wave in Fig. 13")
    q = train_tractions(r, T_A)
    rep.add("mean |T_s| along the train, 32 µs", 7.0, q.get("ts_mean"), "MPa")
    rep.add("|T_s| swing (max − min) along the train, 32 µs", 1.5, q.get("ts_swing"), "MPa",
            note="paper: 'oscillations of 1.5 MPa'")
    rep.add("μ_app along the train: min, 32 µs", 0.48, q.get("mu_min"))
    rep.add("μ_app along the train: max, 32 µs", 0.59, q.get("mu_max"))
    rep.add("μ_app over the leading pulse: max, 32 µs", 0.63, q.get("mu_lead"))
    rep.add("largest T_n over 30–60 mm, 32 µs", 14.0, q.get("tn_max"), "MPa")
    rep.add("... at x1", 45.0, q.get("x_tn_max"), "mm")
    rep.add("T_n at x1 = 30 mm, 32 µs", 11.5, q.get("tn_30"), "MPa")
    rep.add("T_n at x1 = 60 mm, 32 µs", 11.5, q.get("tn_60"), "MPa")
    return rep.write()


def main(argv=None):
    args = common.options("fig12_13_case3", "Figs. 12, 13: Case III, a train of pulses", argv)
    runs = common.run_scenes(["case3"], args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
