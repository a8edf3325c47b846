# # Fig. 21 — line B of the mode map: V_imp = 2 m/s, Σ0 from 6 to 30 MPa
#
# Along line B of the paper's Fig. 19 the impact velocity is held at
# V_imp = 2 m/s and the compression raised: Σ0 = 6, 10, 16 and 30 MPa
# (shipped scenes `lineB_s6` … `lineB_s30`).  As in Fig. 20, the histories
# at x1 = 16.1 mm: (a) Δu̇_s, (b) Δu̇_slip, (c) T_s, (d) μ_app = T_s / T_n.
# A higher compression needs a higher shear traction to slide,
# |T_s| = μ T_n, so sliding starts later.
#
# The paper: crack-like at 6 and 10 MPa, with Δu̇_slip and Δu̇_s first
# overshooting their steady values (the direct effect of the rate- and
# state-dependent law); a train of pulses at 16 MPa, whose width is half its
# spacing; at 30 MPa steeper and narrower pulses, peak Δu̇_slip ≈ 820 m/s,
# drawn off scale in (b) as the paper does.  The peak μ_app does not grow
# with Σ0 although T_s does.  Each run's sliding mode is in the legend.
# The 820 m/s peak is the largest slip rate anywhere on the interface
# (`demos/reproduction.py`), the width/spacing ratio the median sliding time
# over the median period at the station.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig21_lineB.py [--v-scale K] [--direction pull]`

import sys

import _common as common
from fricfem.analysis import measures

SCENES = {"lineB_s6": 6, "lineB_s10": 10, "lineB_s16": 16, "lineB_s30": 30}  # Σ0 [MPa]
MODES = {6: "crack-like", 10: "crack-like", 16: "pulse-train", 30: "pulse"}


def report(args, runs):
    rep = common.Report(args, "Fig. 21: line B, V_imp = 2 m/s, Σ0 = 6–30 MPa, histories at x1 = 16.1 mm")
    labels = {}
    for name, s in SCENES.items():
        r = common.load(runs[name])
        rep.add_run(name, runs[name], r)
        labels[rf"$\Sigma_0$ = {r.summary['input']['loading']['sigma0'] / 1e6:g} MPa"] = runs[name]

        # ## Numbers at the station, per run
        m = common.station_measures(r, common.sign(runs[name]))
        tag = f"Σ0 = {s} MPa"
        rep.add(f"{tag}: sliding mode", MODES[s], measures.mode(r))
        rep.add(f"{tag}: sliding starts at the station", "later with Σ0", m.get("onset_us"), "µs")
        rep.add(f"{tag}: peak / late mean Δu̇_slip at the station", "peak > steady" if s <= 10 else None,
                [m.get("peak_slip_rate"), m.get("late_slip_rate")], "m/s")
        if s == 16:
            rep.add(f"{tag}: sliding time / period at the station", 0.5, m.get("duty"))
        if s == 30:
            rep.add(f"{tag}: peak Δu̇_slip anywhere", 820.0, float(r.slip_rate.max()), "m/s")
        rep.add(f"{tag}: mean T_s, late", "grows with Σ0", m.get("late_ts_MPa"), "MPa")
        rep.add(f"{tag}: peak μ_app at the station", "no growth with Σ0", m.get("peak_mu"))

    # ## Figure: the four histories stacked panel by panel
    title = r"Line B: $V_{\rm imp}$ = 2 m/s, $\Sigma_0$ = 6–30 MPa; " + common.reading_text(args)
    rep.figure(common.station_stack(labels, args.out / "fig21_lineB_x16.1mm.png", title))
    return rep.write()


def main(argv=None):
    args = common.options("fig21_lineB", "Fig. 21: line B of the mode map", argv)
    runs = common.run_scenes(list(SCENES), args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
