# # All the paper's figures, one demo after the other
#
# Runs every demo of `demos/paper/` with the same options (see `_common.py`:
# `--preset`, `--direction`, `--v-scale`, `--set`, `--t-end`, `--rerun`), each
# writing to `OUT/<demo>/`, all sharing the run directories in `OUT/runs/`:
# the per-case demos run the scenes first, the tip-speed and Case I/III
# comparisons then reuse them.  At the end `OUT/index.json` lists every
# demo's numbers.
#
# Run: `mpirun -n 2 .venv/bin/python demos/paper/run_all.py [--out DIR] [options]`;
# started without mpirun it starts itself under `mpirun -n 2` (`--np N` to change).

import argparse
import importlib
import json
import os
import shutil
import sys
from pathlib import Path

DEMOS = ["fig07_symmetric", "fig08_09_case1", "fig10_11_case2", "fig12_13_case3", "fig15_16_case4",
         "fig17_18_case5", "fig06_tip_speed", "fig14_case1_vs_case3", "fig20_lineA", "fig21_lineB"]


def under_mpirun() -> bool:
    return any(k in os.environ for k in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"))


def relaunch(argv, np_: int):
    """Start this script again under ``mpirun -n np_`` (before MPI is initialised here)."""
    env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = [shutil.which("mpirun") or "mpirun", "-n", str(np_), sys.executable, __file__, *argv]
    os.execvpe(cmd[0], cmd, env)


def main(argv=None):
    ap = argparse.ArgumentParser(description="all the paper demos; other options go to every demo")
    ap.add_argument("--out", type=Path, default=Path("demos/output/paper"), help="OUT: holds OUT/<demo>/")
    ap.add_argument("--runs", type=Path, default=None, help="run directories (default OUT/runs)")
    ap.add_argument("--np", type=int, default=2, help="MPI ranks when started without mpirun")
    args, rest = ap.parse_known_args(sys.argv[1:] if argv is None else argv)
    if args.np > 1 and not under_mpirun():
        relaunch(sys.argv[1:], args.np)

    from mpi4py import MPI

    runs = args.runs or args.out / "runs"
    index = {}
    for name in DEMOS:
        demo = importlib.import_module(name)
        index[name] = demo.main(rest + ["--out", str(args.out / name), "--runs", str(runs)])
    if MPI.COMM_WORLD.rank == 0:
        (args.out / "index.json").write_text(json.dumps(index, indent=2, ensure_ascii=False) + "\n")
        print(f"\nevery demo's numbers: {args.out}/<demo>/numbers.json, together in {args.out / 'index.json'}")
    return index


if __name__ == "__main__":
    main()
