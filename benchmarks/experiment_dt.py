"""What the steel costs in time step: the stable step 2/√λmax of the experiment's
model (plates, steel buffer and projectile) against the same plates alone, on
each mesh preset, and the number of steel cells.

    mpirun -n 2 .venv/bin/python benchmarks/experiment_dt.py [--presets coarse,reference,half,fine]

Writes benchmarks/results/experiment_dt.json.  Both models are built in the
same run, so the ratio does not depend on the machine.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem.model.bodies import body_of_cells
from fricfem.model.build import build_model
from fricfem.scene import apply_overrides, resolve, validate


def measure(preset: str, comm) -> dict:
    row = {"preset": preset}
    raw = apply_overrides(resolve("experiment_42"), [f"mesh.preset='{preset}'"])
    plates = {k: v for k, v in raw.items() if k != "experiment"}  # the same plates without the steel
    plates["mesh"] = {**plates["mesh"], "impact_b": raw["experiment"]["projectile_diameter"]}
    for label, table in (("plates", plates), ("experiment", raw)):
        scene = validate(table)
        pm, model = build_model(scene, comm)
        row[f"dt_crit_{label}_s"] = model.dt_crit
        row[f"dt_{label}_s"] = model.dt
        row[f"dofs_{label}"] = 2 * pm.mesh.topology.index_map(0).size_global
        if label == "experiment":
            body = body_of_cells(model.num.x, model.num.cells, scene.mesh)
            row["steel_triangles"] = int(np.count_nonzero(body > 0))
            row["triangles"] = int(len(body))
    row["dt_ratio"] = row["dt_crit_experiment_s"] / row["dt_crit_plates_s"]
    row["steps_ratio"] = row["dt_plates_s"] / row["dt_experiment_s"]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="coarse,reference,half,fine")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "experiment_dt.json"))
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    rows = [measure(p, comm) for p in args.presets.split(",")]
    if comm.rank == 0:
        Path(args.out).write_text(json.dumps(rows, indent=1) + "\n")
        for r in rows:
            print(f"{r['preset']:>9}: dt_crit {r['dt_crit_plates_s'] * 1e9:.1f} ns (plates) -> "
                  f"{r['dt_crit_experiment_s'] * 1e9:.1f} ns (with steel), ratio {r['dt_ratio']:.3f}; "
                  f"steps x {r['steps_ratio']:.3f}; dofs {r['dofs_plates']} -> {r['dofs_experiment']}")


if __name__ == "__main__":
    main()
