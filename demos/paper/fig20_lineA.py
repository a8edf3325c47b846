# # Fig. 20 — line A of the mode map: Σ0 = 10 MPa, V_imp from 2 to 40 m/s
#
# Along line A of the paper's Fig. 19 the compression is held at
# Σ0 = 10 MPa and the impact velocity raised: 2, 7, 10, 20 and 40 m/s
# (shipped scenes `lineA_v2` … `lineA_v40`).  The figure follows one point of
# the interface, x1 = 16.1 mm, in time: (a) the velocity jump Δu̇_s,
# (b) the slip rate Δu̇_slip, (c) the shear traction T_s, (d) the apparent
# friction μ_app = T_s / T_n.  With Δu̇_s = Δu̇_slip + Ṫ_s / C_s, the
# oscillations of T_s carry the "elastic" part of the jump.
#
# The paper: at 2 m/s steady sliding (crack-like) with μ_app ≈ 0.598; at
# 7 m/s a transition (oscillations that stick at their crests: a few pulses
# then a crack); from 10 m/s a train of pulses whose amplitude and frequency
# grow with V_imp, while the swing of Δu̇_s stops growing between 20 and
# 40 m/s; μ_app oscillates between 0.470 and 0.598 at 40 m/s.
# Each run's sliding mode, as fricfem classifies it, is in the legend.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig20_lineA.py [--v-scale K] [--direction pull]`

import sys

import _common as common
from fricfem.analysis import measures

SCENES = {"lineA_v2": 2, "lineA_v7": 7, "lineA_v10": 10, "lineA_v20": 20, "lineA_v40": 40}  # V_imp [m/s]
MODES = {2: "crack-like", 7: "mixed", 10: "pulse-train", 20: "pulse-train", 40: "pulse-train"}


def report(args, runs):
    rep = common.Report(args, "Fig. 20: line A, Σ0 = 10 MPa, V_imp = 2–40 m/s, histories at x1 = 16.1 mm")
    labels = {}
    for name, v in SCENES.items():
        r = common.load(runs[name])
        rep.add_run(name, runs[name], r)
        labels[f"$V_{{\\rm imp}}$ = {r.summary['input']['loading']['v_imp']:g} m/s"] = runs[name]

        # ## Numbers at the station, per run
        m = common.station_measures(r, common.sign(runs[name]))
        tag = f"V_imp = {v} m/s"
        rep.add(f"{tag}: sliding mode", MODES[v], measures.mode(r))
        rep.add(f"{tag}: sliding starts at the station", None, m.get("onset_us"), "µs")
        rep.add(f"{tag}: peak Δu̇_slip", "grows with V_imp" if v >= 10 else None, m.get("peak_slip_rate"), "m/s")
        rep.add(f"{tag}: sliding episodes / median period", "frequency grows with V_imp" if v >= 10 else None,
                [m.get("episodes"), m.get("period_us")], "— / µs")
        rep.add(f"{tag}: swing of Δu̇_s, late", "no growth 20 → 40" if v >= 20 else None,
                m.get("late_jump_rate_swing"), "m/s")
        rep.add(f"{tag}: mean T_s, late", None, m.get("late_ts_MPa"), "MPa")
        paper_mu = {2: 0.598, 40: [0.470, 0.598]}.get(v)
        rep.add(f"{tag}: μ_app late mean / min / max", paper_mu,
                [m.get("late_mu"), m.get("late_mu_min"), m.get("late_mu_max")])

    # ## Figure: the five histories stacked panel by panel
    title = r"Line A: $\Sigma_0$ = 10 MPa, $V_{\rm imp}$ = 2–40 m/s; " + common.reading_text(args)
    rep.figure(common.station_stack(labels, args.out / "fig20_lineA_x16.1mm.png", title))
    return rep.write()


def main(argv=None):
    args = common.options("fig20_lineA", "Fig. 20: line A of the mode map", argv)
    runs = common.run_scenes(list(SCENES), args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
