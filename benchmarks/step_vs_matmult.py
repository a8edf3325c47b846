# # One full time step against a bare K·u on the same mesh, in the same process
#
# Case I's geometry struck at 10 m/s on the reference mesh, advanced to 20 µs
# (the interface slides crack-like over ~20 mm; ``--at``, ``--v-imp`` choose
# another state, the line printed says how many points slide), then the best of 5 × 100
# calls of `step` (fused: K·u, interface, update, struck edge) against
# the best of 5 × 100 bare `K.mult` on the same matrix and vector (the loops
# alternate, step then MatMult, so that a busy spell touches both); the step's
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
ap.add_argument("--at", type=float, default=20e-6, help="time the state is advanced to before timing [s]")
ap.add_argument("--v-imp", type=float, default=10.0, help="impact speed [m/s]")
a = ap.parse_args()
comm = MPI.COMM_WORLD
scene = load_scene("case1", [f"loading.v_imp={a.v_imp!r}", f"friction.law='{a.law}'", "friction.params={}",
                              f"mesh.preset='{a.preset}'"])
_, model = build_model(scene, comm)
state = State(model)
for _ in evolve(model, state, a.at):
    pass
p = state.points
sliding = comm.allreduce(int((p.slip_rate > 0).sum()), op=MPI.SUM)
points = comm.allreduce(len(p.slip_rate), op=MPI.SUM)


def timed_loop(fn, calls=100):
    """Mean seconds per call of one timed loop (collective), and the step's
    phases [s per call] in it (slowest rank)."""
    state.seconds = dict.fromkeys(state.seconds, 0.0)
    comm.Barrier()
    t0 = time.perf_counter()
    for _ in range(calls):
        fn()
    comm.Barrier()
    t = (time.perf_counter() - t0) / calls
    return t, {k: comm.allreduce(v / calls, op=MPI.MAX) for k, v in state.seconds.items()}


# the step's loops and MatMult's alternate, so that a busy spell of the machine
# touches both; the best of each
t_step, phases, t_mat = float("inf"), {}, float("inf")
f = model.K.createVecRight()  # MatMult's output (the State holds no scratch vector)
for _ in range(5):
    t, ph = timed_loop(lambda: step(model, state))
    if t < t_step:
        t_step, phases = t, ph
    t_mat = min(t_mat, timed_loop(lambda: model.K.mult(state.u, f))[0])
if comm.rank == 0:
    split = ", ".join(f"{k} {1e6 * v:.0f}" for k, v in phases.items())
    print(f"{a.law}, {a.preset}, {comm.size} rank(s): step {1e6 * t_step:.0f} µs ({split}), bare MatMult "
          f"{1e6 * t_mat:.0f} µs, ratio {t_step / t_mat:.2f}; at {a.at * 1e6:g} µs, v_imp {a.v_imp:g} m/s, "
          f"{sliding} of {points} interface points sliding")
