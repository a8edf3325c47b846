"""The peer's own sensitivity to its time step: SEM2DPACK (built from its
public source, outside this tree) on a committed Par file at its Courant
number and at half of it, and the largest change of a station's rupture time
and final slip between the two: the same measure as the 'dt change' of
fricfem's runs (sem_ladder.py, dt_ladder.py), so the two codes' explicit
second-order steps can be compared on one problem.

    SEM2DSOLVE=/path/to/sem2dsolve .venv/bin/python benchmarks/peer/peer_dt.py \\
        --problem rsf_slip_2d --label h0.25mm h0.1mm

Runs: /var/tmp/fricfem-peer-dt/<problem>/<label>_c<Courant> (outside the tree).
Results: benchmarks/results/peer_dt.{json,md} (merged by problem and label).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import score
from make_par import GEOMETRY
from make_tables import parse_info, rupture_time
from read_sem2dpack import read_fault

HERE = Path(__file__).resolve().parent
RESULT = HERE.parents[1] / "benchmarks" / "results" / "peer_dt.json"
T_R_MIN = 1e-6  # s: the nucleation patch's stations are not scored (score.py)


def need_peer() -> None:
    """Stop with the one thing to do when the peer's executable is not named."""
    if "SEM2DSOLVE" not in os.environ:
        raise SystemExit("set SEM2DSOLVE to the sem2dsolve executable (benchmarks/peer/README.md)")


def run(problem: str, label: str, courant: float, base: Path) -> Path:
    par = (HERE / problem / f"Par_{label}.inp").read_text()
    par, n = re.subn(r"Courant=[\d.d+-]+", f"Courant={courant!r}d0", par)
    if n != 1:
        raise SystemExit(f"{problem} {label}: no single Courant= in the Par file")
    d = base / problem / f"{label}_c{courant:g}"
    if not (d / "time.txt").exists():
        d.mkdir(parents=True, exist_ok=True)
        tmp = d / "Par_dt.inp"
        tmp.write_text(par)
        subprocess.run(["bash", str(HERE / "run_peer.sh"), str(tmp), str(d)], check=True,
                       stdout=subprocess.DEVNULL)
    return d


def stations(problem: str, d: Path) -> dict:
    """Rupture time (the slip rate re-centred on whole steps, as make_tables.py)
    and final slip at each station."""
    f = read_fault(str(d / "Flt05_sem2d"))
    v = f["Slip_Rate"].copy()
    v[1:] = 0.5 * (f["Slip_Rate"][1:] + f["Slip_Rate"][:-1])
    out = {}
    for x_mm in GEOMETRY[problem][1]:
        k = int(np.argmin(np.abs(f["x"] - x_mm * 1e-3)))
        out[x_mm] = {"t_r": rupture_time(f["t"], v[:, k]), "slip": float(f["Slip"][-1, k])}
    return out


def compare(problem: str, label: str, base: Path, courant: float) -> dict:
    a_dir, b_dir = run(problem, label, courant, base), run(problem, label, courant / 2, base)
    a, b = stations(problem, a_dir), stations(problem, b_dir)
    dt_r = {x: abs(a[x]["t_r"] - b[x]["t_r"]) * 1e6 for x in a
            if a[x]["t_r"] is not None and b[x]["t_r"] is not None and b[x]["t_r"] > T_R_MIN}
    dslip = {x: 100 * abs(a[x]["slip"] - b[x]["slip"]) / abs(b[x]["slip"]) for x in a if b[x]["slip"] > 0}
    worst_t = max(dt_r, key=dt_r.get)
    worst_s = max(dslip, key=dslip.get)
    return {"problem": problem, "label": label, "courant": [courant, courant / 2],
            "dt_s": [parse_info(str(a_dir))["dt_s"], parse_info(str(b_dir))["dt_s"]],
            "cpu_s": [parse_info(str(a_dir))["cpu_s"], parse_info(str(b_dir))["cpu_s"]],
            "dt_r_us": dt_r[worst_t], "dt_r_x_mm": worst_t, "dslip_pct": dslip[worst_s], "dslip_x_mm": worst_s,
            "dt_r_us_by_station": dt_r}


def table(doc: dict) -> str:
    lines = ["# The peer's own change with its time step", "",
             "`benchmarks/peer/peer_dt.py` (its docstring): SEM2DPACK at its Courant number and at half of it; "
             "the largest change of a station's rupture time and final slip between the two (stations with "
             "t_r > 1 µs). Compare fricfem's 'dt change' between dt_safety 0.9 and 0.45 "
             "(`sem_ladder.md`, `dt_ladder.md`).", "",
             "| problem | run | Courant | dt [ns] | CPU [s] | worst Δt_r [µs] (station) | worst Δslip [%] (station) |",
             "|---|---|---|---|---|---|---|"]
    for r in sorted(doc["runs"].values(), key=lambda r: (r["problem"], r["label"])):
        lines.append(f"| {r['problem']} | {r['label']} | {r['courant'][0]:g} → {r['courant'][1]:g} | "
                     f"{r['dt_s'][0] * 1e9:.2f} → {r['dt_s'][1] * 1e9:.2f} | {r['cpu_s'][0]:.1f}, {r['cpu_s'][1]:.1f} | "
                     f"{r['dt_r_us']:.3f} ({r['dt_r_x_mm']} mm) | {r['dslip_pct']:.2f} ({r['dslip_x_mm']} mm) |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="rsf_slip_2d", choices=sorted(GEOMETRY))
    ap.add_argument("--label", nargs="+", default=["h0.25mm"])
    ap.add_argument("--courant", type=float, default=0.5, help="the Par files' Courant number")
    ap.add_argument("--base", default="/var/tmp/fricfem-peer-dt")
    args = ap.parse_args(argv)
    need_peer()
    doc = score.load_results(RESULT)
    for label in args.label:
        r = compare(args.problem, label, Path(args.base), args.courant)
        doc["runs"][f"{args.problem}/{label}"] = r
        print(f"{args.problem} {label}: worst change {r['dt_r_us']:.3f} us at {r['dt_r_x_mm']} mm, "
              f"slip {r['dslip_pct']:.2f} % at {r['dslip_x_mm']} mm", flush=True)
        score.save_results(RESULT, doc, table)
    return doc


if __name__ == "__main__":
    main()
