# # One full time step against a bare K·u on the same mesh, in the same process
#
# Case I's geometry struck at 10 m/s on the reference mesh, advanced to 20 µs
# (the interface slides crack-like over ~20 mm), then the best of 5 × 100
# calls of `solver.step` (fused: K·u, interface, update, struck edge) against
# 5 × 100 bare `K.mult` on the same matrix and vector.  The law is an argument:
# `stuck` (elastic interface, no friction) or `povirk_needleman`.
#
# Run: `[mpirun -n 2] .venv/bin/python benchmarks/step_vs_matmult.py stuck`
import time, json, logging, sys
logging.getLogger().setLevel(logging.WARNING)
from mpi4py import MPI
from fricfem import config, run, solver
comm = MPI.COMM_WORLD
law = sys.argv[1]
scene = config.load("case1", ["loading.v_imp=10", f"friction.law='{law}'", "friction.params={}"])
_, model = run.build_model(scene, comm)
st = solver.State(model)
for _ in solver.evolve(model, st, 20e-6): pass
res = {}
for name in ("step", "matmult"):
    best = 1e9
    for rep in range(5):
        comm.Barrier(); t0 = time.perf_counter()
        for i in range(100):
            if name == "step": solver.step(model, st)
            else: model.K.mult(st.u, st.f)
        comm.Barrier(); best = min(best, (time.perf_counter() - t0) / 100)
    res[name] = best * 1e6
if comm.rank == 0: print(law, comm.size, "ranks: step %.0f us, bare MatMult %.0f us, ratio %.2f" % (res["step"], res["matmult"], res["step"] / res["matmult"]))
