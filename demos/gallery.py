# # The sliding modes fricfem produces: the gallery's runs and figures
#
# Runs one shipped paper scene per sliding mode fricfem gives (as recorded in
# tests/golden/scene_modes.json: none, crack-like, pulse, mixed — no shipped
# scene and no point of the mode map gives a train of pulses), each as
# shipped plus a camera's isochromatic frames, and writes for docs/gallery.md
#
# - `docs/figures/gallery/<scene>_spacetime.png`: the slip rate over (x1, t)
#   with the tracked fronts and the c_l, c_s lines;
# - `docs/figures/gallery/<scene>_frames.png`: the isochromatic frames;
# - `docs/figures/gallery/gallery.json`: what each run gave (mode, evidence,
#   initiation, tip, peak slip rate) and the command that reproduces it.
#
# Run: `mpirun -n 2 .venv/bin/python demos/gallery.py [--out runs/gallery]`
# (about a minute of runs on 2 ranks, then the figures on rank 0).
# Each run is what `fricfem run <scene> --set ... --out runs/gallery/<scene>`
# writes; `fricfem plot runs/gallery/<scene>` draws the same figures and more.

import argparse
import json
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI
from PIL import Image

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
from fricfem import load_scene, open_run, runner  # noqa: E402
from fricfem.output.rundir import open_interface, run_info  # noqa: E402
from fricfem.plot.frames import frame_series  # noqa: E402
from fricfem.plot.spacetime import spacetime  # noqa: E402

#: scene -> the camera (start, interval, count) of its isochromatic frames [s]
GALLERY = {
    "case1": (16e-6, 8e-6, 4),  # no sliding: the loading waves alone
    "case4": (16e-6, 8e-6, 4),  # crack-like
    "case3": (16e-6, 8e-6, 4),  # pulse
    "lineA_v40": (16e-6, 8e-6, 4),  # mixed
}
FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures" / "gallery"

parser = argparse.ArgumentParser(description="the gallery of sliding modes")
parser.add_argument("--out", default="runs/gallery", help="folder of the run directories")
parser.add_argument("--figures", default=str(FIGURES), help="folder of the gallery's figures")
args = parser.parse_args()
comm = MPI.COMM_WORLD

# ## The runs
# Each scene as shipped (its mesh, end time, loading), no field snapshots but
# the camera's frames; 16 µs to 40 µs every 8 µs.
report = {}
for name, (start, interval, count) in GALLERY.items():
    over = ["output.fields=[]", f"output.frames={{start={start!r}, interval={interval!r}, count={count}}}"]
    scene = load_scene(name, over)
    out = Path(args.out) / name
    summary = runner.run_scene(scene, out, comm, overwrite=True, quiet=True)
    run = open_run(out)
    mode = summary.get("mode") or {}
    init = summary.get("initiation")
    report[name] = {
        "command": (f"mpirun -n 2 .venv/bin/fricfem run {name} --set output.fields=[] "
                    f"--set 'output.frames={{start={start!r}, interval={interval!r}, count={count}}}' "
                    f"--out runs/gallery/{name}"),
        "description": scene.description, "mode": mode.get("label"),
        "reason": (mode.get("evidence") or {}).get("reason"),
        "sliding_from_us": None if init is None else init["time_s"] * 1e6,
        "tip_at_end_mm": None if not np.isfinite(run.tip(run.t[-1])) else run.tip(run.t[-1]) * 1e3,
        "peak_slip_rate_m_s": float(run.slip_rate.max()), "t_end_us": scene.t_end * 1e6,
        "dofs": summary["dofs"], "steps": summary["steps"],
    }

# ## The figures (rank 0)
if comm.rank == 0:
    figures = Path(args.figures)
    figures.mkdir(parents=True, exist_ok=True)
    for name, (start, interval, count) in GALLERY.items():
        out = Path(args.out) / name
        summary = json.loads((out / "summary.json").read_text())
        with open_interface(out) as itf:
            info = run_info(out, interface=itf, summary=summary)
            spacetime(itf, figures / f"{name}_spacetime.png", summary=summary, info=info)
            times = [start + k * interval for k in range(count)]
            frame_series(out / "fields.xdmf", figures / f"{name}_frames.png", times, info=info, itf=itf,
                         window=(0.0, 0.080, -0.030, 0.030), width_px=420)
    for png in figures.glob("*.png"):  # small files for the repository: a 96-colour palette
        Image.open(png).convert("RGB").quantize(colors=96).save(png, optimize=True)
    (figures / "gallery.json").write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps({k: (v["mode"], v["sliding_from_us"], v["tip_at_end_mm"]) for k, v in report.items()}, indent=1))
