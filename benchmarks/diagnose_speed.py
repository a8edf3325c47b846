# # The run's diagnostics (fronts and mode) timed over the points of a sweep
#
# Every run ends with `analysis.fronts` and `analysis.classify` on its
# interface history (fricfem/runner.py `_diagnose`); this times them again,
# serially, over the stored points of a sweep directory (best of 3 passes,
# after one call that loads the compiled kernels) and checks that each label
# is the point's own.  To compare two versions of fricfem on the same points,
# run it with each on PYTHONPATH:
#
#     mpirun -n 2 .venv/bin/fricfem sweep case1 --grid default --out /tmp/m8
#     git worktree add /tmp/old 1922b97
#     (cd /tmp && PYTHONPATH=/tmp/old /work/main/.venv/bin/python /work/main/benchmarks/diagnose_speed.py /tmp/m8)
#     (cd /tmp && PYTHONPATH=/work/main /work/main/.venv/bin/python /work/main/benchmarks/diagnose_speed.py /tmp/m8)
#
# prints which fricfem it imported and the seconds for all points.
# `benchmarks/sweep_speed.py` uses `load_points` and `time_points` on its map.

import argparse
import json
import time
from pathlib import Path

import numpy as np

import fricfem
from fricfem import analysis


def load_points(dirs) -> list:
    """(summary, t, x1, slip_rate) of each run directory in ``dirs``."""
    data = []
    for d in dirs:
        s = json.loads((Path(d) / "summary.json").read_text())
        r = fricfem.open_run(d)
        data.append((s, np.asarray(r.t), np.asarray(r.x1), np.asarray(r.slip_rate)))
    return data


def time_points(data: list, repeats: int = 1) -> tuple:
    """(seconds of each point, best of ``repeats`` passes; whether every label is the
    point's own), after one call that loads the compiled kernels."""
    s0, t0_, x0, r0 = data[0]
    analysis.classify(t0_, x0, r0, s0["speeds"])
    best, same = None, True
    for _ in range(repeats):
        took = []
        for s, t, x1, rate in data:
            t0 = time.perf_counter()
            analysis.fronts(t, x1, rate, s["speeds"])
            label, _ = analysis.classify(t, x1, rate, s["speeds"])
            took.append(time.perf_counter() - t0)
            same &= label == (s.get("mode") or {}).get("label")
        if best is None or sum(took) < sum(best):
            best = took
    return best, same


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("sweep_dir", type=Path, help="a fricfem sweep --out directory")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    data = load_points(sorted((a.sweep_dir / "points").iterdir()))
    took, same = time_points(data, a.repeats)
    print(f"{fricfem.__file__}: {sum(took):.3f} s for {len(data)} points (best of {a.repeats}); "
          f"labels the points' own: {same}")


if __name__ == "__main__":
    main()
