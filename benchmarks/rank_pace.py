# # The interface's parts on each rank, from one sliding state
#
# Case I's geometry struck at 10 m/s on the reference mesh, advanced to 20 µs
# (as `step_vs_matmult.py`), then on every rank, best of 5 × 200 calls each:
# a plain copy of the rank's interface point arrays (the state restored before
# each kernel call), the friction kernel from that restored state, the whole
# `Interface.advance` (gather, kernel, send), the gather and the send alone.
# Equal work on the ranks with unequal times says a CPU runs slower, not the
# code; `--seg-block` deals the interface segments in other blocks.
#
# Run: `mpirun -n 2 .venv/bin/python benchmarks/rank_pace.py [--seg-block 8]`

import argparse
import time

import numpy as np
from mpi4py import MPI

from fricfem import load_scene
from fricfem.model import interface as interface_mod
from fricfem.model.build import build_model
from fricfem.step import State, evolve

ap = argparse.ArgumentParser()
ap.add_argument("--seg-block", type=int, default=interface_mod.SEG_BLOCK)
a = ap.parse_args()
interface_mod.SEG_BLOCK = a.seg_block
comm = MPI.COMM_WORLD
scene = load_scene("case1", ["loading.v_imp=10.0", "friction.law='povirk_needleman'", "friction.params={}"])
_, model = build_model(scene, comm)
state = State(model)
for _ in evolve(model, state, 20e-6):
    pass
itf, u, dt = model.interface, state.u, model.dt
g = itf.geometry


def arrays(x):
    if isinstance(x, np.ndarray):
        yield x
    elif isinstance(x, tuple):
        for y in x:
            yield from arrays(y)


saved = [(x, x.copy()) for x in arrays(state.points.kernel_state())]  # the state's (the model's are read-only)


def restore():
    for x, c in saved:
        np.copyto(x, c)


def best_us(fn, calls=200):
    best = np.inf
    for _ in range(5):
        comm.Barrier()
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - t0) / calls)
    return 1e6 * best


sliding = int((state.points.slip_rate > 0).sum())
itf._gather(u)
w = g.work.array
res = {"copy": best_us(restore)}
res["kernel"] = best_us(lambda: (restore(), itf.kernel(w, g.force.array, itf._geom, itf._const,
                                                           state.points.kernel_state(), dt))) \
    - res["copy"]
res["advance"] = best_us(lambda: (restore(), itf.advance(state, u, dt))) - res["copy"]
res["gather"] = best_us(lambda: itf._gather(u))
res["send"] = best_us(itf._send)
rows = comm.gather((res, sliding, len(state.points.slip_rate)), root=0)
if comm.rank == 0:
    print(f"segments dealt in blocks of {a.seg_block}; µs per call, best of 5 × 200")
    for r, (d, sl, n) in enumerate(rows):
        print(f"rank {r}: {sl} of {n} points sliding; " + ", ".join(f"{k} {v:.1f}" for k, v in d.items()))
