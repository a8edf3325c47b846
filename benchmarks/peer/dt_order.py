"""Both codes on one mesh with a ladder of time steps: SEM2DPACK (built from its
public source, outside this tree) at Courant numbers 0.5, 0.25, 0.125, 0.0625
and fricfem at ``time.dt_safety`` 0.9, 0.45, 0.225, 0.1125, both on 1 mm
elements of degree 4 over the peer's whole box (fricfem's mesh uniform:
``mesh.max_size`` = the element size), the rigid kind.

Per station it gives each run's rupture time and final slip, the change
between neighbouring steps and the observed order log2 of successive changes,
and each code's limit dt -> 0 by Richardson extrapolation with that order.
Two codes that solve the same semi-discrete problem (the same elements, mass,
fault nodes and weights, initial tractions and friction at the nodes) must
agree in that limit however differently they step in time: the gap between
the two limits is what remains of a difference in the problem.

    SEM2DSOLVE=/path/to/sem2dsolve .venv/bin/python benchmarks/peer/dt_order.py \\
        --problem rsf_aging_2d rsf_slip_2d tpv205_2d

Runs: /var/tmp/fricfem-dt-order/<problem>/{h0.25mm_c<C>, fricfem_sf<s>} (outside the tree).
Results: benchmarks/results/dt_order.{json,md} (merged by problem).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import peer_dt
import score
import sem_ladder
from make_par import GEOMETRY
from make_tables import parse_info

HERE = Path(__file__).resolve().parent
RESULT = score.RESULTS / "dt_order.json"
LABEL = "h0.25mm"  # the peer's 1 mm elements of degree 4 (make_par.py --elem 1e-3)
H = 1e-3  # m, the element size
COURANT = (0.5, 0.25, 0.125, 0.0625)
SAFETY = (0.9, 0.45, 0.225, 0.1125)


def run_fricfem(problem: str, safety: float, base: Path) -> tuple:
    """fricfem's run at ``safety`` on the peer's layout (sem_ladder.layout: degree 4, the whole box): (dir, record)."""
    d = base / problem / f"fricfem_sf{safety:g}"
    return d, score.run_fricfem(problem, "rigid", H, d, 1, None, extra=sem_ladder.layout(4, H, True, safety))


def ladder_stats(times: list) -> dict:
    """Changes between neighbouring steps, the observed order of the last two, and the
    Richardson limit with it (None where a time is missing or the changes vanish)."""
    if any(t is None for t in times):
        return {"changes_us": None, "order": None, "limit_s": None}
    d = [1e6 * (b - a) for a, b in zip(times, times[1:])]
    order = None
    if abs(d[-1]) > 0 and abs(d[-2]) > 0 and d[-1] * d[-2] > 0:
        order = math.log2(d[-2] / d[-1])
    limit = times[-1] + (1e-6 * d[-1] / (2 ** order - 1) if order and order > 0.3 else 0.0)
    return {"changes_us": d, "order": order, "limit_s": limit}


def problem_result(problem: str, base: Path) -> dict:
    ref = score.peer_metrics(problem, score.reference(problem))
    xs = sorted(ref["stations"])
    peer_runs = [peer_dt.run(problem, LABEL, c, base) for c in COURANT]
    peer = [peer_dt.stations(problem, d) for d in peer_runs]
    fric = []
    recs = []
    for sf in SAFETY:
        d, rec = run_fricfem(problem, sf, base)
        recs.append(rec)
        fric.append(score.run_metrics(d, "rigid", xs, ref["end_s"]))
    rows = []
    for x in xs:
        if ref["stations"][x]["t_r"] is None or ref["stations"][x]["t_r"] <= score.T_R_MIN:
            continue
        p = ladder_stats([s[x]["t_r"] for s in peer])
        f = ladder_stats([m[x]["t_r"] for m in fric])
        gap = None if p["limit_s"] is None or f["limit_s"] is None else 1e6 * (f["limit_s"] - p["limit_s"])
        rows.append({"x_mm": x, "t_r_ref_s": ref["stations"][x]["t_r"],
                     "peer_t_r_s": [s[x]["t_r"] for s in peer], "fricfem_t_r_s": [m[x]["t_r"] for m in fric],
                     "peer_slip_m": [s[x]["slip"] for s in peer], "fricfem_slip_m": [m[x]["slip"] for m in fric],
                     "peer": p, "fricfem": f, "limit_gap_us": gap})
    return {"problem": problem, "label": LABEL, "h_m": H, "courant": list(COURANT), "dt_safety": list(SAFETY),
            "peer_dt_s": [parse_info(str(d))["dt_s"] for d in peer_runs],
            "peer_cpu_s": [parse_info(str(d))["cpu_s"] for d in peer_runs],
            "fricfem_dt_s": [r["dt_s"] for r in recs], "fricfem_cpu_s": [r["cpu_s"] for r in recs],
            "stations": rows}


def _f(v, fmt="{:+.3f}"):
    return "–" if v is None else fmt.format(v)


def table(doc: dict) -> str:
    lines = ["# Both codes on one mesh, a ladder of time steps", "",
             "`benchmarks/peer/dt_order.py` (its docstring): 1 mm elements of degree 4, the rigid kind; the peer at "
             "Courant 0.5 / 0.25 / 0.125 / 0.0625, fricfem at dt_safety 0.9 / 0.45 / 0.225 / 0.1125. Rupture times "
             "against the peer's finest run (the reference of peer_score.md) [µs]; the order is log2 of the last "
             "two changes; the limit is the Richardson extrapolation with it; the gap is fricfem's limit minus "
             "the peer's.", ""]
    for r in sorted(doc["runs"].values(), key=lambda r: r["problem"]):
        lines += [f"## {r['problem']}", "",
                  f"dt [ns]: peer {' / '.join(f'{d * 1e9:.2f}' for d in r['peer_dt_s'])}; "
                  f"fricfem {' / '.join(f'{d * 1e9:.2f}' for d in r['fricfem_dt_s'])}. "
                  f"CPU [s]: peer {' / '.join(f'{c:.1f}' for c in r['peer_cpu_s'])}; "
                  f"fricfem {' / '.join(f'{c:.1f}' for c in r['fricfem_cpu_s'])}.", "",
                  "| x [mm] | peer t_r − ref, 4 steps | peer order | peer limit − ref | fricfem t_r − ref, 4 steps "
                  "| fricfem order | fricfem limit − ref | gap of the limits |",
                  "|---|---|---|---|---|---|---|---|"]
        for s in r["stations"]:
            ref = s["t_r_ref_s"]
            rel = lambda ts: " / ".join(_f(None if t is None else 1e6 * (t - ref)) for t in ts)  # noqa: E731
            lim = lambda d: _f(None if d["limit_s"] is None else 1e6 * (d["limit_s"] - ref))  # noqa: E731
            lines.append(f"| {s['x_mm']} | {rel(s['peer_t_r_s'])} | {_f(s['peer']['order'], '{:.2f}')} | "
                         f"{lim(s['peer'])} | {rel(s['fricfem_t_r_s'])} | {_f(s['fricfem']['order'], '{:.2f}')} | "
                         f"{lim(s['fricfem'])} | {_f(s['limit_gap_us'])} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", nargs="+", default=["rsf_aging_2d"], choices=sorted(GEOMETRY))
    ap.add_argument("--base", default="/var/tmp/fricfem-dt-order")
    args = ap.parse_args(argv)
    peer_dt.need_peer()
    doc = score.load_results(RESULT)
    for problem in args.problem:
        doc["runs"][problem] = problem_result(problem, Path(args.base))
        worst = max((s for s in doc["runs"][problem]["stations"] if s["limit_gap_us"] is not None),
                    key=lambda s: abs(s["limit_gap_us"]), default=None)
        gap = "–" if worst is None else f"{worst['limit_gap_us']:+.3f} us at {worst['x_mm']} mm"
        print(f"{problem}: largest gap of the dt -> 0 limits {gap}", flush=True)
        score.save_results(RESULT, doc, table)
    return doc


if __name__ == "__main__":
    main()
