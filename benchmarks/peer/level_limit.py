"""A level of the peer in its own dt -> 0 limit: SEM2DPACK (built from its public
source, outside this tree) on one of its committed meshes at Courant 0.5 and
0.25, extrapolated to dt -> 0 at first order (its rate-and-state fault's
observed order, dt_order.md), and its reference (p8_h0.0625mm) likewise
(ref_dt.extrapolated: its committed run and peer_dt.py's run at C/2); with
``--fricfem``, fricfem on the same mesh (elements of the label's size and
degree over the whole box, sem_ladder.layout, at dt_safety 0.45).

Per station, rupture times against the reference as it is [µs]: the peer's
level as scored (Courant 0.5), its limit, the reference's limit and fricfem's
run; then each one's worst error [% of t_r] against the reference and against
the reference's limit.  It says whether a level's score is the accuracy of its
mesh or its step error cancelling another error (docs/elements.md).

    SEM2DSOLVE=/path/to/sem2dsolve .venv/bin/python benchmarks/peer/level_limit.py \\
        --problem rsf_aging_2d --label h0.1mm --fricfem

Runs: the peer's in --base (peer_dt.py's: <problem>/<label>_c<Courant>), fricfem's
in runs/sem/ (sem_ladder.rundir).  Results: benchmarks/results/level_limit.{json,md}.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import peer_dt
import score
import sem_ladder
from make_par import GEOMETRY
from ref_dt import extrapolated, first_order_limit

RESULT = score.RESULTS / "level_limit.json"
COURANT = 0.5
SAFETY = 0.45
#: each peer label's element size [m] and degree (make_par.py: h is the mean node spacing)
ELEMENT = {"h0.25mm": (1e-3, 4), "h0.1mm": (0.4e-3, 4), "h0.05mm": (0.2e-3, 4), "p8_h0.125mm": (1e-3, 8)}


def level(problem: str, label: str, base: Path, fricfem: bool) -> dict:
    ref, _, ref_limit = extrapolated(problem, base)  # the reference as scored, at C/2, and its dt -> 0 limit
    peer = [peer_dt.stations(problem, peer_dt.run(problem, label, c, base)) for c in (COURANT, COURANT / 2)]
    fric = rec = None
    if fricfem:
        h, p = ELEMENT[label]
        d = sem_ladder.rundir(score.ROOT / "runs" / "sem", problem, p, h, True, SAFETY)
        rec = score.run_fricfem(problem, "rigid", h, d, 1, None, extra=sem_ladder.layout(p, h, True, SAFETY))
        fric = score.run_metrics(d, "rigid", sorted(ref), score.peer_metrics(problem, score.REFERENCE)["end_s"])
    rows = []
    for x, r in sorted(ref.items()):
        t = r["t_r"]
        if t is None or t <= score.T_R_MIN or peer[0][x]["t_r"] is None or peer[1][x]["t_r"] is None:
            continue
        row = {"x_mm": x, "t_r_ref_s": t, "peer_s": peer[0][x]["t_r"],
               "peer_limit_s": first_order_limit(peer[0][x]["t_r"], peer[1][x]["t_r"]),
               "ref_limit_s": ref_limit[x]["t_r"]}
        if fric is not None and fric[x]["t_r"] is not None:
            row["fricfem_s"] = fric[x]["t_r"]
        rows.append(row)
    worst = {}
    for key in ("peer_s", "peer_limit_s", "fricfem_s"):
        if all(key in r for r in rows):
            worst[key] = {"ref_pct": 100 * max(abs(r[key] - r["t_r_ref_s"]) / r["t_r_ref_s"] for r in rows),
                          "ref_limit_pct": 100 * max(abs(r[key] - r["ref_limit_s"]) / r["t_r_ref_s"] for r in rows)}
    return {"problem": problem, "label": label, "courant": [COURANT, COURANT / 2],
            "fricfem": None if rec is None else {"degree": ELEMENT[label][1], "h_m": ELEMENT[label][0],
                                                 "dt_safety": SAFETY,
                                                 "cpu_s": rec["cpu_s"], "dt_s": rec["dt_s"]},
            "stations": rows, "worst": worst}


def table(doc: dict) -> str:
    lines = ["# The peer's levels in their own dt → 0 limit", "",
             "`benchmarks/peer/level_limit.py` (its docstring). Rupture times minus the reference's "
             "(`p8_h0.0625mm` at Courant 0.5, as peer_score.md) [µs]; limits: first-order extrapolation from "
             "Courant 0.5 and 0.25.", ""]
    for r in sorted(doc["runs"].values(), key=lambda r: (r["problem"], r["label"])):
        f = r["fricfem"]
        lines += [f"## {r['problem']} {r['label']}", "",
                  (f"fricfem: degree {f['degree']}, " + f"{f['h_m'] * 1e3:g} mm elements over the whole box, dt_safety "
                   f"{f['dt_safety']:g}, {f['cpu_s']:.1f} CPU s." if f else "fricfem: not run on this mesh."), "",
                  "| x [mm] | peer, Courant 0.5 | peer, dt → 0 | reference, dt → 0 | fricfem |",
                  "|---|---|---|---|---|"]
        for s in r["stations"]:
            ref = s["t_r_ref_s"]
            cell = (lambda k: f"{1e6 * (s[k] - ref):+.3f}" if k in s else "—")  # noqa: E731
            lines.append(f"| {s['x_mm']} | {cell('peer_s')} | {cell('peer_limit_s')} | {cell('ref_limit_s')} | "
                         f"{cell('fricfem_s')} |")
        lines += ["", "| worst Δt_r [% of t_r] | against the reference | against the reference's dt → 0 limit |",
                  "|---|---|---|"]
        names = {"peer_s": "peer, Courant 0.5", "peer_limit_s": "peer, dt → 0", "fricfem_s": "fricfem"}
        for k, w in r["worst"].items():
            lines.append(f"| {names[k]} | {w['ref_pct']:.2f} | {w['ref_limit_pct']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="rsf_aging_2d", choices=sorted(GEOMETRY))
    ap.add_argument("--label", nargs="+", default=["h0.1mm"], choices=sorted(ELEMENT))
    ap.add_argument("--fricfem", action="store_true", help="fricfem on the same mesh too (its degree, whole box)")
    ap.add_argument("--base", default="/var/tmp/fricfem-peer-dt")
    args = ap.parse_args(argv)
    peer_dt.need_peer()
    doc = score.load_results(RESULT)
    for label in args.label:
        r = level(args.problem, label, Path(args.base), args.fricfem)
        doc["runs"][f"{args.problem}/{label}"] = r
        print(f"{args.problem} {label}: " + ", ".join(f"{k} {w['ref_pct']:.2f} % / {w['ref_limit_pct']:.2f} %"
                                                      for k, w in r["worst"].items()), flush=True)
        score.save_results(RESULT, doc, table)
    return doc


if __name__ == "__main__":
    main()
