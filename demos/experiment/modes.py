# # One scene per sliding mode fricfem finds under the experiment's loading (and crack-like under the edge velocity)
#
# The scenes `fricfem/scenes/experiment_mode_*.toml` are points of the sweep of
# `sweep.py` (experiment_42 over projectile speed and Σ0, nothing tuned);
# `mode_crack_like.toml` is a point of the edge-velocity mode map (REPRODUCTION.md
# §5), the mode the experiment's loading never gives; each says how it was found.  This script runs each scene (or takes the sweep's run
# of the same point: same keys but the name) and shows its slip rate over x1
# and t with the leading tip and the fronts faster than c_l, next to the
# classifier's label and reason, the coalescences of slipping regions and the
# share of the interface behind the tip that slides.
#
# Run: `mpirun -n 2 .venv/bin/python demos/experiment/modes.py [--preset reference]`
# Writes benchmarks/results/experiment/modes_<preset>.json and .png.

import json
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).parent))
import common  # noqa: E402

from fricfem import load_scene, open_run  # noqa: E402
from fricfem.analysis.tip import tip_history  # noqa: E402

ap = common.options("runs/experiment_modes")
ap.add_argument("--sweep", type=Path, default=Path("runs/experiment_sweep"))
a = ap.parse_args()
comm = MPI.COMM_WORLD
SCENES = ("experiment_mode_pulse", "experiment_mode_pulse_then_crack", "experiment_mode_coalescing",
          "experiment_mode_supersonic_trailing", "mode_crack_like")  # the last: the edge-velocity loading


def rundir(name: str) -> Path:
    """The sweep's run of the scene's point when it has the same input but the name, else a new run."""
    scene = load_scene(name, [f"mesh.preset='{a.preset}'"])
    same = False
    if scene.experiment is not None:
        sweep = a.sweep / f"v{scene.experiment.projectile_speed:g}_s{scene.sigma0 / 1e6:g}"
    if comm.rank == 0 and scene.experiment is not None and (sweep / "summary.json").is_file():
        got = json.loads((sweep / "summary.json").read_text())["input"]
        mine = {k: v for k, v in scene.raw.items() if k not in ("name", "description", "base")}
        same = {k: v for k, v in got.items() if k not in ("name", "description", "base")} == mine
    if comm.bcast(same, root=0):
        return sweep
    common.run(scene, a.work / name, comm)
    return a.work / name


rows, dirs = {}, {}
for name in SCENES:
    dirs[name] = rundir(name)
if comm.rank == 0:
    fig = Figure(figsize=(3.4 * len(SCENES), 3.6))
    axes = np.atleast_1d(fig.subplots(1, len(SCENES)))
    for ax, name in zip(axes, SCENES):
        r = open_run(dirs[name])
        s = r.summary
        ev = s["mode"]["evidence"]
        evidence = json.loads((dirs[name] / "evidence.json").read_text()).get("mode_evidence", {})
        sf = common.second_front(r, s["speeds"])
        rows[name] = {"run": str(dirs[name]), "label": s["mode"]["label"], "reason": ev.get("reason"),
                      "coalescences": len(evidence.get("coalescences") or []),
                      "crack_like": common.crack_like(r, (30e-6, 40e-6, 50e-6)), "second_front": sf,
                      "tip": common.tip_measures(r)}
        ax.pcolormesh(r.x1 * 1e3, r.t * 1e6, np.log10(np.maximum(r.slip_rate, 1e-2)), shading="auto",
                      cmap="magma_r", vmin=-2, vmax=max(math.log10(max(r.slip_rate.max(), 1.0)), -1))
        t, x = tip_history(r.t, r.x1, r.slip_rate)
        ax.plot(x * 1e3, t * 1e6, "c-", lw=0.6)
        for f in sf["fronts"]:
            ax.plot(f["x_mm"], f["t_us"], "b-", lw=2)
        sc = s["input"]
        load = f"{sc['experiment']['projectile_speed']:g} m/s" if "experiment" in sc else \
            f"edge V_imp = {sc['loading']['v_imp']:g} m/s"
        ax.set(xlabel="x1 [mm]", ylabel="t [µs]",
               title=f"{name.removeprefix('experiment_mode_').removeprefix('mode_')}\n{load}, "
                     f"Σ0 = {sc['loading']['sigma0'] / 1e6:g} MPa: {s['mode']['label']}")
        ax.title.set_fontsize(8)
    fig.tight_layout()
    a.out.mkdir(parents=True, exist_ok=True)
    fig.savefig(a.out / f"modes_{a.preset}.png", dpi=110)
    (a.out / f"modes_{a.preset}.json").write_text(json.dumps(rows, indent=1, default=float) + "\n")
    for n, row in rows.items():
        print(n, row["label"], "|", row["reason"], "| coalescences", row["coalescences"], "| supersonic",
              [round(f["mean_speed_m_s"]) for f in row["second_front"]["fronts"]])
