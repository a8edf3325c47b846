"""dt-convergence at fixed h (issue 26's goal: rupture times within 0.05 µs and
slip within 0.2 % between ``time.dt_safety`` 0.9 and 0.45): each peer problem
with each interface kind at both steps on the same mesh, the worst change over
the peer's stations (rupture times after 1 µs, as score.py scores them; slip at
the peer's end time, over the stations the peer's rupture reaches) and where it
is, and each run's worst errors against the peer's finest run.

    .venv/bin/python benchmarks/peer/dt_convergence.py                       # all problems, both kinds, h = 0.2, 0.1 mm
    .venv/bin/python benchmarks/peer/dt_convergence.py --problems rsf_slip_2d --kinds rigid --h 0.2e-3
    .venv/bin/python benchmarks/peer/dt_convergence.py --h 0.2e-3 --pythonpath OTHER_TREE --tag before

Runs go to ``runs/dt_convergence/<tag>/<problem>/[<kind>_]h<h>_sf<dt_safety>``
(rigid runs without the kind prefix; reused when complete, as score.py's).  The
results are merged into ``benchmarks/results/peer_dt_convergence.json`` (key
``<tag>/<problem>/<kind>/h<h mm>``), which report.py shows in peer_score.md."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import score

RESULT = score.RESULTS / "peer_dt_convergence.json"


def compare(problem: str, kind: str, h: float, safety, ranks: int, tag: str, pythonpath, out: str) -> dict:
    """Both steps of one (problem, kind, h): the changes between them and each against the peer."""
    ref = score.peer_metrics(problem, score.reference(problem))
    xs = sorted(ref["stations"])
    m, rec = {}, {}
    for sf in safety:
        d = Path(out) / tag / problem / (f"h{h * 1e3:g}_sf{sf:g}" if kind == "rigid" else f"{kind}_h{h * 1e3:g}_sf{sf:g}")
        rec[sf] = score.run_fricfem(problem, kind, h, d, ranks, pythonpath,
                                    extra=["--set", f"time.dt_safety={sf!r}"])
        m[sf] = score.run_metrics(d, kind, xs, ref["end_s"])
    a, b = (m[sf] for sf in safety)
    d_tr = {x: abs(a[x]["t_r"] - b[x]["t_r"]) for x in xs
            if a[x]["t_r"] is not None and b[x]["t_r"] is not None and b[x]["t_r"] > score.T_R_MIN}
    d_slip = {x: abs(a[x]["slip"] / b[x]["slip"] - 1.0) for x in xs if ref["stations"][x]["v_peak"] > score.THRESHOLD}
    x_tr, x_slip = max(d_tr, key=d_tr.get), max(d_slip, key=d_slip.get)
    peer = {sf: score.errors(m[sf], ref["stations"]) for sf in safety}
    return {"problem": problem, "kind": kind, "h_m": h, "ranks": ranks, "safety": list(safety),
            "dt_s": [rec[sf]["dt_s"] for sf in safety], "cpu_s": [rec[sf]["cpu_s"] for sf in safety],
            "dt_r_us": 1e6 * d_tr[x_tr], "dt_r_x_mm": x_tr, "dslip_pct": 100 * d_slip[x_slip], "dslip_x_mm": x_slip,
            "peer": {f"{sf:g}": {k: peer[sf][k] for k in ("t_r_us", "t_r_pct", "slip_pct")} for sf in safety}}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="+", default=list(score.PROBLEMS), choices=score.PROBLEMS)
    ap.add_argument("--kinds", nargs="+", default=["rigid", "elastic"], choices=["rigid", "elastic"])
    ap.add_argument("--h", nargs="+", type=float, default=[0.2e-3, 0.1e-3])
    ap.add_argument("--safety", nargs=2, type=float, default=[0.9, 0.45])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--tag", default="tree")
    ap.add_argument("--note", help="what this fricfem is (default: as in this tree, on N ranks)")
    ap.add_argument("--pythonpath")
    ap.add_argument("--out", default="runs/dt_convergence")
    ap.add_argument("--result", default=str(RESULT), help="JSON the results are merged into")
    args = ap.parse_args(argv)
    out = {}
    for problem in args.problems:
        for kind in args.kinds:
            for h in args.h:
                r = compare(problem, kind, h, args.safety, args.ranks, args.tag, args.pythonpath, args.out)
                out[f"{args.tag}/{problem}/{kind}/h{h * 1e3:g}"] = r
                p = r["peer"]
                print(f"{args.tag} {problem} {kind} h = {h * 1e3:g} mm: dt_safety {args.safety[0]:g} vs "
                      f"{args.safety[1]:g}: worst |Δt_r| {r['dt_r_us']:.3f} µs (x = {r['dt_r_x_mm']} mm), worst slip "
                      f"change {r['dslip_pct']:.2f} % (x = {r['dslip_x_mm']} mm); against the peer: "
                      + ", ".join(f"{sf}: t_r {v['t_r_us']:.3f} µs ({v['t_r_pct']:.2f} %), slip {v['slip_pct']:.2f} %"
                                  for sf, v in p.items()), flush=True)
                path = Path(args.result)
                doc = json.loads(path.read_text()) if path.exists() else {"runs": {}, "notes": {}}
                doc["runs"].update(out)
                doc["notes"][args.tag] = args.note or (f"fricfem as in this tree, on {args.ranks} rank"
                                                       + ("s" if args.ranks > 1 else ""))
                doc["date"] = time.strftime("%Y-%m-%d %H:%M")
                path.write_text(json.dumps(doc, indent=1, default=float))
    return out


if __name__ == "__main__":
    main()
