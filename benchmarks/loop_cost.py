# # The time loop with its outputs against a bare K·u, in one process
#
# ``fricfem run case1`` (reference mesh, the scene's own outputs: interface
# snapshots every 0.2 µs, one station every step, energies every 50 steps,
# three field snapshots) run ``--repeats`` times in this process on one model
# (:class:`fricfem.model.reuse.ModelCache`: the first run also compiles; it is
# the warm-up and not counted), each run followed by a bare PETSc ``K.mult``
# on the same matrix, timed over as many calls as the run has steps.  Per run,
# from its ``summary.json`` ``loop_cost`` (µs per step, rank 0, the steps after
# the first): the step alone, what the energy evaluations add, the monitor's
# parts (stations, the per-step reduction, interface snapshots, fields,
# flushes), their total and the loop's measured wall time; then the ratios
# loop / MatMult and step / MatMult of that run (same load).  The medians over
# the runs are the result; the load average is recorded beside each run.
#
# Run (under mpirun, like any fricfem run)::
#
#     mpirun -n 2 .venv/bin/python benchmarks/loop_cost.py [--repeats 5] [--json results/loop_cost.json]
#
# ``--preset coarse --set time.end=5e-6`` make a quick check (tests/test_loop_outputs.py calls
# :func:`measure` so).

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

#: the issue's goal: the whole loop with the default outputs per step / a bare MatMult
GOAL_LOOP = 1.3


def bare_matmult(model, calls: int) -> float:
    """Mean seconds of ``K.mult`` over ``calls`` calls (collective: barrier before and after)."""
    comm = model.comm
    x, y = model.K.createVecRight(), model.K.createVecLeft()
    x.set(1.0)
    model.K.mult(x, y)
    comm.Barrier()
    t0 = time.perf_counter()
    for _ in range(calls):
        model.K.mult(x, y)
    comm.Barrier()
    return (time.perf_counter() - t0) / calls


def measure(scene_ref: str, sets: list, repeats: int, out: Path, comm) -> dict:
    from fricfem import load_scene
    from fricfem.model.reuse import ModelCache
    from fricfem.runner import run_scene

    scene = load_scene(scene_ref, sets)
    cache = ModelCache()
    runs = []
    for k in range(repeats + 1):
        load = os.getloadavg()[0]
        s = run_scene(scene, out, comm, overwrite=True, quiet=True, build=cache.build)
        model = cache.build(scene, comm)[1]
        mm = bare_matmult(model, max(s["steps"], 100))
        if k == 0:  # the warm-up: compilation, caches
            continue
        lc = s["loop_cost"]
        runs.append({"load_before": load, "load_after": os.getloadavg()[0], "loop_cost_us": lc,
                     "matmult_us": 1e6 * mm, "loop_over_matmult": lc["wall"] / (1e6 * mm),
                     "step_over_matmult": lc["step"] / (1e6 * mm),
                     "steps": s["steps"], "dofs": s["dofs"], "wall_s": s["wall_s"]})
    cache.clear()
    med = lambda f: statistics.median(f(r) for r in runs)  # noqa: E731
    parts = list(runs[0]["loop_cost_us"])
    return {"scene": scene_ref, "sets": sets, "ranks": comm.size, "repeats": repeats, "runs": runs,
            "median": {"matmult_us": med(lambda r: r["matmult_us"]),
                       "loop_over_matmult": med(lambda r: r["loop_over_matmult"]),
                       "step_over_matmult": med(lambda r: r["step_over_matmult"]),
                       **{k: med(lambda r: r["loop_cost_us"][k]) for k in parts
                          if isinstance(runs[0]["loop_cost_us"][k], (int, float))}},
            "goal_loop_over_matmult": GOAL_LOOP}


def report(res: dict) -> str:
    m = res["median"]
    loads = ", ".join(f"{r['load_before']:.1f}" for r in res["runs"])
    sets = " ".join(res["sets"])
    rows = [f"{res['scene']} {sets} on {res['ranks']} rank(s), {res['runs'][0]['dofs']} dofs, "
            f"{res['runs'][0]['steps']} steps; median of {res['repeats']} runs (loads {loads}):",
            f"  bare MatMult {m['matmult_us']:.0f} µs",
            "  per step [µs]: " + ", ".join(f"{k} {m[k]:.1f}" for k in ("step", "energy", "stations", "watch",
                                                                        "snapshots", "fields_gauges", "flush",
                                                                        "outputs", "total", "wall")),
            f"  outputs {100 * m['outputs_share']:.1f} % of the loop",
            f"  loop / MatMult {m['loop_over_matmult']:.2f} (goal ≤ {res['goal_loop_over_matmult']}), "
            f"step / MatMult {m['step_over_matmult']:.2f}"]
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="the time loop with its outputs against a bare K·u")
    ap.add_argument("--scene", default="case1")
    ap.add_argument("--preset")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", type=Path, help="write the result here (rank 0)")
    a = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sets = list(a.set) + ([f"mesh.preset={a.preset!r}"] if a.preset else [])
    tmp = tempfile.mkdtemp(prefix="loop_cost_") if comm.rank == 0 else None
    out = Path(comm.bcast(tmp, root=0)) / "run"
    res = measure(a.scene, sets, a.repeats, out, comm)
    if comm.rank == 0:
        res["date"] = time.strftime("%Y-%m-%d %H:%M")
        print(report(res))
        if a.json:
            a.json.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
