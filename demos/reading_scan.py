# # Which reading of the paper's loading fits its statements best?
#
# Runs `demos/reproduction.py`'s statement check for a list of readings
# (direction of the edge velocity × a factor on every V_imp × a factor on
# C_n, C_s; one reading applies to every scene, nothing is fitted per case)
# and ranks them by the number of statements met.  Results (finished runs are
# reused) go to `--out`; the ranking to `reading_scan.json` / `.md` there.
#
# Run: `mpirun -n 2 .venv/bin/python demos/reading_scan.py --out runs/readings`

import argparse
import itertools
import json
from pathlib import Path

from mpi4py import MPI

import reproduction as rp  # the statements and readings (demos/reproduction.py)

from fricfem import load_scene

ap = argparse.ArgumentParser()
ap.add_argument("--directions", default="push,pull")
ap.add_argument("--v-scales", default="1,2.5,5,7.5")
ap.add_argument("--stiffness-scales", default="1")
ap.add_argument("--preset", default="reference")
ap.add_argument("--out", default="runs/readings")
a = ap.parse_args()
comm = MPI.COMM_WORLD
speeds = load_scene("case1").material.speeds()
ranking = []
for d, v, k in itertools.product(a.directions.split(","), map(float, a.v_scales.split(",")),
                                 map(float, a.stiffness_scales.split(","))):
    reading = rp.Reading(d, v, k, a.preset)
    out = Path(a.out) / f"{d}_v{v:g}_k{k:g}_{a.preset}"
    runs = rp.run_all(reading, out, comm)
    if comm.rank == 0:
        rows = rp.statements(runs, speeds)
        (out / "statements.json").write_text(json.dumps({"reading": reading._asdict(), "rows": rows}, indent=2))
        (out / "statements.md").write_text(rp.markdown(rows, reading))
        met = sum(r["ok"] for r in rows)
        ranking.append({"reading": reading._asdict(), "met": met, "total": len(rows),
                        "met_statements": [f"{r['group']}: {r['statement']}" for r in rows if r["ok"]]})
        print(f"{d:5s} V×{v:<4g} C×{k:<4g} {met:3d} / {len(rows)}", flush=True)
if comm.rank == 0:
    ranking.sort(key=lambda r: -r["met"])
    Path(a.out, "reading_scan.json").write_text(json.dumps(ranking, indent=2))
    lines = ["| rank | direction | V_imp × | C_n, C_s × | statements met |", "|---|---|---|---|---|"]
    for i, r in enumerate(ranking, 1):
        rd = r["reading"]
        lines.append(f"| {i} | {rd['direction']} | {rd['v_scale']:g} | {rd['stiffness_scale']:g} | "
                     f"{r['met']} / {r['total']} |")
    Path(a.out, "reading_scan.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
