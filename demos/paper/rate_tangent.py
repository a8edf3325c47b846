# # The paper's own update: does the plain rate-tangent step make the pulses?
#
# The paper integrates the friction law with the rate-tangent method (Peirce,
# Shih & Needleman 1984; its Appendix): one linearised update per step,
#
#     C_s^tan = C_s / (1 + γ dt C_s ∂v/∂|T_s|),
#     Ṫ_s = C_s^tan Δu̇_s − Ṙ_p,  Ṙ_p = C_s^tan sgn(T_s) (v + γ dt Σ_i ∂v/∂θ_i θ̇_i),
#
# with γ = 1/2 and automatic step control.  fricfem integrates the same law to
# convergence inside every bulk step (sub-steps, located onset, implicit
# solve; ``povirk_needleman``).  At slip rates of hundreds of m/s the plain
# update at a 20–100 ns step is no longer accurate, nor stable
# (docs/friction.md).  If the paper's pulses at high Σ0 (Cases II, V) or its
# trains (Case III) came from its numerics, fricfem should see them with the
# plain update (law ``povirk_needleman_rate_tangent``: the same parameters and
# state, ``rate_tangent_advance`` once per bulk step, no step control).
#
# This demo runs Cases II, III and V with both laws under three readings of
# the loading — the shipped one (push, V_imp as printed), the best ranked one
# (push, V_imp × 5; REPRODUCTION.md §3) and V_imp × 10, the first of these
# under which Cases II and V slide before their end (§2b: they need × 6.7 and
# × 7.8) — on the reference mesh, and reports
# side by side: the initiation time, the mode, the peak slip rate, the number
# of slipping regions (pulses) at 32 µs and the most at any time, and the
# watchdog's message where it stopped a run (a divergence: non-finite values,
# a negative kinetic energy or an energy budget that does not close); a slip
# rate above c_l is reported (`slip_rate_spike` of summary.json), not stopped.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/rate_tangent.py`
# Writes `demos/output/rate_tangent/rate_tangent.json` and `rate_tangent.png`
# (slip rate at x1 = 16.1 mm, both laws); runs in `runs/rate_tangent/`.

import argparse
import json
import logging
from pathlib import Path

import numpy as np
from mpi4py import MPI

import _common as common
from fricfem.analysis import measures  # (scene: the shipped scene under a reading)

from fricfem import open_run, runner

logging.getLogger().setLevel(logging.WARNING)

SCENES = ("case2", "case3", "case5")
LAWS = ("povirk_needleman", "povirk_needleman_rate_tangent")
READINGS = {"shipped (V_imp × 1)": 1.0, "best ranked (V_imp × 5)": 5.0, "Cases II and V slide (V_imp × 10)": 10.0}

ap = argparse.ArgumentParser(description="Cases II, III, V with the converged and the plain rate-tangent update")
ap.add_argument("--scenes", nargs="+", default=list(SCENES))
ap.add_argument("--v-scales", nargs="+", type=float, default=list(READINGS.values()))
ap.add_argument("--preset", default="reference")
ap.add_argument("--t-end", type=float, default=None, help="end every run here [s] (smoke tests)")
ap.add_argument("--work", type=Path, default=Path("runs/rate_tangent"))
ap.add_argument("--out", type=Path, default=Path("demos/output/rate_tangent"))
a = ap.parse_args()
comm = MPI.COMM_WORLD


def finished(d: Path, sc) -> bool:
    """A run of this input ended for good here: complete, or stopped by the watchdog."""
    try:
        s = json.loads((d / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    return bool(s.get("complete") or s.get("watchdog")) and s.get("input") == json.loads(json.dumps(sc.raw))


def measure(d: Path) -> dict:
    """Initiation, mode, peak slip rate and slipping regions of a finished run (rank 0)."""
    s = json.loads((d / "summary.json").read_text())
    r = open_run(d)
    ini = s.get("initiation")
    counts = [len(measures.regions(r, k)) for k in range(len(r.t))]
    peak = float(r.slip_rate.max(initial=0.0))
    k32 = r.at(32e-6) if len(r.t) and r.t[-1] >= 32e-6 else None
    st = r.stations.get("x16.1mm", {})
    return {"initiation_us": ini["time_s"] * 1e6 if ini else None,
            "initiation_x1_mm": ini["x1_m"] * 1e3 if ini else None,
            "mode": "diverged" if s.get("watchdog") else (s.get("mode") or {}).get("label"),
            "peak_slip_rate_m_s": peak if np.isfinite(peak) else None,  # None: non-finite (diverged)
            "regions_at_32us": counts[k32] if k32 is not None else None,
            "regions_max": max(counts, default=0),
            "t_end_us": float(r.t[-1]) * 1e6 if len(r.t) else 0.0,
            "watchdog": s.get("watchdog"), "wall_s": (s.get("wall_s") or {}).get("total"),
            "slip_rate_spike": s.get("slip_rate_spike"),
            "station": {"t": st.get("time", np.zeros(0)), "v": st.get("slip_rate", np.zeros(0))}}


results = {}
for v_scale in a.v_scales:
    for law in LAWS:
        extra = [f"friction.law='{law}'", "output.fields=[]"]
        args = common.options("rate_tangent", "", ["--preset", a.preset, "--v-scale", f"{v_scale:g}", "--quiet"]
                              + [x for e in extra for x in ("--set", e)]
                              + (["--t-end", repr(a.t_end)] if a.t_end is not None else []))
        for name in a.scenes:
            sc = common.scene(name, args)
            d = a.work / f"v{v_scale:g}" / law / name
            if not comm.bcast(finished(d, sc) if comm.rank == 0 else None, root=0):
                runner.run_scene(sc, d, comm, overwrite=True, quiet=True)
            if comm.rank == 0:
                m = measure(d)
                results[(v_scale, law, name)] = m
                print(f"V_imp × {v_scale:g} {name} {law}: starts {m['initiation_us']} µs, {m['mode']}, "
                      f"peak {m['peak_slip_rate_m_s']} m/s, regions {m['regions_at_32us']} at 32 µs "
                      f"(max {m['regions_max']}){' — ' + m['watchdog'] if m['watchdog'] else ''}", flush=True)

if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a.out.mkdir(parents=True, exist_ok=True)
    doc = {"preset": a.preset, "t_end_s": a.t_end, "runs": [
        {"v_scale": v, "law": law, "scene": name, **{k: x for k, x in m.items() if k != "station"}}
        for (v, law, name), m in results.items()]}
    (a.out / "rate_tangent.json").write_text(json.dumps(doc, indent=2, allow_nan=False))
    fig, axs = plt.subplots(len(a.v_scales), len(a.scenes), figsize=(4.2 * len(a.scenes), 3.2 * len(a.v_scales)),
                            squeeze=False)
    for i, v in enumerate(a.v_scales):
        for j, name in enumerate(a.scenes):
            ax = axs[i][j]
            for law, ls in zip(LAWS, ("-", "--")):
                m = results[(v, law, name)]
                lab = "converged" if law == "povirk_needleman" else "plain rate-tangent"
                pk = m["peak_slip_rate_m_s"]
                ax.plot(m["station"]["t"] * 1e6, m["station"]["v"], ls, lw=1.0,
                        label=f"{lab}: {m['mode']}, peak {'non-finite' if pk is None else f'{pk:.0f} m/s'}")
            ax.set_title(f"{name}, V_imp × {v:g}", fontsize=9)
            ax.set_xlabel("t [µs]")
            ax.set_ylabel("Δu̇_slip at 16.1 mm [m/s]")
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.out / "rate_tangent.png", dpi=110)
