# # The gallery's mode scenes: one run per sliding mode found by search, its figures and numbers
#
# Runs the shipped mode scenes (`fricfem/scenes/mode_*.toml`, `experiment_mode_*.toml`; each says how
# it was found) as shipped plus a camera's isochromatic frames, and writes for docs/gallery.md
#
# - `docs/figures/gallery/<scene>_spacetime.png` and `<scene>_frames.png`, drawn as `demos/gallery.py`
#   draws the paper scenes' (the same functions, window and palette);
# - `docs/figures/gallery/modes.json`: what each run gave (mode, reason, initiation, tip, peak slip
#   rate, coalescences, the share of the interface behind the tip that slides, fronts faster than
#   c_l behind the tip) and the command that reproduces it.
#
# Run: `mpirun -n 2 .venv/bin/python demos/experiment/gallery.py` (about two minutes of runs on 2 ranks).
# Each run is what `fricfem run <scene> --set ... --out runs/gallery/<scene>` writes;
# `fricfem plot runs/gallery/<scene>` draws the same figures and more.

import json
import os
import sys
from pathlib import Path

from mpi4py import MPI
from PIL import Image

sys.path.insert(0, str(Path(__file__).parent))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
import common  # noqa: E402

from fricfem import load_scene, open_run, runner  # noqa: E402
from fricfem.output.rundir import open_interface, run_info  # noqa: E402
from fricfem.plot.frames import frame_series  # noqa: E402
from fricfem.plot.spacetime import spacetime  # noqa: E402

#: scene -> the camera (start, interval, count) of its isochromatic frames [s]
MODES = {
    "mode_crack_like": (16e-6, 8e-6, 4),  # edge-velocity loading, to 40 µs
    "experiment_mode_pulse_then_crack": (32e-6, 8e-6, 4),  # the experiment's loading, to 56 µs
    "experiment_mode_coalescing": (32e-6, 8e-6, 4),
    "experiment_mode_supersonic_trailing": (32e-6, 8e-6, 4),
}
FIGURES = Path(__file__).resolve().parents[2] / "docs" / "figures" / "gallery"
ap = common.options("runs/gallery")
ap.set_defaults(out=FIGURES)  # --out: the figures' folder; --preset: the mesh (the scenes' own: reference)
a = ap.parse_args()
comm = MPI.COMM_WORLD


def numbers(name: str, scene, summary: dict, out: Path, command: str) -> dict:
    """What the run gave, for the gallery's text (rank 0)."""
    run = open_run(out)
    mode = summary.get("mode") or {}
    ev = json.loads((out / "evidence.json").read_text()).get("mode_evidence", {})
    init = summary.get("initiation")
    tip = common.tip_measures(run)
    late = ev.get("late") or {}
    return {
        "command": command, "description": scene.description, "mode": mode.get("label"),
        "reason": ev.get("reason"), "sliding_from_us": None if init is None else init["time_s"] * 1e6,
        "tip_at_end_mm": float(run.tip(run.t[-1]) * 1e3), "tip_mean_m_s": tip.get("mean_m_s"),
        "peak_slip_rate_m_s": float(run.slip_rate.max()), "t_end_us": scene.t_end * 1e6,
        "types": ev.get("types"), "late_types": ev.get("late_types"), "longest_pulse_phase": ev.get("longest_pulse_phase"),
        "late_median": late, "max_regions": ev.get("max_regions"), "coalescences": len(ev.get("coalescences") or []),
        "sliding_share_behind_tip": common.crack_like(run, [t * 1e-6 for t in (16, 24, 32, 40, 48)
                                                           if t * 1e-6 <= scene.t_end]),
        "second_front": common.second_front(run, summary["speeds"]),
        "slip_rate_spike": summary.get("slip_rate_spike"),
    }


report = {}
for name, (start, interval, count) in MODES.items():
    frames = f"output.frames={{start={start!r}, interval={interval!r}, count={count}}}"
    scene = load_scene(name, [f"mesh.preset='{a.preset}'", "output.fields=[]", frames])
    out = a.work / name
    summary = runner.run_scene(scene, out, comm, overwrite=True, quiet=True)
    if comm.rank == 0:
        command = f"mpirun -n 2 .venv/bin/fricfem run {name} --set output.fields=[] --set '{frames}' --out {out}"
        report[name] = numbers(name, scene, summary, out, command)

if comm.rank == 0:
    a.out.mkdir(parents=True, exist_ok=True)
    for name, (start, interval, count) in MODES.items():
        out = a.work / name
        summary = json.loads((out / "summary.json").read_text())
        with open_interface(out) as itf:
            info = run_info(out, interface=itf, summary=summary)
            spacetime(itf, a.out / f"{name}_spacetime.png", summary=summary, info=info)
            frame_series(out / "fields.xdmf", a.out / f"{name}_frames.png",
                         [start + k * interval for k in range(count)], info=info, itf=itf,
                         window=(0.0, 0.080, -0.030, 0.030), width_px=420)
        for png in a.out.glob(f"{name}_*.png"):  # small files for the repository: a 96-colour palette
            Image.open(png).convert("RGB").quantize(colors=96).save(png, optimize=True)
    (a.out / "modes.json").write_text(json.dumps(report, indent=1, default=float) + "\n")
    print(json.dumps({k: (v["mode"], v["sliding_from_us"], v["tip_at_end_mm"]) for k, v in report.items()}, indent=1))
