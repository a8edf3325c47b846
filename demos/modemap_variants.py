# # The mode map (the paper's Fig. 19) and its two interface-stiffness variants, for REPRODUCTION.md §5
#
# Runs (or resumes) `fricfem sweep case1 --grid default --variants` into
# `--work` and condenses its three `modemap.json` into
# `docs/reproduction/modemap_push_v1.json`: per map the stiffnesses, the mode
# counts, the label table, the crack/pulse boundary, the points the watchdog
# stopped (with its message) and the points whose slip rate spiked above c_l
# (reported in summary.json, not stopped: docs/model.md, "The watchdog"), and
# the single-rank run times added up.  With `--compare OLD.json` (an earlier
# version of that file) it lists every point whose label changed.  The
# figures are copied next to it.  `--collect` condenses a finished sweep in
# `--work` without running anything.
#
# Run: `mpirun -n 2 .venv/bin/python demos/modemap_variants.py`
# (`--compare` defaults to the committed file as it was before the run).

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from mpi4py import MPI

from fricfem.sweep import DEFAULT_SIGMA0_MPA, DEFAULT_V_IMP, sweep

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "reproduction"
FIGURES = {"main": "modemap_push_v1.png", "stiff_x10": "modemap_push_v1_stiff_x10.png",
           "stiff_div10": "modemap_push_v1_stiff_div10.png"}
COMMAND = "mpirun -n 2 .venv/bin/python demos/modemap_variants.py"


def condense(doc: dict, name: str) -> dict:
    """One map of the committed summary from the sweep's ``modemap.json``."""
    pts = doc["points"]
    labels = doc["labels"]["values"]
    counts = {k: sum(row.count(k) for row in labels) for k in ("none", "crack-like", "pulse", "pulse-train",
                                                              "mixed", "diverged")}
    spikes = {}
    for p in pts:
        s = json.loads((Path(doc["dir"]) / p["dir"] / "summary.json").read_text()).get("slip_rate_spike") or {}
        if s.get("above_threshold"):
            spikes[p["key"]] = {"peak_m_s": s["peak_m_s"], "x1_mm": s["x1_m"] * 1e3, "time_us": s["time_s"] * 1e6,
                                "label": p["label"]}
    return {"Cn_MPa_per_um": doc["Cn_Pa_m"] / 1e12, "Cs_MPa_per_um": doc["Cs_Pa_m"] / 1e12, "counts": counts,
            "scenes": len(pts), "point_wall_s_sum": round(sum(p["wall_s"] or 0.0 for p in pts), 1),
            "labels": doc["labels"], "boundary": doc["boundary"]["lines"],
            "diverged": {p["key"]: p["reason"] for p in pts if p["label"] == "diverged"},
            "spikes_above_c_l": spikes, "figure": f"docs/reproduction/{FIGURES[name]}"}


def changes(old: dict, new: dict) -> dict:
    """Per map: the points whose label differs between ``old`` and ``new`` (same grid)."""
    out = {}
    s, v = new["grid"]["sigma0_MPa"], new["grid"]["v_imp_m_s"]
    for name, m in new["maps"].items():
        before = old["maps"][name]["labels"]["values"]
        after = m["labels"]["values"]
        out[name] = [{"sigma0_MPa": s[i], "v_imp_m_s": v[j], "before": before[i][j], "after": after[i][j]}
                     for i in range(len(s)) for j in range(len(v)) if before[i][j] != after[i][j]]
    return out


def main(argv=None, comm=MPI.COMM_WORLD) -> None:
    ap = argparse.ArgumentParser(description="the mode map and its stiffness variants for REPRODUCTION.md §5")
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "modemap")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--compare", type=Path, default=OUT / "modemap_push_v1.json")
    ap.add_argument("--collect", action="store_true", help="condense the finished sweep in --work, run nothing")
    a = ap.parse_args(argv)
    old = json.loads(a.compare.read_text()) if comm.rank == 0 and a.compare.is_file() else None
    names = {"": "main", "stiff_x10": "stiff_x10", "stiff_div10": "stiff_div10"}
    if a.collect:
        maps = {k: json.loads((a.work / k / "modemap.json").read_text()) for k in names} if comm.rank == 0 else {}
        ranks, wall = (maps[""]["ranks"], maps[""]["sweep_wall_s"]) if maps else (0, 0.0)
    else:
        res = sweep("case1", DEFAULT_SIGMA0_MPA, DEFAULT_V_IMP, a.work, variants=True, comm=comm)
        maps, ranks, wall = (res["maps"], comm.size, res["wall_s"]) if comm.rank == 0 else ({}, 0, 0.0)
    if comm.rank != 0:
        return
    doc = {"command": COMMAND, "grid": {"sigma0_MPa": list(DEFAULT_SIGMA0_MPA), "v_imp_m_s": list(DEFAULT_V_IMP)},
           "ranks": ranks, "maps": {names[k]: condense(m, names[k]) for k, m in maps.items()},
           "sweep_wall_s": round(wall, 1),
           "wall_note": "sweep_wall_s: the whole sweep (3 × 64 scenes, dealt to the ranks, each scene run serially "
                        "on one rank); point_wall_s_sum: the run times of one map's 64 scenes added up (one rank "
                        "each)"}
    if old is not None:
        doc["changed_labels"] = {"against": old.get("command"), "maps": changes(old, doc)}
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "modemap_push_v1.json").write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    for k, name in names.items():
        shutil.copy(a.work / k / "modemap.png" if k else a.work / "modemap.png", a.out / FIGURES[name])
    shutil.copy(a.work / "modemap_variants.png", a.out / "modemap_push_v1_variants.png")
    for name, m in doc["maps"].items():
        print(f"{name}: {m['counts']}; spikes above c_l: {len(m['spikes_above_c_l'])}")
        for c in (doc.get("changed_labels") or {}).get("maps", {}).get(name, []):
            print(f"  Σ0 {c['sigma0_MPa']:g} MPa, V_imp {c['v_imp_m_s']:g} m/s: {c['before']} → {c['after']}")


if __name__ == "__main__":
    main()
