# # Fig. 7 — symmetric loading: the fringes of impact without sliding
#
# Both plates are struck alike (|x2| ≤ 25 mm, V_imp = 5 m/s) after a uniform
# compression Σ0 = 10 MPa (shipped scene `symmetric`).  By symmetry about
# x2 = 0 the shear traction on the interface stays zero, T_s = 0, so the
# friction law, which needs |T_s| to reach μ T_n before anything slides, keeps
# the interface stuck: Δu̇_slip = 0 everywhere.  The isochromatics
# (dark-field sin²(π N), N = (σ1 − σ2) h / f_σ) therefore show what the
# impact alone does to the fringes — the loading front, its cusp at the
# interface, the head wave — before sliding adds its Mach cones in Cases I–V.
#
# The paper: "At this time [16 µs], the loading wave front has propagated
# 34 mm into the specimen"; "no sliding occurs along the interface".
# fricfem's loading front is the furthest x1 where T_n differs from Σ0 by
# more than 0.01 % (`reproduction.loading_front`), so it travels at the
# longitudinal speed along the interface, x1 ≈ c_l (t − a fraction of the rise).
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig07_symmetric.py [--preset coarse] [--out DIR]`

import sys

import numpy as np

import _common as common
from fricfem.plot.interface import interface_distributions
from fricfem.analysis import measures

T_FIG = 16e-6  # s, the time of Fig. 7a


def report(args, runs):
    rep = common.Report(args, "Fig. 7a: symmetric loading, isochromatics at 16 µs")
    d = runs["symmetric"]
    r = common.load(d)
    rep.add_run("symmetric", d, r)
    sigma0 = r.summary["input"]["loading"]["sigma0"]

    # ## Figures: the fringes at 16 µs and the interface at the same time
    for p in common.isochromatics(d, [T_FIG], args.out):
        rep.figure(p)
    rep.figure(interface_distributions(d, [T_FIG], args.out / "interface_16us.png",
                                                       info=common.info(d)))

    # ## Numbers
    rep.add("largest slip rate anywhere, any time (no sliding)", 0.0, float(r.slip_rate.max()), "m/s")
    rep.add("largest |T_s| anywhere, any time", None, float(np.abs(r.shear_traction).max()) / 1e6, "MPa",
            note="not quoted; zero by symmetry")
    rep.add("loading front along the interface at 16 µs", 34.0, measures.loading_front(r, T_FIG, sigma0), "mm")
    rep.add("c_l × 16 µs (the longitudinal wave, for scale)", None,
            r.summary["speeds"]["c_l"] * T_FIG * 1e3, "mm")
    rep.add("sliding mode", "none (no sliding)", measures.mode(r))
    return rep.write()


def main(argv=None):
    args = common.options("fig07_symmetric", "Fig. 7: symmetric loading, no sliding", argv)
    runs = common.run_scenes(["symmetric"], args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
