# # Cost of the interface kernel (with its sub-steps) against the bulk K·u
#
# Runs Case I's geometry at V_imp = 10 m/s (sliding crack-like from 9 µs) on
# the reference mesh with the Povirk–Needleman law and, over the steps from
# 20 to 32 µs (while ~40 mm of interface slides), reads the step's named
# timers: `bulk` (PETSc MatMult K·u), `interface` (PETSc gather of the partner
# dofs, the numba kernel with the law's adaptive sub-steps, reverse
# scatter-add) and `update` (the fused leapfrog pass, the struck edge and its
# work).  Prints µs per step per phase and interface / K·u.
#
# Run: `mpirun -n 2 .venv/bin/python benchmarks/interface_cost.py [--preset reference]`

import argparse
import json
import logging

from mpi4py import MPI

from fricfem import config, run, solver

logging.getLogger().setLevel(logging.WARNING)
ap = argparse.ArgumentParser()
ap.add_argument("--preset", default="reference")
a = ap.parse_args()
comm = MPI.COMM_WORLD
scene = config.load("case1", ["loading.v_imp=10", f"mesh.preset='{a.preset}'"])
_, model = run.build_model(scene, comm)
state = solver.State(model)
for _ in solver.evolve(model, state, 20e-6):
    pass
timers, n, nsub, npts = {}, 0, 0, 0
while state.t < 32e-6:
    solver.step(model, state, timers=timers)
    n += 1
    nsub += int(model.interface.points.nsub.sum())
    npts += len(model.interface.points.nsub)
slowest = {k: comm.allreduce(v, op=MPI.MAX) for k, v in sorted(timers.items())}
res = {"ranks": comm.size, "preset": a.preset, "steps": n,
       **{f"{k}_us": 1e6 * v / n for k, v in slowest.items()},
       "interface_over_bulk": slowest["interface"] / slowest["bulk"],
       "mean_substeps_per_point_step": comm.allreduce(nsub, op=MPI.SUM) / comm.allreduce(npts, op=MPI.SUM)}
if comm.rank == 0:
    print(json.dumps(res, indent=2))
