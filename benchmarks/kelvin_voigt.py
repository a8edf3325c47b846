"""What a Kelvin–Voigt layer about the fault (``interface.damping_eta``,
``interface.damping_width``; docs/interface_kinds.md) does on the peer
problems: the rigid kind's slip-rate ringing behind the front, and the
rupture-time and slip errors against the peer's finest run.

Each (problem, h, ETA) is one fricfem run on 1 rank (benchmarks/peer/score.py
runs it and reads it); the layer is 3 cells tall on each side.  Ringing: at each
peer station the slip rate's high-frequency part, V minus its moving average
over 0.3 µs (about one period of the ringing), as an rms over 3 µs from 1 µs
after the station's rupture time (past the front's own rise), relative to the
station's peak slip rate; the worst and the median over the stations that slip.

    .venv/bin/python benchmarks/kelvin_voigt.py                           # both problems, 0.2 mm, ETA 0 / 0.03 / 0.1 / 0.3
    .venv/bin/python benchmarks/kelvin_voigt.py --problems tpv205_2d --h 0.4e-3 --eta 0 0.3
    .venv/bin/python benchmarks/kelvin_voigt.py --h 0.4e-3 0.2e-3 0.1e-3         # the committed table
    .venv/bin/python benchmarks/kelvin_voigt.py --h 0.1e-3 --merge                # add rows, keep the others

Results: benchmarks/results/kelvin_voigt.{json,md}.  Runs: runs/kelvin_voigt/.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks" / "peer"))
import score  # noqa: E402  (benchmarks/peer/score.py: the peer's reference and the run's metrics)

from fricfem.output.rundir import open_interface  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
LAYER_CELLS = 3  # cells on each side of the fault
WINDOW_S = 0.3e-6  # the moving average the ringing is measured against: about one period of the ringing
SKIP_S = 1.0e-6  # the front's own rise after the rupture time, not counted
AFTER_S = 3.0e-6  # how long it is measured, from t_r + SKIP_S


def ringing(rundir: Path, stations_mm, t_r: dict) -> dict:
    """{x_mm: rms of V − its 0.3 µs moving average over [t_r + 1 µs, t_r + 4 µs], over the peak V}."""
    with open_interface(rundir) as itf:
        st = itf.stations()
    out = {}
    for x in stations_mm:
        s = st[f"x{x}mm"]
        t, v = np.asarray(s.time), np.asarray(s.data["slip_rate"])
        if t_r.get(x) is None or v.max() <= score.THRESHOLD:
            continue
        dt = t[1] - t[0]
        k = max(int(round(WINDOW_S / dt)), 1)
        smooth = np.convolve(v, np.ones(k) / k, mode="same")
        t0 = t_r[x] + SKIP_S
        sel = (t >= t0) & (t <= t0 + AFTER_S) & (t <= t[-1] - WINDOW_S)
        if sel.sum() > 2 * k:
            out[x] = float(np.sqrt(np.mean((v[sel] - smooth[sel]) ** 2)) / v.max())
    return out


def one(problem: str, h: float, eta: float, ranks: int, out: Path) -> dict:
    ref = score.peer_metrics(problem, score.reference(problem))
    xs = sorted(ref["stations"])
    d = out / problem / f"h{h * 1e3:g}_eta{eta:g}"
    extra = []
    if eta > 0:
        extra = ["--set", f"interface.damping_eta={eta!r}", "--set", f"interface.damping_width={LAYER_CELLS * h!r}"]
    rec = score.run_fricfem(problem, "rigid", h, d, ranks, None, extra=extra)
    m = score.run_metrics(d, "rigid", xs, ref["end_s"])
    err = score.errors(m, ref["stations"])
    ring = ringing(d, xs, {x: m[x]["t_r"] for x in xs})
    vals = sorted(ring.values())
    return {"problem": problem, "h_m": h, "eta": eta, "dt_s": rec["dt_s"], "cpu_s": rec["cpu_s"],
            "t_r_us": err["t_r_us"], "t_r_pct": err["t_r_pct"], "slip_pct": err["slip_pct"],
            "ringing_worst": vals[-1], "ringing_median": vals[len(vals) // 2], "ringing": ring}


def table(rows: list) -> str:
    lines = ["# Kelvin–Voigt layer on the peer problems (rigid kind)", "",
             "`.venv/bin/python benchmarks/kelvin_voigt.py` (method: its docstring). The layer is "
             f"{LAYER_CELLS} cells on each side of the fault; ETA = `interface.damping_eta` (η = ETA dt). "
             "Errors against the peer's finest run (benchmarks/peer/score.py); ringing: rms of the slip rate "
             "minus its 0.3 µs moving average from 1 to 4 µs after rupture, over the peak slip rate.", "",
             "| problem | h [mm] | ETA | dt [ns] | CPU [s] | worst Δt_r [µs] (%) | worst Δslip [%] | ringing worst | ringing median |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['problem']} | {r['h_m'] * 1e3:g} | {r['eta']:g} | {r['dt_s'] * 1e9:.1f} | {r['cpu_s']:.1f} "
                     f"| {r['t_r_us']:.3f} ({r['t_r_pct']:.2f}) | {r['slip_pct']:.2f} | {r['ringing_worst']:.4f} "
                     f"| {r['ringing_median']:.4f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> list:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="+", default=["tpv205_2d", "rsf_aging_2d"], choices=score.PROBLEMS)
    ap.add_argument("--h", nargs="+", type=float, default=[0.2e-3])
    ap.add_argument("--eta", nargs="+", type=float, default=[0.0, 0.03, 0.1, 0.3])
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--out", default="runs/kelvin_voigt")
    ap.add_argument("--merge", action="store_true", help="keep the committed rows this run does not redo")
    args = ap.parse_args(argv)
    rows = []
    for problem in args.problems:
        for h in args.h:
            for eta in args.eta:
                r = one(problem, h, eta, args.ranks, Path(args.out))
                rows.append(r)
                print(f"{problem} h = {h * 1e3:g} mm ETA {eta:g}: dt {r['dt_s'] * 1e9:.1f} ns, t_r {r['t_r_us']:.3f} µs "
                      f"({r['t_r_pct']:.2f} %), slip {r['slip_pct']:.2f} %, ringing worst {r['ringing_worst']:.4f} "
                      f"median {r['ringing_median']:.4f}, CPU {r['cpu_s']:.1f} s", flush=True)
    if args.merge and RESULTS.joinpath("kelvin_voigt.json").exists():
        # the committed rows this invocation did not rerun are kept
        done = {(r["problem"], r["h_m"], r["eta"]) for r in rows}
        old = json.loads(RESULTS.joinpath("kelvin_voigt.json").read_text())["rows"]
        rows += [r for r in old if (r["problem"], r["h_m"], r["eta"]) not in done]
    order = {p: i for i, p in enumerate(score.PROBLEMS)}
    rows.sort(key=lambda r: (order[r["problem"]], r["h_m"], r["eta"]))
    RESULTS.joinpath("kelvin_voigt.json").write_text(json.dumps(
        {"date": time.strftime("%Y-%m-%d %H:%M"), "rows": rows}, indent=1, default=float))
    RESULTS.joinpath("kelvin_voigt.md").write_text(table(rows))
    return rows


if __name__ == "__main__":
    main()
