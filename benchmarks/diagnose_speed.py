# # The run's diagnostics (fronts and mode) timed over the points of a sweep
#
# Every run ends with `analysis.fronts` and `analysis.classify` on its
# interface history (fricfem/runner.py `_diagnose`); this times them again,
# serially, over the stored points of a sweep directory (best of 3 passes)
# and checks that each label is the point's own.  To compare two versions of
# fricfem on the same points, run it with each on PYTHONPATH:
#
#     mpirun -n 2 .venv/bin/fricfem sweep case1 --grid default --out /tmp/m8
#     git worktree add /tmp/old 1922b97
#     (cd /tmp && PYTHONPATH=/tmp/old /work/main/.venv/bin/python /work/main/benchmarks/diagnose_speed.py /tmp/m8)
#     (cd /tmp && PYTHONPATH=/work/main /work/main/.venv/bin/python /work/main/benchmarks/diagnose_speed.py /tmp/m8)
#
# prints which fricfem it imported and the seconds for all points.

import argparse
import json
import time
from pathlib import Path

import numpy as np

import fricfem
from fricfem import analysis

ap = argparse.ArgumentParser()
ap.add_argument("sweep_dir", type=Path, help="a fricfem sweep --out directory")
ap.add_argument("--repeats", type=int, default=3)
a = ap.parse_args()
data = []
for d in sorted((a.sweep_dir / "points").iterdir()):
    s = json.loads((d / "summary.json").read_text())
    r = fricfem.open_run(d)
    data.append((s, np.asarray(r.t), np.asarray(r.x1), np.asarray(r.slip_rate)))
s0, t0_, x0, r0 = data[0]
analysis.classify(t0_, x0, r0, s0["speeds"])  # warm: the compiled kernels are loaded once
best, same = [], True
for _ in range(a.repeats):
    t0 = time.perf_counter()
    for s, t, x1, rate in data:
        analysis.fronts(t, x1, rate, s["speeds"])
        label, _ = analysis.classify(t, x1, rate, s["speeds"])
        same &= label == (s.get("mode") or {}).get("label")
    best.append(time.perf_counter() - t0)
print(f"{fricfem.__file__}: {min(best):.3f} s for {len(data)} points (best of {a.repeats}); "
      f"labels the points' own: {same}")
