# # One full time step against a bare K·u on the same mesh, in the same process
#
# Case I's geometry struck at 10 m/s on the reference mesh, advanced to 20 µs
# (the interface slides crack-like over ~20 mm), then the best of 5 × 100
# calls of `step` (fused: K·u, interface, update, struck edge) against
# the best of 5 × 100 bare `K.mult` on the same matrix and vector; the step's
# phases (interface, sweep, wait: `State.seconds`, slowest rank) are those of
# its best loop.  The law is an argument: `stuck` (elastic interface, no
# friction) or `povirk_needleman`.
#
# Run: `[mpirun -n 2] .venv/bin/python benchmarks/step_vs_matmult.py stuck`

import argparse
import logging
import time

from mpi4py import MPI

from fricfem import load_scene
from fricfem.model.build import build_model
from fricfem.step import State, step
from fricfem.step import evolve

logging.getLogger().setLevel(logging.WARNING)
ap = argparse.ArgumentParser()
ap.add_argument("law", nargs="?", default="stuck", help="stuck or povirk_needleman")
ap.add_argument("--preset", default="reference")
a = ap.parse_args()
comm = MPI.COMM_WORLD
scene = load_scene("case1", ["loading.v_imp=10", f"friction.law='{a.law}'", "friction.params={}",
                              f"mesh.preset='{a.preset}'"])
_, model = build_model(scene, comm)
state = State(model)
for _ in evolve(model, state, 20e-6):
    pass


def best_of(fn, repeats=5, calls=100):
    """Best mean seconds per call over ``repeats`` timed loops (collective), and
    the step's phases [s per call] in that loop (slowest rank)."""
    best, phases = float("inf"), {}
    for _ in range(repeats):
        state.seconds = dict.fromkeys(state.seconds, 0.0)
        comm.Barrier()
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        comm.Barrier()
        t = (time.perf_counter() - t0) / calls
        if t < best:
            best = t
            phases = {k: comm.allreduce(v / calls, op=MPI.MAX) for k, v in state.seconds.items()}
    return best, phases


t_step, phases = best_of(lambda: step(model, state))
t_mat, _ = best_of(lambda: model.K.mult(state.u, state.f))
if comm.rank == 0:
    split = ", ".join(f"{k} {1e6 * v:.0f}" for k, v in phases.items())
    print(f"{a.law}, {a.preset}, {comm.size} rank(s): step {1e6 * t_step:.0f} µs ({split}), bare MatMult "
          f"{1e6 * t_mat:.0f} µs, ratio {t_step / t_mat:.2f}")
