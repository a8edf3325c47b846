# # Memory of a run: set-up and loop peaks against the mesh size
#
# The numbers behind the memory estimate of the cost guard
# (fricfem/scene/cost.py, MEMORY): the peak resident set (``VmHWM`` of
# /proc/self/status, each rank) after the set-up (mesh, numbering, K's rows,
# lumped mass, interface, λmax, the fused step) and after a short time loop,
# summed over the ranks, for one scene at several cell sizes, with the set-up
# cache off (λmax by power iteration, K's rows computed: the cold set-up a new
# mesh gets).  Also the set-up's wall time and the time of the power
# iteration (λmax), and whether K was assembled as a PETSc matrix.
#
# Run (each configuration in its own ``mpirun`` so that every peak is its own):
#
#     export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
#     mpirun -n 2 .venv/bin/python benchmarks/memory.py --h 5e-4 --kind rigid --absorbing
#
# Each run appends one JSON line to ``benchmarks/results/memory.jsonl`` (or
# ``--out``) and prints it.

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

if "--warm" not in os.sys.argv:
    os.environ["FRICFEM_CACHE"] = "off"  # a cold set-up: λmax and K's rows computed

from mpi4py import MPI  # noqa: E402

import fricfem  # noqa: E402
from fricfem.model import build as build_mod  # noqa: E402
from fricfem.runner import run_scene  # noqa: E402
from fricfem.scene import cost  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def hwm() -> int:
    """This process's peak resident set [bytes] (VmHWM)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scene", default="rsf_aging_2d")
    ap.add_argument("--h", type=float, default=5e-4, help="mesh.dx = mesh.dy [m]")
    ap.add_argument("--band", type=float, default=None, help="mesh.fine_height [m]")
    ap.add_argument("--kind", default="rigid", choices=("rigid", "elastic"))
    ap.add_argument("--absorbing", action="store_true", help="all four outer edges absorbing")
    ap.add_argument("--end", type=float, default=2e-6, help="time.end [s] of the short loop")
    ap.add_argument("--out", default=str(RESULTS / "memory.jsonl"))
    ap.add_argument("--warm", action="store_true", help="keep the set-up cache on (λmax and K's rows from "
                    "$FRICFEM_CACHE when a run has put them there)")
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    sets = [f"mesh.dx={args.h}", f"mesh.dy={args.h}", f"interface.kind='{args.kind}'", f"time.end={args.end}",
            "output.stations={}", "output.diagnostics=false"]
    if args.band is not None:
        sets.append(f"mesh.fine_height={args.band}")
    if args.absorbing:
        sets.append("mesh.absorbing=['bottom', 'top', 'left', 'right']")
    scene = fricfem.load_scene(args.scene, sets)
    est = cost.estimate(scene)
    base = hwm()
    info = {}
    inner = build_mod.max_eigenvalue

    def timed_lam(*a, **k):
        info["before_lam_hwm"] = hwm()
        t0 = time.perf_counter()
        lam = inner(*a, **k)
        info["lam_s"] = info.get("lam_s", 0.0) + time.perf_counter() - t0
        return lam

    build_mod.max_eigenvalue = timed_lam

    def build(sc, cm):
        t0 = time.perf_counter()
        pm, model = build_mod.build_model(sc, cm)
        info["setup_s"] = time.perf_counter() - t0
        info["setup_hwm"] = hwm()
        info["K_assembled"] = model.K._mat is not None
        return pm, model

    out = tempfile.mkdtemp(prefix="fricfem-mem-") if comm.rank == 0 else None
    out = comm.bcast(out, root=0)
    record = run_scene(scene, Path(out) / "run", comm, overwrite=True, quiet=True, build=build)
    loop = hwm()
    per_rank = comm.gather((base, info["setup_hwm"], loop, info.get("lam_s", 0.0), info["setup_s"],
                            info.get("before_lam_hwm", 0)), root=0)
    if comm.rank == 0:
        row = {"scene": args.scene, "h_m": args.h, "band_m": args.band, "kind": args.kind,
               "absorbing": args.absorbing, "warm": args.warm, "ranks": comm.size, "quads": est.quads, "dofs": record["dofs"],
               "interface_points": record["interface_points"], "steps": record["steps"],
               "import_bytes": sum(r[0] for r in per_rank),
               "before_lam_peak_bytes": sum(r[5] for r in per_rank), "setup_peak_bytes": sum(r[1] for r in per_rank),
               "loop_peak_bytes": sum(r[2] for r in per_rank), "rank_peaks_bytes": [r[2] for r in per_rank],
               "lam_s": max(r[3] for r in per_rank), "setup_s": max(r[4] for r in per_rank),
               "K_assembled": info["K_assembled"]}
        line = json.dumps(row)
        print(line, flush=True)
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "a") as fh:
            fh.write(line + "\n")
        import shutil

        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
