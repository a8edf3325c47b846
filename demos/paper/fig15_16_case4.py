# # Figs. 15 and 16 — Case IV, pulses coalescing into a crack
#
# Σ0 = 0.9 MPa, V_imp = 10 m/s and an interface ten times softer
# (C_n = 0.03 MPa/µm, C_s = 0.01 MPa/µm; shipped scene `case4`).  Sliding
# starts as several pulses; the ones behind travel faster than the leading
# one — supersonically, faster than c_l — catch up with it and merge into a
# single crack-like sliding region running at about c_l, which grows as new
# pulses leave the impact edge and join it.
#
# The paper's Fig. 15 shows Δu̇_slip at 22, 32 and 41 µs (the text; the
# caption says 48 µs for (c), past this scene's end at 45 µs), drawn here as
# three panels; the Δu̇_s and dT_s panels of the same kind as Figs. 8b, 10b
# follow at 32 and 41 µs.  Fig. 16: isochromatics at the same times, drawn
# for x2 > 0 as the paper does (its Mach lines are clearer in that plate).
#
# Speeds: the mean speed of a pulse front between 22 and 32 µs is the
# distance it covered over 10 µs (the paper: ≈ c_l for the leading pulse,
# ≈ 2700 m/s for the second); `reproduction` also quotes the fastest tracked
# rupture front.  The Mach-angle speeds of the three pulse tips at 32 µs
# (2190, 2560, 3160 m/s in Fig. 16b) are compared with the tracked fronts'
# progressive-fit speeds at the three region fronts.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig15_16_case4.py [--v-scale K] [--direction pull]`

import sys

import _common as common
from fricfem.plot.interface import interface_distributions
from fricfem.analysis import measures

TIMES = (22e-6, 32e-6, 41e-6)  # s, Figs. 15 and 16 (the text's times)
UPPER_PLATE = (0.0, 0.080, 0.0, 0.030)  # isochromatic window (x1_min, x1_max, x2_min, x2_max) [m]


def gap(regs):
    """Stick length [mm] between the leading region and the one behind it."""
    return (regs[-1].x_start - regs[-2].x_end) * 1e3 if len(regs) > 1 else float("nan")


def report(args, runs):
    rep = common.Report(args, "Figs. 15 and 16: Case IV, pulses coalescing into a crack")
    d = runs["case4"]
    r = common.load(d)
    rep.add_run("case4", d, r)

    # ## Figures
    rep.figure(common.slip_rate_panels(d, TIMES, args.out / "fig15_slip_rate_22_32_41us.png"))
    for pair in (TIMES[:2], TIMES[1:]):
        name = f"interface_{pair[0] * 1e6:.0f}_{pair[1] * 1e6:.0f}us.png"
        rep.figure(interface_distributions(d, pair, args.out / name, info=common.info(d)))
    for p in common.isochromatics(d, TIMES, args.out, window=UPPER_PLATE):
        rep.figure(p)

    # ## Numbers quoted in the text
    t22, t32, t41 = TIMES
    r22, r32, r41 = (common.leading_regions(r, t) for t in TIMES)
    t0, _ = measures.first_slip(r)
    rep.add("sliding starts at", 14.0, t0, "µs")
    rep.add("sliding mode", "mixed (pulses coalescing into a crack)", measures.mode(r))
    rep.add("pulses at 22 µs", 3, len(r22))
    rep.add("leading pulse tip at 22 µs", 18.0, r.tip(t22) * 1e3, "mm")
    rep.add("stick between first and second pulse, 22 µs", 3.4, gap(r22), "mm")
    rep.add("leading pulse tip at 32 µs", 41.0, r.tip(t32) * 1e3, "mm")
    rep.add("stick between first and second pulse, 32 µs", 0.4, gap(r32), "mm")
    rep.add("mean speed of the leading tip, 22 → 32 µs", "≈ c_l", (r.tip(t32) - r.tip(t22)) / (t32 - t22),
            "m/s", note=f"c_l = {r.summary['speeds']['c_l']:.0f} m/s")
    second = ((r32[-2].x_end - r22[-2].x_end) / (t32 - t22)) if len(r22) > 1 and len(r32) > 1 else float("nan")
    rep.add("mean speed of the second pulse's front, 22 → 32 µs", 2700.0, second, "m/s")
    fast = [f["mean_speed"] for f in r.summary.get("fronts") or []
            if f.get("kind") == "rupture" and f.get("mean_speed")]
    rep.add("fastest tracked rupture front (mean speed)", 2700.0, max(fast, default=float("nan")), "m/s")
    for k, mach in zip((1, 2, 3), (2190.0, 2560.0, 3160.0)):
        v = common.front_speed(r, t32, r32[-k].x_end) if len(r32) >= k else float("nan")
        rep.add(f"front speed of pulse {k} at 32 µs", mach, v, "m/s", note="paper: from the Mach angles of Fig. 16b")
    rep.add("slipping regions at 41 µs (one crack)", 1, len(r41))
    rep.add("sliding tip at 41 µs", 60.0, r.tip(t41) * 1e3, "mm")
    rep.add("median V_tip after 22 µs", 2000.0, common.median_v_tip(r, after=t22), "m/s",
            note="paper (Fig. 6): 'after the initial stages of sliding, V_tip reduces to ≈ 2000 m/s'")
    return rep.write()


def main(argv=None):
    args = common.options("fig15_16_case4", "Figs. 15, 16: Case IV, pulses coalescing into a crack", argv)
    runs = common.run_scenes(["case4"], args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
