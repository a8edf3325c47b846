# # Recompute points of a stored sweep and compare their interface.h5 bit for bit
#
# For a map computed over several calls (or code changes that should not alter
# the physics): each named point of the sweep directory is run again with the
# current code into a scratch directory (the same scene, one rank per point as
# the sweep ran it) and every dataset of its interface.h5 compared with the
# stored one, byte for byte; the labels too.
#
#     mpirun -n 2 .venv/bin/python benchmarks/recheck_points.py runs/sweep32/full \
#         --sigma0 0.9:40:32 --v-imp 1:40:32 --points s0.9_v1,s13.29_v35.51 --json out.json

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
from mpi4py import MPI

from fricfem import batch
from fricfem.output.rundir import read_summary
from fricfem.sweep import parse_axis, plan


def differing(a_path: Path, b_path: Path) -> tuple:
    """(number of datasets, names of those whose bytes differ) between two interface files."""
    names, bad = [], []
    with h5py.File(a_path, "r") as a, h5py.File(b_path, "r") as b:
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            if n not in b or np.asarray(a[n]).tobytes() != np.asarray(b[n]).tobytes():
                bad.append(n)
    return len(names), bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="recompute points of a sweep and compare interface.h5 bit for bit")
    ap.add_argument("sweep_dir", type=Path)
    ap.add_argument("--scene", default="case1")
    ap.add_argument("--sigma0", required=True)
    ap.add_argument("--v-imp", required=True)
    ap.add_argument("--points", required=True, help="point keys, comma-separated (s<Σ0>_v<V>)")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    keys = a.points.split(",")
    tmp = Path(comm.bcast(tempfile.mkdtemp(prefix="recheck_") if comm.rank == 0 else None, root=0))
    s, v = parse_axis(a.sigma0, "--sigma0", "MPa"), parse_axis(a.v_imp, "--v-imp", "m/s")
    _, points = plan(a.scene, s, v, [], None, False, tmp)
    pts = [p for p in points if p.key in keys]
    batch.run_jobs([p.job for p in pts], comm, ranks_per_job=1)
    if comm.rank == 0:
        res = []
        for p in pts:
            stored = a.sweep_dir / "points" / p.key
            n, bad = differing(stored / "interface.h5", p.dir / "interface.h5")
            label = lambda d: (read_summary(d).get("mode") or {}).get("label")  # noqa: E731
            res.append({"key": p.key, "datasets": n, "differ": bad, "label_stored": label(stored),
                        "label_now": label(p.dir), "bit_identical": not bad})
            print(f"{p.key}: {n} datasets, differing: {bad or 'none'}; label stored {res[-1]['label_stored']}, "
                  f"now {res[-1]['label_now']}")
        if a.json:
            a.json.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
