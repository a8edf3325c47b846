"""dt-convergence at fixed h (issue 26's goal: rupture times within 0.05 µs and
slip within 0.2 % between ``time.dt_safety`` 0.9 and 0.45): a peer problem with
the rigid kind at both steps, the worst change over the peer's stations (rupture
times after 1 µs, as score.py scores them; slip at the peer's end time), and
each run's worst errors against the peer's finest run.

    .venv/bin/python benchmarks/peer/dt_convergence.py --h 0.2e-3
    .venv/bin/python benchmarks/peer/dt_convergence.py --h 0.2e-3 --pythonpath OTHER_TREE --tag before

Runs go to ``runs/dt_convergence/<tag>/<problem>/h<h>_sf<dt_safety>`` (reused
when complete, as score.py's)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import score


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="rsf_aging_2d", choices=score.PROBLEMS)
    ap.add_argument("--h", nargs="+", type=float, default=[0.2e-3])
    ap.add_argument("--safety", nargs=2, type=float, default=[0.9, 0.45])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--tag", default="tree")
    ap.add_argument("--pythonpath")
    ap.add_argument("--out", default="runs/dt_convergence")
    args = ap.parse_args(argv)
    ref = score.peer_metrics(args.problem, score.REFERENCE)
    xs = sorted(ref["stations"])
    out = {}
    for h in args.h:
        m = {}
        for sf in args.safety:
            d = Path(args.out) / args.tag / args.problem / f"h{h * 1e3:g}_sf{sf:g}"
            score.run_fricfem(args.problem, "rigid", h, d, args.ranks, args.pythonpath,
                              extra=["--set", f"time.dt_safety={sf!r}"])
            m[sf] = score.run_metrics(d, "rigid", xs, ref["end_s"])
        a, b = (m[sf] for sf in args.safety)
        dt_r = max(abs(a[x]["t_r"] - b[x]["t_r"]) for x in xs
                   if a[x]["t_r"] is not None and b[x]["t_r"] is not None and b[x]["t_r"] > score.T_R_MIN)
        dslip = max(abs(a[x]["slip"] / b[x]["slip"] - 1.0) for x in xs if ref["stations"][x]["v_peak"] > score.THRESHOLD)
        peer = {sf: score.errors(m[sf], ref["stations"]) for sf in args.safety}
        out[h] = {"dt_r_us": 1e6 * dt_r, "dslip_pct": 100 * dslip,
                  "peer": {sf: {k: peer[sf][k] for k in ("t_r_us", "t_r_pct", "slip_pct")} for sf in args.safety}}
        print(f"{args.tag} {args.problem} h = {h * 1e3:g} mm: dt_safety {args.safety[0]:g} vs {args.safety[1]:g}: "
              f"worst |Δt_r| {1e6 * dt_r:.3f} µs, worst slip change {100 * dslip:.2f} %; against the peer: "
              + ", ".join(f"{sf:g}: t_r {peer[sf]['t_r_us']:.3f} µs ({peer[sf]['t_r_pct']:.2f} %), "
                          f"slip {peer[sf]['slip_pct']:.2f} %" for sf in args.safety))
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
