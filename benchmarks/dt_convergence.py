# # Convergence in the time step, with friction
#
# The interface law is stiff (β^m with m = 5, C_s = 10¹¹ Pa/m); fricfem
# integrates it inside each bulk step with adaptive implicit sub-steps, so the
# result must not depend on the bulk step.  This study runs a crack-like case
# (Case I loading at V_imp = 10 m/s) and a pulse case (Case III: Σ0 = 10 MPa,
# V_imp = 20 m/s) on the reference mesh at dt = 0.9, 0.45 and 0.225 of the
# stable step, and compares against the smallest step:
#
# - the slip-rate history at the station x1 = 16.1 mm (every step; L2 over
#   time, relative to its peak),
# - the peak slip rate over the run, and the leading-tip position at 32 µs.
#
# Run: `mpirun -n 2 .venv/bin/python benchmarks/dt_convergence.py [--preset reference]`;
# writes `benchmarks/results/dt_convergence.json` and `.png`.

import argparse
import json
import logging
from pathlib import Path

import h5py
import numpy as np
from mpi4py import MPI

from fricfem import load_scene
from fricfem import runner

logging.getLogger().setLevel(logging.WARNING)
ap = argparse.ArgumentParser()
ap.add_argument("--preset", default="reference")
ap.add_argument("--work", default="runs/dt_convergence")
ap.add_argument("--out", default="benchmarks/results")
a = ap.parse_args()
comm = MPI.COMM_WORLD
CASES = {"case1_v10": ("case1", ["loading.v_imp=10"]), "case3": ("case3", [])}
SAFETY = [0.9, 0.45, 0.225]

results = {}
for label, (base, extra) in CASES.items():
    hist = {}
    for s in SAFETY:
        scene = load_scene(base, extra + [f"time.dt_safety={s}", "output.fields=[]", "time.end=34e-6",
                                            f"mesh.preset='{a.preset}'"])
        d = Path(a.work) / f"{label}_s{s}"
        summ = runner.run_scene(scene, d, comm, overwrite=True, quiet=True)
        if comm.rank == 0:
            with h5py.File(d / "interface.h5", "r") as f:
                st = f["stations/x16.1mm"]
                n = st.attrs["n"]
                k = int(np.argmin(np.abs(f["time"][: f.attrs["n_time"]] - 32e-6)))
                rate = f["slip_rate"][k]
                hist[s] = {"t": st["time"][:n], "v": st["slip_rate"][:n], "dt": summ["dt_s"],
                           "peak": float(f["slip_rate"][: f.attrs["n_time"]].max()),
                           "tip32": float(f["x1"][rate > 0].max()) if (rate > 0).any() else float("nan"),
                           "us_per_step": summ["us_per_step"]}
    if comm.rank == 0:
        ref = hist[SAFETY[-1]]
        rows = []
        for s in SAFETY:
            h = hist[s]
            v = np.interp(ref["t"], h["t"], h["v"])
            err = float(np.sqrt(np.mean((v - ref["v"]) ** 2)) / max(ref["v"].max(), 1e-12))
            rows.append({"dt_safety": s, "dt_ns": h["dt"] * 1e9, "station_L2_rel": err,
                         "peak_m_s": h["peak"], "tip32_mm": h["tip32"] * 1e3,
                         "station_peak_m_s": float(h["v"].max()), "us_per_step": h["us_per_step"]})
        results[label] = {"rows": rows, "curves": {str(s): {"t": hist[s]["t"][::5].tolist(),
                                                              "v": hist[s]["v"][::5].tolist()} for s in SAFETY}}

if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    fig, axs = plt.subplots(1, len(results), figsize=(6 * len(results), 4))
    for ax, (label, res) in zip(np.atleast_1d(axs), results.items()):
        for s, c in res["curves"].items():
            ax.plot(np.array(c["t"]) * 1e6, c["v"], label=f"dt = {s} × stable")
        ax.set_title(f"{label}: slip rate at x1 = 16.1 mm")
        ax.set_xlabel("t [µs]")
        ax.set_ylabel("Δu̇_slip [m/s]")
        ax.legend()
    fig.tight_layout()
    fig.savefig(out / "dt_convergence.png", dpi=110)
    (out / "dt_convergence.json").write_text(json.dumps(
        {k: v["rows"] for k, v in results.items()} | {"preset": a.preset}, indent=2))
    print(f"{'case':10s} {'dt/stable':>9s} {'dt ns':>7s} {'station L2':>10s} {'peak m/s':>9s} "
          f"{'station pk':>10s} {'tip32 mm':>8s}")
    for label, res in results.items():
        for r in res["rows"]:
            print(f"{label:10s} {r['dt_safety']:9.3f} {r['dt_ns']:7.1f} {r['station_L2_rel']:10.2e} "
                  f"{r['peak_m_s']:9.1f} {r['station_peak_m_s']:10.1f} {r['tip32_mm']:8.2f}")
