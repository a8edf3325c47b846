# # Throughput of the time step
#
# How long one explicit step takes, against the cost of the one operation it
# cannot avoid: the stiffness product ``K u``.  For each mesh and rank count:
#
# * ``fused``: :func:`fricfem.step.step` (:class:`fricfem.step.fused.FusedBulk`), one sweep over the rows of
#   ``K`` that updates ``v`` and ``u`` as each row's ``(K u)_i`` is done;
# * ``matmult_aij``: a bare PETSc ``K.mult(u, f)`` (AIJ, I-nodes off: the
#   matrix the solver assembles); ``matmult_sell``: the same in SELL storage;
# * ``interface``: the interface kernel with its two scatters, as timed inside
#   the fused step.
#
# Each is timed from two snapshots of Case I at 10 m/s (``PHASES``): at the
# onset of sliding, and once most of the interface slides (the friction law's
# cost grows with the number of sliding points).
#
# Derived: the ratio step / MatMult (AIJ; the target is <= 1.15), million dof
# updates per second, and the 1 → 2 rank speedup when both are in the results.
#
# Run (each run adds its rank count to ``results/throughput.json`` and redraws
# ``results/throughput.png``):
#
#     mpirun -n 1 .venv/bin/python benchmarks/throughput.py
#     mpirun -n 2 .venv/bin/python benchmarks/throughput.py
#
# ``--smoke`` takes the coarse mesh and a few steps (tests).  Timing: both
# steps start from the same snapshot of a warmed-up run (so they integrate the
# same steps), ``time.perf_counter`` between barriers, median of the repeats,
# the variants interleaved within each repeat; the ratio step / MatMult is
# taken within each repeat (the same load from other processes on both) and
# its median reported.

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from fricfem import load_scene
from fricfem.model.build import build_model
from fricfem.step import State, step

HERE = Path(__file__).resolve().parent
TARGET_RATIO = 1.15  # step / MatMult (issue "Fast and accurate")
TARGET_SPEEDUP = 1.8  # fine mesh, 1 -> 2 ranks


class Snapshot:
    """u, v, t and the interface points of a state, to restart timings from."""

    def __init__(self, model, state):
        self.model = model
        self.saved = state.snapshot()  # u, v, t, the interface points, the rows awake, ...
        self.u = self.saved["u"]

    def state(self):
        """A new state equal to the snapshot (State.restore: it steps on with the same bits)."""
        st = State(self.model)
        st.restore(self.saved)
        return st


def timed(comm, fn, n):
    """Seconds per call of ``fn`` over ``n`` calls, between barriers."""
    comm.Barrier()
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    comm.Barrier()
    return (time.perf_counter() - t0) / n


# ## One mesh


# Two snapshots of Case I at 10 m/s: ``onset`` at 5 µs (the interface sticks;
# sliding starts at the struck edge at 9.3 µs and spreads through the timed
# steps) and ``sliding`` at 36 µs (about 90 % of the interface points slide).
PHASES = {"onset": 5e-6, "sliding": 36e-6}


def measure(preset: str, comm, steps: int, repeats: int, t_snap: float) -> dict:
    scene = load_scene("case1", ["loading.v_imp=10", f"mesh.preset={preset}"])
    _, model = build_model(scene, comm)
    dofs = model.K.getSize()[0]
    # warm up (JIT, and into the phase to time), then snapshot
    st = State(model)
    while st.t < t_snap:
        step(model, st)
    sliding = int(comm.allreduce(int(np.count_nonzero(st.points.slip_rate > 0.0))))
    snap = Snapshot(model, st)
    step(model, snap.state())  # compile the fused kernels

    K = model.K
    K_sell = K.convert(PETSc.Mat.Type.SELL, out=PETSc.Mat())
    x = K.createVecRight()
    x.array[:] = snap.u
    y = K.createVecRight()

    us = {k: [] for k in ("fused", "matmult_aij", "matmult_sell", "interface", "sweep", "wait")}
    for _ in range(repeats):
        st = snap.state()
        us["fused"].append(1e6 * timed(comm, lambda: step(model, st), steps))
        phase = {k: comm.allreduce(v / steps, op=MPI.MAX) for k, v in st.seconds.items()}
        us["interface"].append(1e6 * phase["interface"])
        us["sweep"].append(1e6 * phase["sweep"])
        us["wait"].append(1e6 * phase["wait"])
        us["matmult_aij"].append(1e6 * timed(comm, lambda: K.mult(x, y), steps))
        us["matmult_sell"].append(1e6 * timed(comm, lambda: K_sell.mult(x, y), steps))
    med = {k: float(np.median(v)) for k, v in us.items()}
    aij = np.array(us["matmult_aij"])
    out = {
        "mesh": preset, "ranks": comm.size, "dofs": int(dofs), "steps": steps, "repeats": repeats,
        "interface_points": int(comm.allreduce(len(model.interface.geometry.x1))),
        "t_snapshot_us": 1e6 * st.t, "sliding_points_at_snapshot": sliding,
        "us_per_step": med,
        "us_per_step_min": {k: float(np.min(v)) for k, v in us.items()},
        "us_all": {k: [float(t) for t in v] for k, v in us.items()},
        # each repeat's step against the MatMult timed right after it (same load), median over repeats
        "ratio_fused": float(np.median(np.array(us["fused"]) / aij)),
        "mdof_updates_per_s": {k: dofs / med[k] for k in ("fused", "matmult_aij")},
    }
    K_sell.destroy()
    return out


# ## Results file, table and figure


def speedups(runs: dict) -> dict:
    """1 → 2 rank speedup per mesh and variant, where both runs are present."""
    out = {}
    for key, r1 in runs.items():
        mesh_name, ranks, phase = key.split("/")
        r2 = runs.get(f"{mesh_name}/2/{phase}")
        if ranks == "1" and r2 is not None:
            sp = {k: r1["us_per_step"][k] / r2["us_per_step"][k] for k in ("fused", "matmult_aij")}
            sp["fused_from_min"] = r1["us_per_step_min"]["fused"] / r2["us_per_step_min"]["fused"]
            out[f"{mesh_name}/{phase}"] = sp
    return out


def table(runs: dict, speed: dict) -> str:
    head = (f"{'mesh':>10} {'ranks':>5} {'phase':>8} {'slide':>5} {'dofs':>8} | {'fused':>8} {'AIJ':>8} {'SELL':>8} | "
            f"{'iface':>7} {'sweep':>7} {'wait':>6} | {'fu/AIJ':>6} | {'Mdof/s':>7}")
    lines = [head, "-" * len(head)]
    for r in runs.values():
        t = r["us_per_step"]
        lines.append(
            f"{r['mesh']:>10} {r['ranks']:>5} {r['phase']:>8} {r['sliding_points_at_snapshot']:5d} "
            f"{r['dofs']:>8} | {t['fused']:8.1f} "
            f"{t['matmult_aij']:8.1f} {t['matmult_sell']:8.1f} | {t['interface']:7.1f} {t['sweep']:7.1f} "
            f"{t['wait']:6.1f} | {r['ratio_fused']:6.2f} | "
            f"{r['mdof_updates_per_s']['fused']:7.0f}")
    lines.append("µs per step, median of the repeats; iface, sweep, wait: the phases of the fused step "
                 "(slowest rank)")
    lines.append(f"target: fused / AIJ <= {TARGET_RATIO}; slide: interface points sliding at the snapshot "
                 f"(phases: {', '.join(f'{k} from {1e6 * v:g} µs' for k, v in PHASES.items())})")
    for mesh_name, s in speed.items():
        lines.append(f"1 -> 2 ranks, {mesh_name}: fused {s['fused']:.2f}x, "
                     f"MatMult {s['matmult_aij']:.2f}x (target {TARGET_SPEEDUP} on the fine mesh)")
    return "\n".join(lines)


def figure(runs: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(runs)
    series = [("fused", "step, fused"), ("matmult_aij", "MatMult AIJ"),
              ("matmult_sell", "MatMult SELL"), ("interface", "interface kernel")]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [3, 2]})
    w = 0.8 / len(series)
    xs = np.arange(len(keys))
    for k, (name, label) in enumerate(series):
        ax.bar(xs + (k - 2) * w, [runs[key]["us_per_step"][name] for key in keys], w, label=label)
    ax.set_xticks(xs, [f"{runs[k]['mesh']}\n{runs[k]['ranks']} rank(s)\n{runs[k]['phase']}" for k in keys],
                  fontsize=7)
    ax.set_ylabel("µs per step")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
    ax.set_title("time per step")
    bx.bar(xs, [runs[k]["ratio_fused"] for k in keys], 0.6, label="fused step")
    bx.axhline(TARGET_RATIO, color="k", ls="--", lw=1, label=f"target {TARGET_RATIO}")
    bx.axhline(1.0, color="grey", lw=0.5)
    bx.set_xticks(xs, [f"{runs[k]['mesh']}\n{runs[k]['ranks']}\n{runs[k]['phase']}" for k in keys], fontsize=7)
    bx.set_ylabel("step / MatMult (AIJ)")
    bx.legend(fontsize=8)
    bx.set_title("cost of a step in MatMults")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    ap = argparse.ArgumentParser(description="Time per step of fricfem against a bare MatMult.")
    ap.add_argument("--meshes", nargs="+", default=["reference", "fine"])
    ap.add_argument("--steps", type=int, default=300, help="timed steps per repeat")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--phases", nargs="+", default=list(PHASES), choices=list(PHASES),
                    help="snapshots to time from (onset: 5 µs, sliding: 36 µs)")
    ap.add_argument("--smoke", action="store_true", help="coarse mesh, a few steps")
    ap.add_argument("--out", type=Path, default=None, help="default results/ (results/smoke/ with --smoke)")
    args = ap.parse_args(argv)
    if args.smoke:
        args.meshes, args.steps, args.repeats, args.phases = ["coarse"], 10, 2, ["onset"]
    if args.out is None:
        args.out = HERE / "results" / ("smoke" if args.smoke else "")

    results = {}
    for preset in args.meshes:
        for phase in args.phases:
            r = measure(preset, comm, args.steps, args.repeats, PHASES[phase])
            results[f"{preset}/{comm.size}/{phase}"] = dict(r, phase=phase)
    data = None
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
        path = args.out / "throughput.json"
        data = json.loads(path.read_text()) if path.exists() else {}
        data.setdefault("runs", {}).update(results)
        data["runs"] = dict(sorted(data["runs"].items(),
                                   key=lambda kv: (kv[1]["dofs"], kv[1].get("phase", ""), kv[1]["ranks"])))
        data["speedup_1_to_2"] = speedups(data["runs"])
        data["machine"] = {"node": platform.node(), "processor": platform.processor(),
                           "python": sys.version.split()[0], "petsc": ".".join(map(str, PETSc.Sys.getVersion()))}
        data["target"] = {"ratio": TARGET_RATIO, "speedup_fine": TARGET_SPEEDUP}
        path.write_text(json.dumps(data, indent=2))
        figure(data["runs"], args.out / "throughput.png")
        print(table(data["runs"], data["speedup_1_to_2"]))
    return comm.bcast(data, root=0)


if __name__ == "__main__":
    main()
