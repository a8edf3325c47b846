# # Results on 1, 2, 3 and 4 ranks
#
# Runs a crack-like scene (Case I at 10 m/s), a train of pulses (Case III) and
# the slip-weakening rupture problem (to 12 µs) with ``mpirun -n k`` for
# k = 1…4 (oversubscribed on this 2-core machine) and compares every interface
# quantity and station history bit for bit against the 1-rank run.  fricfem
# sums K, the lumped mass, each row of K·u and each interface node's forces in
# the grid's order (fricfem.model.numbering), so they agree to the bit.
#
# Run: ``.venv/bin/python benchmarks/rank_reproducibility.py`` (plain python:
# it starts mpirun itself); writes results/rank_reproducibility.md and .json.

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCENES = {"case1_v10": ("case1", ["loading.v_imp=10"]), "case3": ("case3", []),
          "rupture_sw_12us": ("rupture_sw", ["time.end=12e-6"])}


def run(scene, sets, ranks: int, out: Path) -> float:
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMP_NUM_THREADS": "1"}
    cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", str(ROOT / ".venv/bin/fricfem"), "run", scene,
           "--out", str(out), "--overwrite", "--quiet", "--set", "output.fields=[]"]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, capture_output=True)
    return time.perf_counter() - t0


def differences(a, b) -> dict:
    """Per quantity: max |a − b| relative to max |a| (0 means the same bits)."""
    out = {}
    for name in a.names:
        x, y = a.quantity(name), b.quantity(name)
        out[name] = 0.0 if np.array_equal(x, y) else float(np.abs(x - y).max() / max(np.abs(x).max(), 1e-300))
    for st, d in a.stations.items():
        for q, v in d.items():
            x, y = np.asarray(v, dtype=float), np.asarray(b.stations[st][q], dtype=float)
            out[f"stations/{st}/{q}"] = 0.0 if np.array_equal(x, y) else float(np.nanmax(np.abs(x - y)))
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--ranks", default="1,2,3,4")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from fricfem import open_run

    ranks = [int(k) for k in args.ranks.split(",")]
    work = Path(tempfile.mkdtemp(prefix="fricfem-ranks-"))
    doc = {"ranks": ranks, "scenes": {}}
    for key, (scene, sets) in SCENES.items():
        walls = {k: run(scene, sets, k, work / key / f"n{k}") for k in ranks}
        ref = open_run(work / key / f"n{ranks[0]}")
        rows = {}
        for k in ranks[1:]:
            d = differences(ref, open_run(work / key / f"n{k}"))
            rows[k] = {"identical": all(v == 0.0 for v in d.values()), "largest": max(d.values()),
                       "quantities": len(d)}
        doc["scenes"][key] = {"wall_s": walls, "peak_slip_rate": float(ref.quantity("slip_rate").max()),
                              "against_1_rank": rows, "mode": (ref.summary.get("mode") or {}).get("label")}
        print(key, {k: r["identical"] for k, r in rows.items()}, flush=True)
    lines = ["# Results on 1 to 4 ranks", "", "`.venv/bin/python benchmarks/rank_reproducibility.py`", "",
             "| scene | mode | peak slip rate [m/s] | " + " | ".join(f"{k} ranks" for k in ranks[1:]) + " |",
             "|---|---|---|" + "---|" * (len(ranks) - 1)]
    for key, r in doc["scenes"].items():
        cells = ["bit-identical" if r["against_1_rank"][k]["identical"]
                 else f"differs (max {r['against_1_rank'][k]['largest']:.1e})" for k in ranks[1:]]
        lines.append(f"| {key} | {r['mode']} | {r['peak_slip_rate']:.3g} | " + " | ".join(cells) + " |")
    lines += ["", "Every interface quantity (slip rate, tractions, jumps, slip, state) at every stored row and "
              "every station history compared against the 1-rank run."]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "rank_reproducibility.json").write_text(json.dumps(doc, indent=1) + "\n")
    (args.out / "rank_reproducibility.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return doc


if __name__ == "__main__":
    main()
