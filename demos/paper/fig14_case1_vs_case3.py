# # Fig. 14 — accumulated slip: the crack (Case I) against the train of pulses (Case III)
#
# Two measures of how far the plates have slid past each other at a point:
# the accumulated frictional slip Δu_slip = ∫ Δu̇_slip dt, and the actual
# tangential displacement jump Δu_s.  The interface is elastic, so
# Δu_s = Δu_slip + (T_s − T_s(0)) / C_s: they differ by the elastic part.
# In a crack (Case I) both vary smoothly along the slipped stretch.  In a
# train of pulses (Case III) every pulse adds a step to Δu_slip; the
# elasticity smooths the steps out of Δu_s, and they show instead in an
# oscillating shear traction T_s.  (The text names T_s in this figure, the
# caption μ_app = T_s / T_n; T_s is drawn.)  Both at 32 µs.
#
# Reported per case: the largest Δu_slip and Δu_s, the number of steps in
# Δu_slip (stick stretches between slipping regions, `Run.regions`), and the
# swing (max − min) of |T_s| along the slipped stretch from 5 mm off the edge
# to 5 mm behind the tip.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig14_case1_vs_case3.py [--v-scale K] [--direction pull]`

import sys

import numpy as np
from matplotlib.figure import Figure

import _common as common
from fricfem.analysis import measures
from fricfem.plot.common import DPI
from fricfem.plot.common import label as quantity_label

T_FIG = 32e-6  # s
CASES = {"case1": ("Case I", "smooth"), "case3": ("Case III", "steps")}


def panel(ax, rundir, title):
    """Δu_slip and the sign-corrected Δu_s [µm] (left), T_s [MPa] (right) at T_FIG."""
    sgn = common.sign(rundir)
    x, slip = common.profile(rundir, "slip", T_FIG)
    _, jump = common.profile(rundir, "jump_s", T_FIG)
    _, ts = common.profile(rundir, "shear_traction", T_FIG)
    lab = quantity_label
    ax.plot(x * 1e3, slip * 1e6, "C0-", lw=1.2, label=lab("slip"))
    ax.plot(x * 1e3, sgn * jump * 1e6, "C2--", lw=1.2, label=lab("jump_s", sgn))
    ax.set_ylabel("slip, jump [µm]")
    axr = ax.twinx()
    axr.plot(x * 1e3, sgn * ts / 1e6, "C3-", lw=0.9, label=lab("shear_traction", sgn))
    axr.set_ylabel(lab("shear_traction", sgn) + " [MPa]", color="C3")
    lines = ax.get_lines() + axr.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper right")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.25)


def report(args, runs):
    rep = common.Report(args, "Fig. 14: Δu_slip, Δu_s and T_s, Case I against Case III at 32 µs")
    fig = Figure(figsize=(7.0, 6.5), dpi=DPI)
    axes = fig.subplots(2, 1, sharex=True)
    for k, (name, (label, paper)) in enumerate(CASES.items()):
        d = runs[name]
        r = common.load(d)
        rep.add_run(name, d, r)
        panel(axes[k], d, f"({'ab'[k]}) {label}: {common.info(d).title()}, t = {T_FIG * 1e6:.0f} µs")

        # ## Numbers
        x, slip = common.profile(d, "slip", T_FIG)
        _, jump = common.profile(d, "jump_s", T_FIG)
        k32 = r.at(T_FIG)
        rep.add(f"{label}: largest Δu_slip, 32 µs", None, float(slip.max()) * 1e6, "µm")
        rep.add(f"{label}: largest |Δu_s|, 32 µs", None, float(np.abs(jump).max()) * 1e6, "µm")
        rep.add(f"{label}: steps in Δu_slip (stick stretches inside the slipped zone)", paper,
                max(len(measures.regions(r, k32)) - 1, 0))
        inside = (r.slip_rate[k32] > 0) & (r.x1 > 5e-3) & (r.x1 < r.tip(T_FIG) - 5e-3)
        swing = float(np.ptp(np.abs(r.shear_traction)[k32, inside])) / 1e6 if inside.any() else None
        rep.add(f"{label}: |T_s| swing along the slipped zone, 32 µs",
                "steady" if name == "case1" else "oscillatory", swing, "MPa")
    axes[-1].set_xlim(0.0, 80.0)
    axes[-1].set_xlabel(r"$x_1$ [mm]")
    fig.suptitle("Accumulated slip and displacement jump: crack (Case I), train of pulses (Case III)\n"
                 + common.reading_text(args), fontsize=10)
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fig14_case1_vs_case3_32us.png"
    fig.savefig(path, dpi=DPI)
    rep.figure(path)
    return rep.write()


def main(argv=None):
    args = common.options("fig14_case1_vs_case3", "Fig. 14: Case I against Case III", argv)
    runs = common.run_scenes(list(CASES), args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
