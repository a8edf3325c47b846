# %% [markdown]
# # fricfem from Python: a scene, a run, its arrays — and a friction law of your own
#
# A literate script (jupytext "percent" format: open it as a notebook with
# `jupytext --to notebook demos/api_tour.py`, or run it as it is):
#
#     mpirun -n 2 .venv/bin/python demos/api_tour.py [--mesh reference] [--out DIR]
#
# It loads the paper's Case I at an edge velocity of 10 m/s, runs it, reads the
# run directory back as arrays with units, plots the slip rate along the
# interface at chosen times and a gauge inside the lower plate, then registers
# a Coulomb law (in under 30 lines) and runs the same scene with it.
# The default mesh is `coarse` (seconds); `--mesh reference` is the paper's.
# docs/api.md describes every call used here.

# %%
import argparse
import json
from pathlib import Path

import numba
import numpy as np
from matplotlib.figure import Figure
from mpi4py import MPI

import fricfem

parser = argparse.ArgumentParser(description="a tour of fricfem's Python API")
parser.add_argument("--mesh", default="coarse", help="mesh preset (coarse, reference, half, fine)")
parser.add_argument("--out", default="demos/output/api_tour", help="output folder")
args, _ = parser.parse_known_args()  # a notebook kernel passes arguments of its own
out = Path(args.out)
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# ## 1. A scene
# `load_scene` takes a shipped scene (or a .toml file) and `--set`-style
# overrides, and checks every key before anything heavy happens.  Here: Case I
# struck at 10 m/s, to 30 µs, with a strain gauge and vibrometer point 20 mm
# from the struck edge, 12.5 mm below the interface.

# %%
common = [f"mesh.preset='{args.mesh}'", "loading.v_imp=10.0", "time.end=30e-6", "output.fields=[]"]
scene = fricfem.load_scene("case1", common + ["output.gauges={SG=[0.020, -0.0125]}"])
if rank0:
    print(f"{scene.name}: Σ0 = {scene.sigma0 / 1e6:g} MPa, V_imp = {scene.pulse.v_imp:g} m/s, "
          f"law {scene.law}, c_l = {scene.material.c_l:.0f} m/s")

# %% [markdown]
# ## 2. The run
# `run` writes the run directory (collective under MPI) and returns its record.

# %%
summary = fricfem.run(scene, out / "case1_v10", overwrite=True)
if rank0:
    print("mode:", summary["mode"]["label"], "| sliding from", summary["initiation"])

# %% [markdown]
# ## 3. Its arrays, with units
# `open_run` reads a run directory (also one still running, or killed):
# `t` [s], `x1` [m], every interface quantity as `[n_t, n_x]`, `units`.

# %%
run = fricfem.open_run(out / "case1_v10")
times = (15e-6, 20e-6, 25e-6, 30e-6)  # s
profiles = {t: run.profile("slip_rate", t) for t in times}  # the stored rows nearest to these times
if rank0:
    print(f"slip_rate: {run.slip_rate.shape} [{run.units['slip_rate']}] over {len(run.t)} rows of t "
          f"[{run.units['t']}]; gauges: {run.gauges.names}")

# %% [markdown]
# ## 4. Slip rate along the interface at chosen times, and the gauge

# %%
if rank0:
    fig = Figure(figsize=(9.0, 3.4))
    ax, axg = fig.subplots(1, 2)
    for t, rate in profiles.items():
        ax.plot(run.x1 * 1e3, rate, label=f"{run.t[run.at(t)] * 1e6:.3g} µs")
    ax.set(xlabel="$x_1$ [mm]", ylabel=f"slip rate [{run.units['slip_rate']}]", xlim=(0, 60))
    ax.legend(fontsize=8)
    g = run.gauges["SG"]
    axg.plot(g.velocity_time * 1e6, g.velocity[:, 0], label="$v_1$ [m/s]")
    axg.plot(g.time * 1e6, g.stress_difference / 1e6, label=r"$\sigma_1-\sigma_2$ [MPa]")
    axg.set(xlabel="t [µs]", title=f"gauge SG at ({g.x1 * 1e3:g}, {g.x2 * 1e3:g}) mm")
    axg.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "slip_rate_and_gauge.png", dpi=110)

# %% [markdown]
# ## 5. A friction law of your own
# A law is a `fricfem.friction.Law` on the contract of
# `fricfem/friction/base.py` (docs/api.md): `advance` integrates one interface
# point over one step.  Coulomb friction with a constant coefficient, by an
# elastic predictor and a return map:

# %%
from fricfem.friction import Law, Param, frictional_work  # noqa: E402


@numba.njit
def coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    trial = Ts + Cs * vs * dt  # the interface spring, if it sticks
    strength = p[0] * Tn1  # μ T_n at the end of the step
    if abs(trial) <= strength:
        return trial, 0.0, 0.0, 0.0, 1
    dslip = (abs(trial) - strength) / Cs  # the slip that brings T_s back to the strength
    Ts1 = strength if trial > 0 else -strength
    return Ts1, dslip / dt, dslip, frictional_work(Ts, Ts1, dslip), 1


@numba.njit
def coulomb_mu(p, v):
    return p[0]


COULOMB = Law(name="coulomb", doc="Coulomb friction with a constant coefficient", state=(),
              params=(Param("mu", 0.55, "", 0.0, 5.0, "friction coefficient"),),
              advance=coulomb_advance, steady_mu=coulomb_mu, initial_state=lambda p, Tn0, Ts0: np.zeros(0))
fricfem.register_law(COULOMB, replace=True)  # replace: a notebook may run this cell again

# %% [markdown]
# The law is now a `friction.law` like the shipped ones; its parameters are
# `friction.params.<name>`, checked against their ranges.

# %%
mine = fricfem.load_scene("case1", common + ["friction.law='coulomb'", "friction.params.mu=0.5"])
summary_mine = fricfem.run(mine, out / "case1_v10_coulomb", overwrite=True)
coulomb = fricfem.open_run(out / "case1_v10_coulomb")
sliding = coulomb.slip_rate > 0
ratio = np.abs(coulomb.shear_traction[sliding]) / coulomb.normal_traction[sliding]  # = μ where it slides
result = {
    "mesh": args.mesh,
    "case1_v10": {"mode": summary["mode"]["label"], "initiation_s": summary["initiation"]["time_s"]},
    "coulomb_mu_0.5": {"mode": summary_mine["mode"]["label"], "initiation_s": summary_mine["initiation"]["time_s"],
                       "sliding_Ts_over_Tn": [float(ratio.min()), float(ratio.max())]},
}
if rank0:
    print(json.dumps(result, indent=1))
    (out / "api_tour.json").write_text(json.dumps(result, indent=1))
