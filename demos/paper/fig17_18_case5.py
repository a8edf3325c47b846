# # Figs. 17 and 18 — Case V, a pulse followed by a crack
#
# Σ0 = 40 MPa, V_imp = 2 m/s, and a friction law with the exponent p = 0.5
# and V1 = 1 m/s in its rate dependence (shipped scene `case5`).  Sliding
# starts late (31 µs in the paper) as a single pulse that grows — narrower
# and faster-slipping as it runs — while a crack-like sliding region opens
# behind it and catches up with its rear.
#
# The paper's Fig. 17: Δu̇_slip at 32, 38 and 44 µs (the caption; the text
# says 44.6 µs for the last) with T_s at 44 µs, drawn here one panel per
# time; the Δu̇_s and dT_s panels of Figs. 8b, 10b follow at 38 and 44 µs.
# Fig. 18: isochromatics at 32, 38 and 44.6 µs (the scene is run with field
# snapshots at these times instead of its own 32 and 44 µs; nothing else
# changes).
#
# The leading pulse is the last slipping region (`reproduction.Run.regions`);
# its width, peak and the tractions over it are read at 32 and 44 µs, the
# crack behind it is every sliding point behind the pulse.  Propagation
# speeds: V_tip (5-point progressive fit, mean over ±1 µs) for the front;
# for Fig. 18b the tracked fronts at the pulse's front and rear at 38 µs.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig17_18_case5.py [--v-scale K] [--direction pull]`

import sys

import numpy as np

import _common as common
from fricfem.plot.interface import interface_distributions
from fricfem.analysis import measures

TIMES = (32e-6, 38e-6, 44e-6)  # s, Fig. 17 (caption)
FRINGES = (32e-6, 38e-6, 44.6e-6)  # s, Fig. 18


def pulse_and_crack(r, t):
    """Leading pulse (width [mm], peak [m/s]) and the crack behind it at ``t``:
    |T_s| [MPa] and μ_app at the tip (over the pulse and 1 mm ahead: max), in
    the pulse (min), at the peak slip rate, and the medians over the crack."""
    regs = common.leading_regions(r, t)
    if not regs:
        return {}
    k, g = r.at(t), regs[-1]
    mu = common.mu_app(r)[k]
    ts = np.abs(r.shear_traction)[k] / 1e6
    tip = (r.x1 >= g.x_start) & (r.x1 <= g.x_end + 1e-3)
    pulse = slice(g.i0, g.i1 + 1)
    crack = (r.slip_rate[k] > 0) & (r.x1 < g.x_start)
    i_peak = g.i0 + int(np.argmax(r.slip_rate[k, pulse]))

    def med(a):
        return float(np.median(a[crack])) if crack.any() else np.nan

    return {"width_mm": g.width * 1e3, "peak": g.peak, "x_start": g.x_start, "x_end": g.x_end,
            "ts_tip": ts[tip].max(), "ts_pulse": ts[pulse].min(), "ts_crack": med(ts),
            "mu_tip": mu[tip].max(), "mu_peak": mu[i_peak], "mu_crack": med(mu), "rate_crack": med(r.slip_rate[k])}


def report(args, runs):
    rep = common.Report(args, "Figs. 17 and 18: Case V, a pulse followed by a crack")
    d = runs["case5"]
    r = common.load(d)
    rep.add_run("case5", d, r)

    # ## Figures
    rep.figure(common.slip_rate_panels(d, TIMES, args.out / "fig17_slip_rate_32_38_44us.png",
                                       traction_at=TIMES[-1]))
    rep.figure(interface_distributions(d, TIMES[1:], args.out / "interface_38_44us.png",
                                                       info=common.info(d)))
    for p in common.isochromatics(d, FRINGES, args.out):
        rep.figure(p)

    # ## Numbers quoted in the text
    t0, _ = measures.first_slip(r)
    rep.add("sliding starts (as a pulse) at", 31.0, t0, "µs")
    rep.add("sliding mode", "mixed (a pulse followed by a crack)", measures.mode(r))
    a, b = pulse_and_crack(r, 32e-6), pulse_and_crack(r, 44e-6)
    rep.add("pulse width at 32 µs", 8.5, a.get("width_mm"), "mm")
    rep.add("pulse width at 44 µs", 2.5, b.get("width_mm"), "mm")
    rep.add("peak Δu̇_slip at 32 µs", 155.0, a.get("peak"), "m/s")
    rep.add("peak Δu̇_slip at 44 µs", 392.0, b.get("peak"), "m/s")
    for t, paper in ((32e-6, 2600.0), (38e-6, 2450.0), (44.6e-6, 2450.0)):
        rep.add(f"V_tip at {t * 1e6:.3g} µs (mean over ±1 µs)", paper, common.v_tip(r, t), "m/s")
    rep.add("Δu̇_slip along the crack behind the pulse (median), 44 µs", 21.0, b.get("rate_crack"), "m/s")
    rep.add("|T_s| at the pulse tip (max), 44 µs", 23.5, b.get("ts_tip"), "MPa")
    rep.add("|T_s| in the pulse (min), 44 µs", 18.5, b.get("ts_pulse"), "MPa")
    rep.add("|T_s| along the crack (median), 44 µs", 20.0, b.get("ts_crack"), "MPa")
    rep.add("μ_app at the pulse tip (max), 44 µs", 0.595, b.get("mu_tip"))
    rep.add("μ_app at the peak slip rate, 44 µs", 0.47, b.get("mu_peak"))
    rep.add("μ_app along the crack (median), 44 µs", 0.50, b.get("mu_crack"))
    c = pulse_and_crack(r, 38e-6)
    rep.add("speed of the pulse's front at 38 µs", 2600.0,
            common.front_speed(r, 38e-6, c["x_end"], "leading") if c else np.nan, "m/s",
            note="paper: from the Mach angles of Fig. 18b")
    rep.add("speed of the pulse's rear at 38 µs", 3500.0,
            common.front_speed(r, 38e-6, c["x_start"], "trailing") if c else np.nan, "m/s")
    return rep.write()


def main(argv=None):
    args = common.options("fig17_18_case5", "Figs. 17, 18: Case V, a pulse followed by a crack", argv)
    runs = common.run_scenes(["case5"], args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
