# # The elastic interface converging to the rigid one as its stiffness grows
#
# The paper's interface is a pair of springs C_n, C_s between the plates
# (``interface.kind = "elastic"``); the rigid split-node interface
# (``"rigid"``) is their limit C → ∞ with no spring and the bulk's stable step.
# How close is a finite C?  The compliance of a spring against the plate's
# own stiffness over a cell is μ/(C h) (μ the shear modulus, h the cell size):
# the bias of the elastic interface should fall like it.
#
# The problem: tpv205_2d (the slip-weakening rupture with heterogeneous
# initial stress of benchmarks/peer/; fricfem/scenes/tpv205_2d.toml), to
# 30 µs, on two meshes (h = 0.2 and 0.1 mm in the band along the fault),
# elastic with C_n = C_s = C on a ladder 1e12 … 1e15 Pa/m, and rigid.  For
# each run, the rupture times at the peer's stations (first slip rate
# > 1e-3 m/s, interpolated), measured as in benchmarks/peer/score.py, at the
# stations the peer's rupture reaches after 1 µs (not the nucleation patch):
#
# - bias: the worst |t_r(elastic, C) − t_r(rigid)| on the same mesh, in % of
#   t_r, against μ/(C h);
# - error: the worst |t_r − t_r(SEM2DPACK p8_h0.0625mm)| in %, elastic and
#   rigid, on the same axis — where the bias stops mattering.
#
# Run (~30 min on 2 busy cores):
#
#     .venv/bin/python benchmarks/rigid_convergence.py [--h 0.2e-3 0.1e-3] [--C 1e12 ... ]
#
# Runs go to ``runs/rigid_convergence/``; complete ones are reused.  Writes
# ``benchmarks/results/rigid_convergence.{json,md,png}``.

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "peer"))
import score  # noqa: E402  (benchmarks/peer/score.py: runs and station metrics)

ROOT = HERE.parent
RESULTS = HERE / "results"
PROBLEM = "tpv205_2d"
C_LADDER = (1e12, 3e12, 1e13, 3e13, 1e14, 3e14, 1e15)


def rupture_times(rundir: Path, kind: str, xs, t_end: float) -> dict:
    m = score.run_metrics(rundir, kind, xs, t_end)
    return {x: m[x]["t_r"] for x in xs}


def worst_pct(tr: dict, ref: dict, scored) -> float:
    """Worst |t_r − t_r,ref| in % of t_r,ref over the stations ``scored``."""
    out = 0.0
    for x in scored:
        t, r = tr.get(x), ref.get(x)
        out = max(out, np.inf if t is None or r is None else abs(100 * (t - r) / r))
    return out


def study(args) -> dict:
    from fricfem import load_scene

    mu = load_scene(PROBLEM).material.mu
    peer = score.peer_metrics(PROBLEM, score.REFERENCE)
    xs = sorted(peer["stations"])
    peer_tr = {x: s["t_r"] for x, s in peer["stations"].items()}
    scored = [x for x, t in peer_tr.items() if t is not None and t > score.T_R_MIN]  # as score.errors
    work = ROOT / "runs" / "rigid_convergence" / args.tag
    doc = {"problem": PROBLEM, "mu_Pa": mu, "reference": score.REFERENCE, "tag": args.tag, "note": args.note,
           "date": time.strftime("%Y-%m-%d %H:%M"), "meshes": []}
    for h in args.h:
        rigid_dir = work / f"rigid_h{h * 1e3:g}mm"
        rec = score.run_fricfem(PROBLEM, "rigid", h, rigid_dir, args.ranks, args.pythonpath, rerun=args.rerun)
        rig = rupture_times(rigid_dir, "rigid", xs, peer["end_s"])
        mesh = {"h_m": h, "rigid": {**rec, "t_r_s": rig, "err_pct": worst_pct(rig, peer_tr, scored)}, "elastic": [],
                "variants": {}}
        print(f"h = {h * 1e3:g} mm rigid: {rec['steps']} steps, error {mesh['rigid']['err_pct']:.2f} %", flush=True)
        for name, path in args.variants:
            d = work / f"rigid_{name}_h{h * 1e3:g}mm"
            rec = score.run_fricfem(PROBLEM, "rigid", h, d, args.ranks, path, rerun=args.rerun)
            tr = rupture_times(d, "rigid", xs, peer["end_s"])
            mesh["variants"][name] = {**rec, "t_r_s": tr, "err_pct": worst_pct(tr, peer_tr, scored)}
        for C in args.C:
            d = work / f"elastic_h{h * 1e3:g}mm_C{C:.0e}"
            sets = ("--set", f"interface.Cn={C!r}", "--set", f"interface.Cs={C!r}")
            rec = score.run_fricfem(PROBLEM, "elastic", h, d, args.ranks, args.pythonpath, rerun=args.rerun,
                                    extra=sets)
            el = rupture_times(d, "elastic", xs, peer["end_s"])
            row = {"C_Pa_m": C, "compliance": mu / (C * h), **rec, "t_r_s": el,
                   "bias_pct": worst_pct(el, rig, scored), "err_pct": worst_pct(el, peer_tr, scored),
                   "bias_variants_pct": {n: worst_pct(el, v["t_r_s"], scored) for n, v in mesh["variants"].items()}}
            mesh["elastic"].append(row)
            print(f"   C = {C:.0e}: mu/(C h) = {row['compliance']:.3g}, {rec['steps']} steps, bias against rigid "
                  f"{row['bias_pct']:.3f} %, error {row['err_pct']:.2f} %", flush=True)
        doc["meshes"].append(mesh)
    return doc


def report(doc: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    L = ["# Elastic interface → rigid as C grows", "",
         f"`.venv/bin/python benchmarks/rigid_convergence.py` ({doc['date']}; fricfem: {doc['note']}).  "
         f"{doc['problem']} to 30 µs, C_n = C_s = C; rupture times at the peer's stations (beyond 1 µs); bias = "
         "worst |t_r(elastic) − t_r(rigid)| on the same mesh; error = worst |t_r − t_r(SEM2DPACK "
         f"{doc['reference']})|, both in % of t_r.  μ = {doc['mu_Pa']:.4g} Pa.", ""]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for k, mesh in enumerate(doc["meshes"]):
        h = mesh["h_m"]
        rows = mesh["elastic"]
        comp = np.array([r["compliance"] for r in rows])
        bias = np.array([max(r["bias_pct"], 1e-4) for r in rows])
        err = np.array([r["err_pct"] for r in rows])
        names = list(mesh["variants"])
        L += [f"## h = {h * 1e3:g} mm", "", f"rigid: {mesh['rigid']['steps']} steps of "
              f"{mesh['rigid']['dt_s'] * 1e9:.2f} ns, error against the peer {mesh['rigid']['err_pct']:.2f} %"
              + "".join(f"; rigid [{n}]: error {v['err_pct']:.2f} %" for n, v in mesh["variants"].items()), "",
              "| C [Pa/m] | μ/(C h) | steps | dt [ns] | bias [%] | " + "".join(f"bias to [{n}] [%] | " for n in names)
              + "error [%] |", "|---|---|---|---|---|" + "---|" * len(names) + "---|"]
        for r in rows:
            L.append(f"| {r['C_Pa_m']:.0e} | {r['compliance']:.3g} | {r['steps']} | {r['dt_s'] * 1e9:.2f} | "
                     f"{r['bias_pct']:.3f} | " + "".join(f"{r['bias_variants_pct'][n]:.3f} | " for n in names)
                     + f"{r['err_pct']:.2f} |")
        L.append("")
        axes[0].loglog(comp, bias, "o-", color=f"C{k}", label=f"h = {h * 1e3:g} mm, to rigid")
        for n in names:
            bv = [max(r["bias_variants_pct"][n], 1e-4) for r in rows]
            axes[0].loglog(comp, bv, "s--", color=f"C{k}", mfc="none", label=f"h = {h * 1e3:g} mm, to rigid [{n}]")
            axes[1].axhline(mesh["variants"][n]["err_pct"], color=f"C{k}", ls=":", label=f"rigid [{n}], h = "
                            f"{h * 1e3:g} mm")
        axes[1].loglog(comp, err, "o-", color=f"C{k}", label=f"elastic, h = {h * 1e3:g} mm")
        axes[1].axhline(mesh["rigid"]["err_pct"], color=f"C{k}", ls="--", label=f"rigid, h = {h * 1e3:g} mm")
    axes[0].set(xlabel="μ/(C h)", ylabel="worst |t_r(elastic) − t_r(rigid)| [%]",
                title="bias of the elastic interface against the rigid one")
    axes[1].set(xlabel="μ/(C h)", ylabel="worst |t_r − t_r(peer)| [%]", title="error against SEM2DPACK")
    for ax in axes:
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{doc['problem']}: elastic interface (C_n = C_s = C) against rigid split nodes")
    fig.tight_layout()
    fig.savefig(out / "rigid_convergence.png", dpi=110)
    plt.close(fig)
    L.append("![rigid convergence](rigid_convergence.png)")
    (out / "rigid_convergence.md").write_text("\n".join(L) + "\n")


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--h", nargs="+", type=float, default=[0.2e-3, 0.1e-3])
    ap.add_argument("--C", nargs="+", type=float, default=list(C_LADDER))
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--tag", default="tree")
    ap.add_argument("--note", default="as in this tree")
    ap.add_argument("--pythonpath", help="run fricfem from this source tree instead")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=DIR",
                    help="also a rigid run of fricfem from source tree DIR, as a second rigid reference")
    ap.add_argument("--rerun", action="store_true")
    ap.add_argument("--out", default=str(RESULTS))
    args = ap.parse_args(argv)
    args.variants = [tuple(v.split("=", 1)) for v in args.variant]
    doc = study(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "rigid_convergence.json").write_text(json.dumps(doc, indent=1, default=float))
    report(doc, out)
    return doc


if __name__ == "__main__":
    main()
