"""The watchdog stops a diverging run with a message that names the likely cause."""

from __future__ import annotations

import json

import pytest

from fricfem import load_scene
from fricfem import runner
from fricfem.model.build import build_model
from fricfem.scene import SceneError


def test_watchdog_stops_an_unstable_step(comm, tmp_dir_shared):
    """dt = 1.5 × the stable step diverges; the run stops with the watchdog's message,
    keeps its outputs, and says it is incomplete."""
    probe = load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=10"])
    _, model = build_model(probe, comm)
    dt = 1.5 * model.dt_crit
    args = ["mesh.preset='coarse'", "loading.v_imp=10", f"time.dt={dt!r}", "output.fields=[]",
            "output.energy_every=5"]
    with pytest.raises(SceneError, match="exceeds the stable step"):
        runner.run_scene(load_scene("case1", args), tmp_dir_shared / "refused", comm, quiet=True)
    scene = load_scene("case1", args + ["time.allow_unstable_dt=true"])
    out = tmp_dir_shared / "unstable"
    summary = runner.run_scene(scene, out, comm, quiet=True)
    assert not summary["complete"]
    msg = summary["watchdog"]
    assert msg.startswith("watchdog stopped the run at t = ")
    assert "1.50 × the stable step" in msg and "time.dt_safety < 1" in msg
    assert summary["steps"] < int(scene.t_end / dt)
    if comm.rank == 0:
        assert json.loads((out / "summary.json").read_text())["watchdog"] == msg
        assert (out / "interface.h5").exists()


def test_runaway_slip_rate_is_stopped_with_the_law_criterion(comm, tmp_dir_shared):
    """Σ0 = 30 MPa struck at 100 m/s: |T_s| passes m·L0·C_s = 10 MPa and the law's slip
    rate runs away; the watchdog stops the run at c_l and names the criterion."""
    scene = load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=100", "loading.sigma0=30e6",
                                  "output.fields=[]"])
    summary = runner.run_scene(scene, tmp_dir_shared / "runaway", comm, quiet=True)
    assert not summary["complete"]
    assert "slip rate beyond the bound" in summary["watchdog"]
    assert "m·L0·C_s = 10 MPa" in summary["watchdog"]


def test_stable_run_is_not_stopped(comm, tmp_dir_shared):
    scene = load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=40", "loading.sigma0=24e6",
                                  "output.fields=[]", "time.end=20e-6"])
    summary = runner.run_scene(scene, tmp_dir_shared / "stable", comm, quiet=True)
    assert summary["complete"] and summary["watchdog"] is None
