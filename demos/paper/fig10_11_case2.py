# # Figs. 10 and 11 — Case II, the pulse-like mode (Σ0 = 30 MPa, V_imp = 2 m/s)
#
# Under a high compression the interface slides in narrow pulses: Δu̇_slip > 0
# over a few millimetres, with stick (Δu̇_slip = 0) ahead of and behind each
# pulse.  The paper's Fig. 10: (a) Δu̇_slip and T_s at 32 µs (dashed) and
# 34 µs (solid, integration points marked); (b) Δu̇_s and dT_s = Ṫ_s dt at
# 34 µs.  Because the interface is elastic, Δu̇_s = Δu̇_slip + Ṫ_s / C_s, the
# "strong" pulse of Δu̇_slip shows in Δu̇_s only as an abrupt change (a pulse
# of dΔu̇_s/dx), while dT_s has a pulse.  Fig. 11: isochromatics, at 32 µs in
# the text and 34 µs in the caption (both are drawn), fringes concentrated at
# the leading pulse near x1 = 22 mm.
#
# Measured here: the slipping regions of `reproduction.Run.regions` (runs of
# ≥ 3 points with a peak ≥ 0.05 m/s); the leading pulse is the last of them.
# Its profile is split at 40 m/s, the paper's level between the gradual
# front part ("from zero to 40 m/s in 4.5 mm") and the sharp pulse (up to
# 700 m/s over 0.5 mm, back to zero over 0.4 mm: "9–10 points").  T_s and
# μ_app at the pulse and just behind it (2 mm behind its rear end) follow
# the paper's description at 32 µs.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig10_11_case2.py [--v-scale K] [--direction pull]`

import sys

import numpy as np

import _common as common
from fricfem.plot.interface import interface_distributions
from fricfem.analysis import cell_lengths
from fricfem.analysis import measures

T_A, T_B = 32e-6, 34e-6  # s, the times of Fig. 10
SHARP = 40.0  # m/s, the paper's level between the gradual and the sharp part of the pulse


def leading_pulse(r, t):
    """The leading pulse at ``t``: width [mm], its part above SHARP (width [mm],
    points), peak [m/s]; T_s [MPa] and μ_app over it and in the 2 mm behind it."""
    regs = common.leading_regions(r, t)
    if not regs:
        return None
    k, g = r.at(t), regs[-1]
    w = cell_lengths(r.x1)
    pulse = slice(g.i0, g.i1 + 1)
    sharp = r.slip_rate[k, pulse] >= SHARP
    behind = (r.x1 < g.x_start) & (r.x1 > g.x_start - 2e-3)
    mu = common.mu_app(r)[k]
    return {
        "width_mm": g.width * 1e3, "sharp_mm": float(w[pulse][sharp].sum()) * 1e3, "sharp_points": int(sharp.sum()),
        "peak": g.peak, "ts_max": float(np.abs(r.shear_traction)[k, pulse].max()) / 1e6,
        "ts_behind": float(np.abs(r.shear_traction)[k, behind].min()) / 1e6 if behind.any() else np.nan,
        "mu_front": float(mu[g.i1]), "mu_max": float(mu[pulse].max()),
        "mu_behind": float(mu[behind].min()) if behind.any() else np.nan,
    }


def report(args, runs):
    rep = common.Report(args, "Figs. 10 and 11: Case II, pulse-like mode")
    d = runs["case2"]
    r = common.load(d)
    rep.add_run("case2", d, r)
    sigma0 = r.summary["input"]["loading"]["sigma0"]

    # ## Figures
    rep.figure(interface_distributions(d, [T_A, T_B], args.out / "fig10_interface_32_34us.png",
                                                       info=common.info(d)))
    for p in common.isochromatics(d, [T_A, T_B], args.out):
        rep.figure(p)

    # ## Numbers quoted in the text
    t0, x0 = measures.first_slip(r)
    rep.add("sliding starts at", 28.0, t0, "µs")
    rep.add("... at x1 (a pulse initiates at the impact edge)", 0.0, x0, "mm")
    rep.add("sliding mode", "pulse", measures.mode(r))
    rep.add("pulses at 32 µs", 2, len(common.leading_regions(r, T_A)))
    rep.add("pulses at 34 µs", 3, len(common.leading_regions(r, T_B)))
    rep.add("peak Δu̇_slip, whole run", 700.0, float(r.slip_rate.max()), "m/s")
    rep.add("leading pulse tip at 32 µs (Fig. 11)", 22.0, r.tip(T_A) * 1e3, "mm")
    rep.add("loading front at 32 µs", 71.0, measures.loading_front(r, T_A, sigma0), "mm")
    p = leading_pulse(r, T_B) or {}  # the profile the text describes: the solid curve, 34 µs
    rep.add("leading pulse: peak Δu̇_slip, 34 µs", 700.0, p.get("peak"), "m/s")
    rep.add("leading pulse: width, 34 µs", 5.4, p.get("width_mm"), "mm", note="paper: 4.5 + 0.5 + 0.4 mm")
    rep.add("leading pulse: width where Δu̇_slip ≥ 40 m/s, 34 µs", 0.9, p.get("sharp_mm"), "mm")
    rep.add("leading pulse: points where Δu̇_slip ≥ 40 m/s, 34 µs", "9–10", p.get("sharp_points"))
    p = leading_pulse(r, T_A) or {}
    rep.add("T_s at the leading pulse, 32 µs", 18.0, p.get("ts_max"), "MPa")
    rep.add("T_s just behind it (min over 2 mm), 32 µs", 14.0, p.get("ts_behind"), "MPa")
    rep.add("μ_app at the front of the leading pulse, 32 µs", 0.60, p.get("mu_front"))
    rep.add("μ_app over the leading pulse (max), 32 µs", 0.61, p.get("mu_max"))
    rep.add("μ_app just behind it (min over 2 mm), 32 µs", 0.44, p.get("mu_behind"))
    k = r.at(T_A)
    mid = (r.x1 > 10e-3) & (r.x1 < 60e-3)
    rep.add("median T_n over 10 mm < x1 < 60 mm, 32 µs", 30.0, float(np.median(r.normal_traction[k, mid])) / 1e6, "MPa")
    rep.add("V_tip at 32 µs (mean over ±1 µs)", 2800.0, common.v_tip(r, T_A), "m/s",
            note="paper: from the 26° shear Mach line in Fig. 11")
    return rep.write()


def main(argv=None):
    args = common.options("fig10_11_case2", "Figs. 10, 11: Case II, pulse-like sliding", argv)
    runs = common.run_scenes(["case2"], args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
