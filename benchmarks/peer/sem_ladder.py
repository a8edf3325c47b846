"""Spectral elements against the peer: the rigid kind on ``mesh.degree`` p
elements of size h, scored as :mod:`score` scores the linear triangles (the
peer's finest run the reference), with CPU summed over ranks, and each run's
rupture times at ``time.dt_safety`` 0.9 and 0.45 (the change between them:
issue 26's dt criterion).

    .venv/bin/python benchmarks/peer/sem_ladder.py --problem tpv205_2d --p 4 --h 0.8e-3 0.4e-3

``--uniform``: the whole box in elements of size h (``mesh.max_size`` = h), the
peer's layout, instead of the scene's band graded to 2 mm (``--coarse S``: graded
to S instead; ``--grading G``: the growth ratio of that grading, default the
scene's); rsf_slip_2d needs it
(its supershear front's field outside the band sets the slip in its right half:
docs/elements.md).  ``--rerun``: run again (CPU measured anew).

Runs: runs/sem/<problem>/p<p>_h<h>[_u][_m<S mm>][_g<G>]_sf<safety> (1 rank; reused when complete).
Results: benchmarks/results/sem_ladder.{json,md} (merged by problem, p and h).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import score

RESULT = score.RESULTS / "sem_ladder.json"


def _suffix(uniform: bool, coarse: float | None, grading: float | None = None) -> str:
    return ("_u" if uniform else "") + (f"_m{coarse * 1e3:g}" if coarse else "") + (f"_g{grading:g}" if grading else "")


def rundir(out: Path, problem: str, p: int, h: float, uniform: bool, sf: float, coarse: float | None = None,
           grading: float | None = None) -> Path:
    return Path(out) / problem / f"p{p}_h{h * 1e3:g}{_suffix(uniform, coarse, grading)}_sf{sf:g}"


def layout(p: int, h: float, uniform: bool, sf: float, coarse: float | None = None,
           grading: float | None = None) -> list:
    """The --set items of one spectral run (beyond score.overrides'): ``uniform`` elements of
    size h over the whole box, else the scene's band graded outward to ``coarse`` [m]
    (``mesh.max_size``; None: the scene's 2 mm) at the growth ratio ``grading``
    (``mesh.grading``; None: the scene's)."""
    size = h if uniform else coarse
    return (["--set", f"mesh.degree={p}", "--set", f"time.dt_safety={sf!r}"]
            + (["--set", f"mesh.max_size={size!r}"] if size else [])
            + (["--set", f"mesh.grading={grading!r}"] if grading and not uniform else []))


def one(problem: str, p: int, h: float, out: Path, ranks: int, safety: tuple, uniform: bool = False,
        rerun: bool = False, coarse: float | None = None, grading: float | None = None) -> dict:
    ref = score.peer_metrics(problem, score.reference(problem))
    xs = sorted(ref["stations"])
    runs = {}
    for sf in safety:
        d = rundir(out, problem, p, h, uniform, sf, coarse, grading)
        rec = score.run_fricfem(problem, "rigid", h, d, ranks, None, rerun=rerun,
                                extra=layout(p, h, uniform, sf, coarse, grading))
        m = score.run_metrics(d, "rigid", xs, ref["end_s"])
        runs[f"{sf:g}"] = {"record": rec, "errors": score.errors(m, ref["stations"]), "metrics": m}
    first, *rest = safety
    change = None
    if rest:
        a, b = runs[f"{first:g}"]["metrics"], runs[f"{rest[0]:g}"]["metrics"]
        d_t = [abs(a[x]["t_r"] - b[x]["t_r"]) for x in xs
               if a[x]["t_r"] is not None and b[x]["t_r"] is not None and b[x]["t_r"] > score.T_R_MIN]
        d_s = [abs(a[x]["slip"] - b[x]["slip"]) / abs(b[x]["slip"]) for x in xs if b[x]["slip"]]
        change = {"dt_r_us": 1e6 * max(d_t), "slip_pct": 100 * max(d_s)}
    for r in runs.values():
        r.pop("metrics")
    return {"problem": problem, "p": p, "h_m": h, "uniform": uniform, "coarse_m": coarse,
            "grading": grading, "ranks": ranks,
            "safety": list(safety),
            "runs": runs, "dt_change": change}


def table(doc: dict) -> str:
    lines = ["# Spectral elements against the peer (rigid kind)", "",
             "`.venv/bin/python benchmarks/peer/sem_ladder.py` (its docstring). Errors against the peer's finest "
             "run, as benchmarks/results/peer_score.md; CPU: user + system summed over ranks, the whole run. "
             "dt change: the largest change of a station's rupture time [µs] and final slip [%] between "
             "`time.dt_safety` 0.9 and 0.45.", ""]
    for problem in score.PROBLEMS:
        rows = [r for r in doc["runs"].values() if r["problem"] == problem]
        if not rows:
            continue
        lines += [f"## {problem}", "", "| p | h [mm] | mesh | dofs | dt [ns] | CPU [s] | worst Δt_r [µs] | worst Δt_r [%] "
                  "| worst Δslip [%] | worst ΔV_peak [%] | dt change: t_r [µs], slip [%] |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in sorted(rows, key=lambda r: (r["p"], r.get("uniform", False), r.get("coarse_m") or 0.0,
                                                r.get("grading") or 0.0, -r["h_m"])):
            run = r["runs"][f"{r['safety'][0]:g}"]
            e, rec = run["errors"], run["record"]
            ch = r["dt_change"]
            mesh = "uniform" if r.get("uniform") else (f"band to {(r.get('coarse_m') or 2e-3) * 1e3:g} mm"
                                                        + (f", grading {r['grading']:g}" if r.get("grading") else ""))
            lines.append(f"| {r['p']} | {r['h_m'] * 1e3:g} | {mesh} | "
                         f"{rec['dofs']:,} | {rec['dt_s'] * 1e9:.2f} | "
                         f"{rec['cpu_s']:.1f} | {e['t_r_us']:.3f} | {e['t_r_pct']:.2f} | {e['slip_pct']:.2f} | "
                         f"{e['v_peak_pct']:.1f} | "
                         + ("—" if ch is None else f"{ch['dt_r_us']:.3f}, {ch['slip_pct']:.2f}") + " |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="tpv205_2d", choices=score.PROBLEMS)
    ap.add_argument("--p", nargs="+", type=int, default=[4])
    ap.add_argument("--h", nargs="+", type=float, default=[0.8e-3, 0.4e-3])
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--safety", nargs="+", type=float, default=[0.9, 0.45])
    ap.add_argument("--out", default="runs/sem")
    ap.add_argument("--uniform", action="store_true", help="elements of size h over the whole box (module doc)")
    ap.add_argument("--coarse", type=float, help="the largest element outside the band [m] (mesh.max_size; "
                    "default: the scene's 2 mm)")
    ap.add_argument("--grading", type=float, help="the growth ratio of that grading (mesh.grading; default: "
                    "the scene's)")
    ap.add_argument("--rerun", action="store_true", help="run again even where a complete run is there")
    args = ap.parse_args(argv)
    if args.uniform and (args.coarse or args.grading):
        ap.error("--coarse and --grading shape the band's grading; --uniform has none")
    doc = score.load_results(RESULT)
    for p in args.p:
        for h in args.h:
            r = one(args.problem, p, h, Path(args.out), args.ranks, tuple(args.safety), args.uniform, args.rerun,
                    args.coarse, args.grading)
            key = _suffix(args.uniform, args.coarse, args.grading).replace("_", "")
            doc["runs"][f"{args.problem}/p{p}/h{h * 1e3:g}{key}"] = r
            e = r["runs"][f"{args.safety[0]:g}"]["errors"]
            print(f"{args.problem} p = {p} h = {h * 1e3:g} mm: worst t_r {e['t_r_us']:.3f} us ({e['t_r_pct']:.2f} %), "
                  f"slip {e['slip_pct']:.2f} %, CPU {r['runs'][f'{args.safety[0]:g}']['record']['cpu_s']:.1f} s, "
                  f"dt change {r['dt_change']}", flush=True)
            score.save_results(RESULT, doc, table)
    return doc


if __name__ == "__main__":
    main()
