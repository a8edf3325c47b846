# # Cost of the interface kernel (with its sub-steps) against the bulk K·u
#
# Runs Case I's geometry at V_imp = 10 m/s (sliding crack-like from 9 µs) on
# the reference mesh with the Povirk–Needleman law and, over the steps from
# 20 to 32 µs (while ~40 mm of interface slides), reads the fused step's phase
# timers (``State.seconds``): `sweep` (the one pass over the rows of K that
# computes K·u and updates v and u), `interface` (PETSc gather of the partner
# dofs, the numba kernel with the law's adaptive sub-steps, reverse
# scatter-add) and `wait` (off-rank displacements).  Prints µs per step per
# phase, interface / sweep, and the whole step against a bare MatMult loop on
# the same matrix in the same process.
# `--law stuck` gives the elastic interface without friction.
#
# Run: `mpirun -n 2 .venv/bin/python benchmarks/interface_cost.py [--preset reference] [--law stuck]`

import argparse
import json
import logging
import time

from mpi4py import MPI

from fricfem import load_scene
from fricfem.model.build import build_model
from fricfem.step import State, evolve, step

logging.getLogger().setLevel(logging.WARNING)
ap = argparse.ArgumentParser()
ap.add_argument("--preset", default="reference")
ap.add_argument("--law", default="povirk_needleman")
a = ap.parse_args()
comm = MPI.COMM_WORLD
scene = load_scene("case1", ["loading.v_imp=10", f"mesh.preset='{a.preset}'", f"friction.law='{a.law}'",
                              "friction.params={}"])
_, model = build_model(scene, comm)
state = State(model)
for _ in evolve(model, state, 20e-6):
    pass
state.seconds = dict.fromkeys(state.seconds, 0.0)  # the fused step's phase timers
n, nsub, npts = 0, 0, 0
while state.t < 32e-6:
    step(model, state)
    n += 1
    nsub += int(state.points.nsub.sum())
    npts += len(state.points.nsub)
slowest = {k: comm.allreduce(v, op=MPI.MAX) for k, v in sorted(state.seconds.items())}
# a bare K·u loop on the same matrix and vectors, for the ratio
y = model.K.createVecRight()
comm.Barrier()
t0 = time.perf_counter()
for _ in range(n):
    model.K.mult(state.u, y)
comm.Barrier()
bare = time.perf_counter() - t0
res = {"ranks": comm.size, "preset": a.preset, "steps": n,
       **{f"{k}_us": 1e6 * v / n for k, v in slowest.items()},
       "interface_over_sweep": slowest["interface"] / slowest["sweep"],
       "step_us": 1e6 * sum(slowest.values()) / n, "bare_matmult_us": 1e6 * bare / n,
       "step_over_bare_matmult": sum(slowest.values()) / bare, "law": a.law, "dofs": 2 * model.V.dofmap.index_map.size_global,
       "mean_substeps_per_point_step": comm.allreduce(nsub, op=MPI.SUM) / comm.allreduce(npts, op=MPI.SUM)}
if comm.rank == 0:
    print(json.dumps(res, indent=2))
