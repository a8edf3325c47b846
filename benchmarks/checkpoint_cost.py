# # What a checkpoint costs, in steps
#
# Case III (``case3``) run in this process with ``output.checkpoint_every`` set,
# once to warm up (the kernels' compilation), then ``--repeats`` times; every
# checkpoint is timed as the run takes it (the flush before it, the gather of the
# state in the grid's order to rank 0, the write, fsync and rename:
# :class:`fricfem.output.checkpoint.Checkpointer` in the steps that took one), and the step
# from the run's ``summary.json`` (``us_per_step``: the time loop without its
# outputs, per step).  The result is the median checkpoint in µs and as a
# number of steps, with the file's size.
#
# Run (under mpirun, like any fricfem run)::
#
#     mpirun -n 2 .venv/bin/python benchmarks/checkpoint_cost.py --preset coarse
#     mpirun -n 2 .venv/bin/python benchmarks/checkpoint_cost.py --preset reference

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from fricfem import load_scene, runner
from fricfem.model.reuse import ModelCache
from fricfem.output import checkpoint


def measure(preset: str, t_end: float, every: float, repeats: int, comm=MPI.COMM_WORLD) -> dict:
    """Median checkpoint wall time [µs] (rank 0), µs per step, and their ratio."""
    scene = load_scene("case3", [f"mesh.preset='{preset}'", f"time.end={t_end}", "output.fields=[]",
                                 f"output.checkpoint_every={every}"])
    times, steps, size = [], [], 0
    observe = checkpoint.Checkpointer.observe

    def timed(self, state, energy):  # the steps that took one: the flush, the gather, the write
        nonlocal size
        before, t0 = self.checkpoints.taken, time.perf_counter()
        observe(self, state, energy)
        if self.checkpoints.taken > before:
            times.append(time.perf_counter() - t0)
            size = self.checkpoints.bytes

    checkpoint.Checkpointer.observe = timed
    models = ModelCache()
    try:
        tmp = Path(comm.bcast(tempfile.mkdtemp(prefix="fricfem-ckpt-") if comm.rank == 0 else None, root=0))
        for k in range(repeats + 1):
            first = len(times)
            summary = runner.run_scene(scene, tmp / f"run{k}", comm, overwrite=True, quiet=True, build=models.build)
            if k == 0:  # the warm-up: compilation, caches
                del times[first:]
                continue
            steps.append(summary["us_per_step"])
    finally:
        checkpoint.Checkpointer.observe = observe
    us = 1e6 * statistics.median(times)
    step = statistics.median(steps)
    return {"preset": preset, "ranks": comm.size, "checkpoints": len(times), "checkpoint_us": us,
            "us_per_step": step, "steps_per_checkpoint_cost": us / step, "bytes": size}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="What a checkpoint costs, in steps (benchmarks/checkpoint_cost.py)")
    ap.add_argument("--preset", default="coarse", choices=("coarse", "reference", "half", "fine"))
    ap.add_argument("--t-end", type=float, default=20e-6, help="time.end [s]")
    ap.add_argument("--every", type=float, default=2e-6, help="output.checkpoint_every [s]")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    res = measure(args.preset, args.t_end, args.every, args.repeats)
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
