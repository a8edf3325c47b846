"""How much of the score is the reference's own time step: the peer's finest run
(`p8_h0.0625mm`, Courant 0.5) again at Courant 0.25 (peer_dt.py makes it), and
the reference extrapolated to dt -> 0 with the first order its rate-and-state
fault shows (dt_order.md): t_0 = 2 t(C/2) - t(C), the same for the final slip.
Every peer run and every fricfem run of peer_score.json is scored against both.

    .venv/bin/python benchmarks/peer/ref_dt.py --problem rsf_aging_2d rsf_slip_2d \\
        [--base /var/tmp/fricfem-peer-dt5]

Results: benchmarks/results/ref_dt.{json,md} (merged by problem).  The official
scores stay those against the peer's finest run as it is (peer_score.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import peer_dt
import score

RESULT = score.RESULTS / "ref_dt.json"
#: the fricfem series scored here (peer_score.json tags), the triangles and the spectral elements
TAGS = ("serial", "p4-serial", "p6-serial", "p4-dt0.45-serial")


def first_order_limit(at_c: float, at_half: float) -> float:
    """t_0 = 2 t(C/2) − t(C): a first-order quantity extrapolated to dt -> 0 from the step and its half."""
    return 2.0 * at_half - at_c


def extrapolated(problem: str, base: Path) -> tuple:
    """(the reference's stations, the C/2 run's, the dt -> 0 extrapolation's), {x_mm: {t_r, slip, v_peak}}."""
    ref = score.peer_metrics(problem, score.REFERENCE)["stations"]
    half = peer_dt.stations(problem, base / problem / f"{score.REFERENCE}_c0.25")
    ex = {}
    for x, r in ref.items():
        h = half[x]
        t = None if r["t_r"] is None or h["t_r"] is None else first_order_limit(r["t_r"], h["t_r"])
        ex[x] = {"t_r": t, "slip": first_order_limit(r["slip"], h["slip"]), "v_peak": r["v_peak"]}
    return ref, half, ex


def problem_result(problem: str, base: Path, doc: dict) -> dict:
    ref, half, ex = extrapolated(problem, base)
    change = {x: 1e6 * (half[x]["t_r"] - ref[x]["t_r"]) for x in ref
              if ref[x]["t_r"] is not None and half[x]["t_r"] is not None and ref[x]["t_r"] > score.T_R_MIN}
    rows = []
    for label, p in score.peer_runs(problem).items():
        rows.append({"who": f"SEM2DPACK {label}", "cpu_s": p["cpu_s"],
                     "as_is": score.errors(p["stations"], ref), "dt0": score.errors(p["stations"], ex)})
    prob = doc["problems"].get(problem, {})
    for tag in TAGS:
        for key, run in prob.get("fricfem", {}).get(tag, {}).get("runs", {}).items():
            if run.get("kind") != "rigid":
                continue
            m = score.stored_metrics(run)
            rows.append({"who": f"fricfem [{tag}] {key}", "cpu_s": run["cpu_s"],
                         "as_is": score.errors(m, ref), "dt0": score.errors(m, ex)})
    for r in rows:
        for k in ("as_is", "dt0"):
            r[k] = {m: r[k][m] for m in ("t_r_us", "t_r_pct", "slip_pct")}
    return {"problem": problem, "reference_change_us": change, "rows": rows}


def table(out: dict) -> str:
    lines = ["# The reference's own time step", "",
             "`benchmarks/peer/ref_dt.py` (its docstring): the peer's finest run at half its Courant number, and "
             "each run scored against the reference as it is (Courant 0.5) and against its first-order "
             "extrapolation to dt → 0. Worst over the stations, as peer_score.md.", ""]
    for r in sorted(out["runs"].values(), key=lambda r: r["problem"]):
        ch = r["reference_change_us"]
        worst = max(ch, key=lambda x: abs(ch[x]))
        lines += [f"## {r['problem']}", "",
                  f"The reference's rupture times move by {min(ch.values()):+.3f} to {max(ch.values()):+.3f} µs "
                  f"when its Courant number halves (largest at {worst} mm).", "",
                  "| run | CPU [s] | worst Δt_r [µs], [%] as is | worst Δslip [%] as is "
                  "| worst Δt_r [µs], [%] dt → 0 | worst Δslip [%] dt → 0 |", "|---|---|---|---|---|---|"]
        for row in r["rows"]:
            a, b = row["as_is"], row["dt0"]
            lines.append(f"| {row['who']} | {row['cpu_s']:.1f} | {a['t_r_us']:.3f}, {a['t_r_pct']:.2f} | "
                         f"{a['slip_pct']:.2f} | {b['t_r_us']:.3f}, {b['t_r_pct']:.2f} | {b['slip_pct']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", nargs="+", default=["rsf_aging_2d", "rsf_slip_2d"], choices=score.PROBLEMS)
    ap.add_argument("--base", default="/var/tmp/fricfem-peer-dt5")
    args = ap.parse_args(argv)
    doc = score.load_results(score.RESULTS / "peer_score.json")
    out = score.load_results(RESULT)
    for problem in args.problem:
        out["runs"][problem] = problem_result(problem, Path(args.base), doc)
        score.save_results(RESULT, out, table)
    return out


if __name__ == "__main__":
    main()
