"""The order in dt at fixed h of a peer problem's rupture times and slip (the
rigid kind): ``time.dt_safety`` 0.9, 0.45, 0.225, 0.1125 on one mesh, each
station's change between neighbouring steps and the observed order
log2(Δ_k / Δ_{k+1}).  It tells a large error constant from a low order: issue
26's goal asks the change between 0.9 and 0.45 to be under 0.05 µs.

    .venv/bin/python benchmarks/peer/dt_ladder.py --problem rsf_slip_2d --h 0.4e-3 0.2e-3

Runs: runs/dt_ladder/<problem>/h<h>_sf<safety> (1 rank; reused when complete,
as score.py's).  Results: benchmarks/results/dt_ladder.{json,md} (merged by
problem and h).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import score

SAFETY = (0.9, 0.45, 0.225, 0.1125)
RESULT = score.RESULTS / "dt_ladder.json"


def ladder(problem: str, h: float, out: Path, safety=SAFETY) -> dict:
    ref = score.peer_metrics(problem, score.reference(problem))
    xs = sorted(ref["stations"])
    m, dts = {}, {}
    for sf in safety:
        d = out / problem / f"h{h * 1e3:g}_sf{sf:g}"
        dts[sf] = score.run_fricfem(problem, "rigid", h, d, 1, None, extra=["--set", f"time.dt_safety={sf!r}"])["dt_s"]
        m[sf] = score.run_metrics(d, "rigid", xs, ref["end_s"])
    stations = {}
    for x in xs:
        t_r = [m[sf][x]["t_r"] for sf in safety]
        if any(t is None for t in t_r) or t_r[-1] <= score.T_R_MIN:
            continue
        d = [abs(t_r[i] - t_r[i + 1]) for i in range(len(safety) - 1)]
        stations[x] = {"t_r_s": t_r, "dt_r_us": [1e6 * v for v in d],
                       "order": [math.log2(d[i] / d[i + 1]) if d[i + 1] > 0 else None for i in range(len(d) - 1)],
                       "slip_m": [m[sf][x]["slip"] for sf in safety]}
    worst = [max(s["dt_r_us"][i] for s in stations.values()) for i in range(len(safety) - 1)]
    peer = {f"{sf:g}": score.errors(m[sf], ref["stations"])["t_r_us"] for sf in safety}
    return {"problem": problem, "h_m": h, "safety": list(safety), "dt_s": [dts[sf] for sf in safety],
            "worst_dt_r_us": worst, "peer_t_r_us": peer, "stations": stations}


def table(doc: dict) -> str:
    lines = ["# Rupture times against the step at fixed h (rigid kind, 1 rank)", "",
             "`.venv/bin/python benchmarks/peer/dt_ladder.py` (its docstring). Δ_k: the change of a station's "
             "rupture time between neighbouring `time.dt_safety` (0.9 → 0.45 → 0.225 → 0.1125); order: "
             "log2(Δ_k/Δ_{k+1}). Worst over the stations, and each station.", ""]
    for key, r in sorted(doc["runs"].items()):
        lines += [f"## {r['problem']}, h = {r['h_m'] * 1e3:g} mm (dt {', '.join(f'{d * 1e9:.2f}' for d in r['dt_s'])} ns)",
                  "", "worst Δ_k [µs]: " + ", ".join(f"{v:.4f}" for v in r["worst_dt_r_us"])
                  + "; worst |t_r − peer| [µs] at each safety: "
                  + ", ".join(f"{k}: {v:.3f}" for k, v in r["peer_t_r_us"].items()), "",
                  "| x [mm] | t_r [µs] | " + " | ".join(f"Δ_{k} [µs]" for k in range(len(r["safety"]) - 1))
                  + "".join(f" | order {k}→{k + 1}" for k in range(len(r["safety"]) - 2)) + " | slip [µm] at each safety |",
                  "|---|---|" + "---|" * (2 * len(r["safety"]) - 3) + "---|"]
        for x, s in sorted(r["stations"].items(), key=lambda kv: float(kv[0])):
            o = ["—" if v is None else f"{v:.2f}" for v in s["order"]]
            lines.append(f"| {x} | {s['t_r_s'][-1] * 1e6:.3f} | " + " | ".join(f"{v:.4f}" for v in s["dt_r_us"])
                         + "".join(f" | {v}" for v in o) + " | " + ", ".join(f"{v * 1e6:.3f}" for v in s["slip_m"])
                         + " |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="rsf_slip_2d", choices=score.PROBLEMS)
    ap.add_argument("--h", nargs="+", type=float, default=[0.4e-3, 0.2e-3])
    ap.add_argument("--out", default="runs/dt_ladder")
    ap.add_argument("--safety", nargs="+", type=float, default=list(SAFETY),
                    help="the dt_safety ladder, largest first (default: %(default)s)")
    args = ap.parse_args(argv)
    doc = score.load_results(RESULT)
    for h in args.h:
        r = ladder(args.problem, h, Path(args.out), tuple(args.safety))
        doc["runs"][f"{args.problem}/h{h * 1e3:g}"] = r
        print(f"{args.problem} h = {h * 1e3:g} mm: worst Δ_k " + ", ".join(f"{v:.4f}" for v in r["worst_dt_r_us"])
              + " µs", flush=True)
    score.save_results(RESULT, doc, table)
    return doc


if __name__ == "__main__":
    main()
