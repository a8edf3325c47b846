"""The slip-weakening rupture scene (``rupture_sw``): its parameters, a coarse run
that nucleates at the patch, spreads both ways at a plausible speed and stops at
the barriers, and the work-precision benchmark in smoke mode.  Run under
``mpirun -n 2`` (every rank runs every test)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fricfem import load_scene
from fricfem import runner

ROOT = Path(__file__).resolve().parents[1]
THRESHOLD = 1e-3  # m/s: rupture time = first time the slip rate exceeds this


def test_rupture_scene_validates():
    """Plane strain, no impact, τ_d < τ0 < τ_s, an overstressed patch, locked
    barriers, a fine band along the whole interface, a resolved cohesive zone."""
    scene = load_scene("rupture_sw")
    mat, p, s0 = scene.material, scene.params, scene.sigma0
    assert mat.plane == "strain" and scene.pulse.v_imp == 0.0 and scene.law == "slip_weakening"
    assert p["mu_d"] * s0 < scene.tau0 < p["mu_s"] * s0
    (patch,) = scene.tau0_patches
    assert patch["tau0"] > p["mu_s"] * s0
    centre = 0.5 * (patch["x1_min"] + patch["x1_max"])
    assert abs(centre - 0.5 * scene.mesh.length) < 0.1 * scene.mesh.length
    assert len(scene.regions) == 2
    for reg in scene.regions:
        assert reg["params"]["mu_s"] * s0 > 5 * patch["tau0"]  # locked
    ends = sorted((r["x1_min"], r["x1_max"]) for r in scene.regions)
    assert ends[0][0] == 0.0 and ends[1][1] == scene.mesh.length
    assert scene.mesh.fine_x0 == 0.0 and scene.mesh.fine_x1 == scene.mesh.length
    # cohesive zone Λ0 ≈ (9π/32) μ Dc / ((μs − μd) Σ0), several cells; no snap-back
    drop = (p["mu_s"] - p["mu_d"]) * s0
    lam0 = 9 * math.pi / 32 * mat.mu * p["Dc"] / drop
    assert lam0 >= 5 * scene.mesh.dx
    assert scene.Cs * p["Dc"] > 5 * drop
    assert mat.mu / scene.Cs < 0.25 * lam0  # the interface compliance is below the cohesive zone
    for x in scene.output["stations"].values():
        assert 0.0 <= x <= scene.mesh.length


def _rupture_times(path: Path) -> dict:
    """name -> (x1, rupture time or NaN) from the station histories; plus the final slip profile."""
    import h5py

    with h5py.File(path / "interface.h5", "r") as f:
        out = {}
        for name, g in f["stations"].items():
            n = int(g.attrs["n"])
            v = g["slip_rate"][:n]
            k = np.flatnonzero(v > THRESHOLD)
            out[name] = (float(g.attrs["x1"]), float(g["time"][k[0]]) if len(k) else float("nan"))
        n = int(f.attrs["n_time"])
        return out, f["x1"][:], f["slip"][n - 1]


def test_coarse_rupture_spreads_both_ways_and_stops_at_the_barriers(comm, tmp_dir_shared):
    scene = load_scene("rupture_sw", ["mesh.dx=0.4e-3", "mesh.dy=0.4e-3", "time.end=30e-6"])
    summary = runner.run_scene(scene, tmp_dir_shared / "rupture", comm, overwrite=True, quiet=True)
    assert summary["complete"] and summary["watchdog"] is None
    data = _rupture_times(tmp_dir_shared / "rupture") if comm.rank == 0 else None
    stations, x1, slip = comm.bcast(data, root=0)

    (patch,) = scene.tau0_patches
    dx = scene.mesh.dx
    init = summary["initiation"]
    assert init["time_s"] < 1e-6
    assert patch["x1_min"] - dx <= init["x1_m"] and init["x1_max_m"] <= patch["x1_max"] + dx

    centre = 0.5 * (patch["x1_min"] + patch["x1_max"])
    c_R, c_s = scene.material.c_R, scene.material.c_s
    b_lo = max(r["x1_max"] for r in scene.regions if r["x1_min"] == 0.0)
    b_hi = min(r["x1_min"] for r in scene.regions if r["x1_max"] == scene.mesh.length)
    for sgn in (-1.0, 1.0):
        side = sorted((sgn * (x - centre), t) for x, t in stations.values()
                      if sgn * (x - centre) > patch["x1_max"] - centre and b_lo < x < b_hi)
        r, t = np.array(side).T
        assert np.isfinite(t).all(), side  # every station between the patch and the barrier breaks
        assert (np.diff(t) > 0).all(), side  # in order of distance from the patch
        speed = np.polyfit(t, r, 1)[0]
        assert 0.3 * c_R < speed < 1.7 * c_s, (sgn, speed)
    # the barriers hold: no slip inside them beyond one cell of their edge, stations there never break
    assert np.all(slip[(x1 < b_lo - dx) | (x1 > b_hi + dx)] == 0.0)
    for x, t in stations.values():
        if x < b_lo or x > b_hi:
            assert math.isnan(t), (x, t)
    # and the rupture did reach them: slip right next to both barriers
    assert slip[(x1 > b_lo) & (x1 < b_lo + 2 * dx)].max() > 0.0
    assert slip[(x1 < b_hi) & (x1 > b_hi - 2 * dx)].max() > 0.0


def test_work_precision_benchmark_smoke(comm, tmp_dir_shared):
    """benchmarks/work_precision.py --smoke writes its JSON and figure, errors shrink under refinement."""
    import work_precision as bench  # benchmarks/ is on pytest's pythonpath

    data = bench.main(["--smoke", "--out", str(tmp_dir_shared / "out"), "--work", str(tmp_dir_shared / "work")],
                      comm)
    rows = data["problems"]["rupture_sw"]["rows"]
    assert len(rows) == 4 and sum(r["reference"] for r in rows) == 1
    coarse = [r for r in rows if r["level"] == "dx1.6mm"]
    assert all(r["station_L2"] > 0 and np.isfinite(r["station_L2"]) for r in coarse)
    finer = next(r for r in rows if r["level"] == "dx0.8mm" and not r["reference"])
    assert finer["station_L2"] < min(r["station_L2"] for r in coarse)
    if comm.rank == 0:
        assert (tmp_dir_shared / "out" / "work_precision_smoke.json").stat().st_size > 0
        assert (tmp_dir_shared / "out" / "work_precision_smoke_rupture_sw.png").stat().st_size > 0
