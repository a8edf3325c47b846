# # Skipping what a scene does not need
#
# Each line of the table is one saving, measured as the wall time of whole
# runs (``fricfem.runner.run_scene`` in this process, all ranks) with the saving
# on and off, everything else equal; the median over ``--repeats`` runs of
# each, the two variants interleaved so that both see the same load:
#
# * **quiet rows** (``time.skip_quiet``): the fused step skips the rows of K
#   the motion has not reached yet (bit-identical to computing every row;
#   ``tests/test_fused.py``).  Case I as printed (nothing slides), Case III
#   (a train of pulses) and the slip-weakening rupture problem, whose motion
#   starts at the interface instead of the struck edge;
# * **fields** (``output.fields``): displacement, velocity and σ1 − σ2 are
#   computed and written only at the requested times — here none against one
#   snapshot per µs;
# * **interface snapshots** (``output.interface_every``): every 0.2 µs (the
#   default) against every step;
# * **energy** (``output.energy_every``): every 50 steps (the default)
#   against every step;
# * **stop early** (``time.stop_at_tip``): line A at 40 m/s (Σ0 = 10 MPa)
#   ends once its sliding tip leaves the fine region (x1 = 60 mm, at 36 µs),
#   where the mode is decided and the mesh no longer resolves the interface,
#   against running to 40 µs.  (For a whole mode map see the README.)
#
# Run (under mpirun; every rank runs every scene)::
#
#     mpirun -n 2 .venv/bin/python benchmarks/skipping.py [--repeats 3]
#
# writes ``benchmarks/results/skipping.json``, ``skipping.md`` and
# ``skipping.png``.  ``--smoke``: coarse mesh, 5 µs, one repeat (tests).

from __future__ import annotations

import argparse
import json
import logging
import tempfile
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import load_scene
from fricfem.runner import run_scene

HERE = Path(__file__).resolve().parent

# (name, what, base scene, overrides with the saving, overrides without it)
CASES = [
    ("quiet rows", "Case I as printed", "case1", ["time.skip_quiet=true"], ["time.skip_quiet=false"]),
    ("quiet rows", "Case III", "case3", ["time.skip_quiet=true"], ["time.skip_quiet=false"]),
    ("quiet rows", "rupture problem", "rupture_sw", ["time.skip_quiet=true"], ["time.skip_quiet=false"]),
    ("fields", "Case I, no snapshot vs one per µs", "case1", ["output.fields=[]"], None),
    ("interface snapshots", "Case I, every 0.2 µs vs every step", "case1", [], ["output.interface_every=1e-9"]),
    ("energy", "Case I, every 50 steps vs every step", "case1", [], ["output.energy_every=1"]),
    ("stop early", "line A at 40 m/s, stop when the tip passes 60 mm", "lineA_v40", ["time.stop_at_tip=0.06"], []),
]


def fields_every_us(t_end: float) -> list:
    """The override asking for one field snapshot per µs up to ``t_end``."""
    times = [round(k * 1e-6, 9) for k in range(1, int(round(t_end * 1e6)) + 1)]
    return [f"output.fields={times!r}"]


def timed_run(comm, name: str, overrides: list, work: Path) -> dict:
    scene = load_scene(name, overrides)
    s = run_scene(scene, work, comm, overwrite=True, quiet=True)
    return {"total_s": s["wall_s"]["total"], "loop_s": s["wall_s"]["time_loop"], "output_s": s["wall_s"]["output"],
            "steps": s["steps"], "ended_early": s["ended_early"]}


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    ap = argparse.ArgumentParser(description="Speed-ups of the savings fricfem makes when a scene does not need "
                                             "the work.")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--preset", default="reference")
    ap.add_argument("--smoke", action="store_true", help="coarse mesh, 5 µs, one repeat")
    ap.add_argument("--out", type=Path, default=None, help="default results/ (results/smoke/ with --smoke)")
    args = ap.parse_args(argv)
    common = [f"mesh.preset='{args.preset}'"]
    if args.smoke:
        args.repeats, common = 1, ["mesh.preset='coarse'", "time.end=5e-6", "output.fields=[]"]
    if args.out is None:
        args.out = HERE / "results" / ("smoke" if args.smoke else "")
    logging.getLogger().setLevel(logging.WARNING)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(comm.bcast(tmp if comm.rank == 0 else None))
        for saving, what, name, on, off in CASES:
            t_end = load_scene(name, common).t_end
            if off is None:  # the fields line: the same scene with a snapshot per µs
                off = fields_every_us(t_end)
            on_runs, off_runs = [], []
            for _ in range(args.repeats):
                on_runs.append(timed_run(comm, name, common + on, work / "on"))
                off_runs.append(timed_run(comm, name, common + off, work / "off"))
            med = {k: {q: float(np.median([r[q] for r in runs])) for q in ("total_s", "loop_s", "output_s")}
                   for k, runs in (("on", on_runs), ("off", off_runs))}
            rows.append({
                "saving": saving, "what": what, "scene": name, "with": on, "without": off,
                "median": med, "steps": {"on": on_runs[0]["steps"], "off": off_runs[0]["steps"]},
                "speedup_total": med["off"]["total_s"] / med["on"]["total_s"],
                "speedup_loop": med["off"]["loop_s"] / med["on"]["loop_s"],
            })
    doc = {"ranks": comm.size, "preset": "coarse" if args.smoke else args.preset, "repeats": args.repeats,
           "smoke": args.smoke, "rows": rows}
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "skipping.json").write_text(json.dumps(doc, indent=2))
        text = table(doc)
        (args.out / "skipping.md").write_text(text + "\n")
        figure(doc, args.out / "skipping.png")
        print(text)
    return doc


def table(doc: dict) -> str:
    lines = [f"# Skipping what a scene does not need ({doc['preset']} mesh, {doc['ranks']} rank(s), "
             f"median of {doc['repeats']})", "",
             "| saving | scene | total without / with [s] | time loop without / with [s] | speed-up (total) | "
             "speed-up (loop) |", "|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        m = r["median"]
        lines.append(f"| {r['saving']} | {r['what']} | {m['off']['total_s']:.2f} / {m['on']['total_s']:.2f} | "
                     f"{m['off']['loop_s']:.2f} / {m['on']['loop_s']:.2f} | {r['speedup_total']:.2f} | "
                     f"{r['speedup_loop']:.2f} |")
    return "\n".join(lines)


def figure(doc: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = doc["rows"]
    fig, ax = plt.subplots(figsize=(8, 0.5 * len(rows) + 1.2))
    y = np.arange(len(rows))
    ax.barh(y, [r["speedup_total"] for r in rows], color="C0")
    ax.set_yticks(y, [f"{r['saving']}: {r['what']}" for r in rows], fontsize=8)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.invert_yaxis()
    ax.set_xlabel("wall time without / with the saving (whole run)")
    ax.set_title(f"{doc['preset']} mesh, {doc['ranks']} rank(s)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
