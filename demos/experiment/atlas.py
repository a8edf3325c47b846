# # Slip-rate histories of the experiment sweep, one panel per run (`sweep.py`'s runs)
#
# Run after `sweep.py`: `.venv/bin/python demos/experiment/atlas.py [--preset reference]`
# Writes benchmarks/results/experiment/atlas_<preset>.png: log10 of the slip rate over x1 and t,
# each panel titled with the projectile speed, Σ0 and the classifier's label.

import json
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

sys.path.insert(0, str(Path(__file__).parent))
import common  # noqa: E402

from fricfem import open_run  # noqa: E402

a = common.options("runs/experiment_sweep").parse_args()
rows = json.loads((a.out / f"sweep_{a.preset}.json").read_text())["rows"]
speeds = sorted({r["v_projectile_m_s"] for r in rows})
sigmas = sorted({r["sigma0_Pa"] for r in rows})
fig = Figure(figsize=(2.3 * len(speeds), 2.2 * len(sigmas)))
axes = np.atleast_2d(fig.subplots(len(sigmas), len(speeds), sharex=True, sharey=True))
for r in rows:
    i, j = sigmas.index(r["sigma0_Pa"]), speeds.index(r["v_projectile_m_s"])
    run = open_run(a.work / f"v{r['v_projectile_m_s']:g}_s{r['sigma0_Pa'] / 1e6:g}")
    ax = axes[i, j]
    sr = np.log10(np.maximum(run.slip_rate, 1e-2))
    ax.pcolormesh(run.x1 * 1e3, run.t * 1e6, sr, shading="auto", cmap="magma_r", vmin=-2,
                  vmax=max(math.log10(max(run.slip_rate.max(), 1.0)), -1))
    sf = r["second_front"]["count"]
    ax.set_title(f"{r['v_projectile_m_s']:g} m/s, {r['sigma0_Pa'] / 1e6:g} MPa\n{r['mode']}"
                 f"{', supersonic trailing' if sf else ''}", fontsize=7)
for ax in axes[-1]:
    ax.set_xlabel("x1 [mm]")
for ax in axes[:, 0]:
    ax.set_ylabel("t [µs]")
fig.tight_layout()
fig.savefig(a.out / f"atlas_{a.preset}.png", dpi=100)
