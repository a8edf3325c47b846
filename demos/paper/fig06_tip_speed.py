# # Fig. 6 — speed of the leading sliding tip in the five cases
#
# The paper's recipe: the leading sliding tip is the point furthest from the
# impact edge where Δu̇_slip > 0; V_tip is the slope of a least-squares line
# through five consecutive tip positions (a progressive fit).  fricfem does
# exactly this during the run (tip every step, fit on the tip sampled at the
# 0.2 µs interface cadence) and stores it in summary.json under `tip`.
#
# While sliding starts, separate patches appear and link up, so the tip jumps
# and the early "speeds" are unphysically high; they are drawn at the top of
# the frame.  Afterwards the paper finds V_tip ≈ c_l for Cases II and V and
# ≈ 2000 m/s for Case IV; Cases I and III run near c_l as well (their Mach
# cones give 2244 m/s, "close to but less than" the computed V_tip, and ≈ c_l).
# Reference speeds (plane stress, E = 5.2 GPa, ν = 0.34, ρ = 1230 kg/m³):
# c_l = √(E / ρ(1 − ν²)), c_s = √(E / 2ρ(1 + ν)), c_R from the Rayleigh
# equation, and √2 c_s, above which a shear crack can run steadily.
#
# Reported per case: the median V_tip over the later half of the sliding
# time (past the linking-up), and over the whole of it.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/fig06_tip_speed.py [--v-scale K] [--direction pull]`

import sys

import numpy as np
from matplotlib.figure import Figure

import _common as common
from fricfem.plot.common import DPI, SPEED_LABEL
from fricfem.analysis import measures

CASES = {"case1": "Case I", "case2": "Case II", "case3": "Case III", "case4": "Case IV", "case5": "Case V"}
PAPER = {"case1": "> 2244", "case2": "≈ c_l", "case3": "≈ c_l", "case4": 2000.0, "case5": "≈ c_l"}
SPEEDS = {"c_R": (1155.0, ":"), "c_s": (1255.0, "-."), "sqrt2_c_s": (1775.0, "--"), "c_l": (2187.0, "-")}


def figure(loaded, speeds, path, reading):
    """(a) tip position, (b) V_tip against time, every case; c_R, c_s, √2 c_s, c_l marked."""
    fig = Figure(figsize=(7.5, 7.0), dpi=DPI)
    ax_x, ax_v = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    top = 1.6 * speeds["c_l"]
    for k, (name, r) in enumerate(loaded.items()):
        tip = r.summary.get("tip") or {}
        t, x = np.asarray(tip.get("time_s") or []), np.asarray(tip.get("x1_m") or [])
        tv, v = np.asarray(tip.get("v_tip_time_s") or []), np.asarray(tip.get("v_tip_m_s") or [])
        label = f"{CASES[name]} ({measures.mode(r)})"
        ax_x.plot(t * 1e6, x * 1e3, color=f"C{k}", lw=1.0, label=label)
        ax_v.plot(tv * 1e6, np.clip(v, 0.0, top), color=f"C{k}", lw=0.9, marker="o", ms=2)
    for key, (_, style) in SPEEDS.items():
        ax_v.axhline(speeds[key], color="0.3", ls=style, lw=0.9)
        ax_v.text(1.0, speeds[key], f" {SPEED_LABEL[key]} = {speeds[key]:.0f}",
                  transform=ax_v.get_yaxis_transform(), va="center", fontsize=8)
    ax_v.set_ylim(0.0, top)
    ax_x.set_ylabel(r"$x_{\rm tip}$ [mm]")
    ax_v.set_ylabel(r"$V_{\rm tip}$ [m/s] (larger values drawn at the top)")
    ax_v.set_xlabel(r"$t$ [µs]")
    ax_x.legend(fontsize=8, loc="upper left")
    for a in (ax_x, ax_v):
        a.grid(alpha=0.25)
    fig.suptitle("Leading sliding tip in Cases I–V: position and speed (5-point progressive fit)\n"
                 + reading, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    return path


def report(args, runs):
    rep = common.Report(args, "Fig. 6: V_tip against time, Cases I–V")
    loaded = {name: common.load(d) for name, d in runs.items()}
    for name, r in loaded.items():
        rep.add_run(name, runs[name], r)
    speeds = next(iter(loaded.values())).summary["speeds"]

    # ## Figure
    args.out.mkdir(parents=True, exist_ok=True)
    rep.figure(figure(loaded, speeds, args.out / "fig06_tip_speed.png", common.reading_text(args)))

    # ## Numbers: the wave speeds, then V_tip per case
    for key, (paper, _) in SPEEDS.items():
        rep.add(f"{key}", paper, speeds[key], "m/s")
    for name, r in loaded.items():
        t0, _ = measures.first_slip(r)
        if t0 is None:
            rep.add(f"{CASES[name]}: median V_tip, later half of sliding", PAPER[name], None, "m/s",
                    note="no sliding")
            continue
        t0, t1 = t0 * 1e-6, r.summary["t_s"]
        rep.add(f"{CASES[name]}: median V_tip, later half of sliding", PAPER[name],
                common.median_v_tip(r, after=0.5 * (t0 + t1)), "m/s")
        rep.add(f"{CASES[name]}: median V_tip, all of sliding", None, common.median_v_tip(r), "m/s")
    return rep.write()


def main(argv=None):
    args = common.options("fig06_tip_speed", "Fig. 6: tip speed of Cases I-V", argv)
    runs = common.run_scenes(list(CASES), args)
    return common.on_rank0(lambda: report(args, runs))


if __name__ == "__main__":
    main(sys.argv[1:])
