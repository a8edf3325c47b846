# # The experiment's loading over projectile speed and Σ0: how the leading tip's speed trends
#
# The paper (Section 3): "the propagation speed of the leading sliding tip was
# found to increase with increasing impact speed (or decreasing compressive
# stress) and in all cases to be between √2 c_s and c_l"; "with the magnitude
# of the initial compressive stress increased, there is an increase in the
# number of discontinuous regions of fringe concentration that may indicate
# separate regions of sliding and regions of sticking (i.e. multiple pulses)".
# Here: experiment_42 at projectile speeds 10–60 m/s and several Σ0, each run
# on one rank (runs dealt round-robin), measured as in `experiments.py`.
#
# Run: `mpirun -n 2 .venv/bin/python demos/experiment/sweep.py [--preset reference]`
# Writes benchmarks/results/experiment/sweep_<preset><tag>.json and .png.

import json
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).parent))
import common  # noqa: E402

from fricfem import load_scene, open_run  # noqa: E402

ap = common.options("runs/experiment_sweep")
ap.add_argument("--speeds", default="10,20,32.7,42,50,60")
ap.add_argument("--sigma0", default="4.7e6,9.4e6,18.8e6")
ap.add_argument("--t-end", type=float, default=56e-6)
ap.add_argument("--tag", default="", help="suffix of the output files (another grid)")
a = ap.parse_args()
world = MPI.COMM_WORLD
self_comm = MPI.COMM_SELF
speeds = [float(v) for v in a.speeds.split(",")]
sigmas = [float(s) for s in a.sigma0.split(",")]
jobs = [(v, s) for s in sigmas for v in speeds]


def one(v: float, s: float) -> dict:
    name = f"v{v:g}_s{s / 1e6:g}"
    scene = load_scene("experiment_42", [f"mesh.preset='{a.preset}'", f"experiment.projectile_speed={v}",
                                         f"loading.sigma0={s}", f"time.end={a.t_end}", "output.fields=[]"])
    res = common.run(scene, a.work / name, self_comm)
    r = open_run(a.work / name)
    sp = res["summary"]["speeds"]
    tip = common.tip_measures(r)
    crack = common.crack_like(r, (30e-6, 40e-6, 50e-6))
    return {"v_projectile_m_s": v, "sigma0_Pa": s, "tip": tip, "mode": (res["summary"].get("mode") or {}).get("label"),
            "second_front": common.second_front(r, sp), "crack_like": crack,
            "max_stretches": max(c["stretches"] for c in crack.values()), "speeds": sp}


mine = [one(v, s) for i, (v, s) in enumerate(jobs) if i % world.size == world.rank]
rows = [row for part in world.gather(mine, root=0) or [] for row in part]
if world.rank == 0:
    rows.sort(key=lambda r: (r["sigma0_Pa"], r["v_projectile_m_s"]))
    a.out.mkdir(parents=True, exist_ok=True)
    sp = rows[0]["speeds"]
    trend = {}
    for s in sigmas:
        v_tip = [r["tip"]["mean_m_s"] for r in rows if r["sigma0_Pa"] == s]
        ok = [x for x in v_tip if x]
        trend[f"{s:g}"] = {"increasing_with_speed": bool(len(ok) > 1 and all(np.diff(ok) > -10.0)),
                           "in_sqrt2cs_cl": bool(all(math.sqrt(2) * sp["c_s"] < x < sp["c_l"] for x in ok))}
    (a.out / f"sweep_{a.preset}{a.tag}.json").write_text(json.dumps({"rows": rows, "trend": trend}, indent=1,
                                                             default=float) + "\n")
    fig = Figure(figsize=(10, 3.8))
    ax1, ax2 = fig.subplots(1, 2)
    for s in sigmas:
        sel = [r for r in rows if r["sigma0_Pa"] == s]
        x = [r["v_projectile_m_s"] for r in sel]
        ax1.plot(x, [r["tip"]["mean_m_s"] or np.nan for r in sel], "o-", label=f"Σ0 = {s / 1e6:g} MPa")
        ax2.plot(x, [r["max_stretches"] for r in sel], "o-", label=f"Σ0 = {s / 1e6:g} MPa")
    ax1.plot([32.7, 42.0], [1810, 1950], "k*", ms=10, label="paper (9.4 MPa)")
    for val, lab in ((sp["c_l"], "$c_l$"), (math.sqrt(2) * sp["c_s"], r"$\sqrt{2}c_s$")):
        ax1.axhline(val, color="0.5", lw=0.7, ls="--")
        ax1.text(speeds[0], val + 8, lab, fontsize=8)
    ax1.set(xlabel="projectile speed [m/s]", ylabel="mean leading-tip speed [m/s]",
            title="leading tip (10–110 mm)")
    ax1.legend(fontsize=7)
    ax2.set(xlabel="projectile speed [m/s]", ylabel="slipping stretches behind the tip (most, 30–50 µs)",
            title="separate sliding regions")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out / f"sweep_{a.preset}{a.tag}.png", dpi=110)
    for r in rows:
        print(f"v {r['v_projectile_m_s']:5.1f} Σ0 {r['sigma0_Pa'] / 1e6:5.1f}: tip {r['tip']['mean_m_s']}, "
              f"mode {r['mode']}, stretches {r['max_stretches']}, second {r['second_front']['count']}")
    print(json.dumps(trend))
