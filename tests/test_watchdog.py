"""The watchdog stops a run only on divergence — non-finite values, a negative
discrete kinetic energy, an energy budget that does not close — with a message
that names the likely cause.  Large slip-rate spikes are reported (peak, place,
time) in summary.json, never a stop."""

from __future__ import annotations

import json

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, open_run
from fricfem import runner
from fricfem.model.build import build_model
from fricfem.observe import Spikes, energy_scale
from fricfem.scene import SceneError
from fricfem.step import stepper

COARSE = ["mesh.preset='coarse'", "output.fields=[]"]


def _inject_after(monkeypatch, n_step: int, act) -> None:
    """Run ``act(model, state)`` right after step ``n_step`` (the monitor sees its effect)."""
    step = stepper.step

    def stepped(model, state, energy=None):
        step(model, state, energy)
        if state.n == n_step:
            act(model, state)

    for module in (stepper, runner):  # wherever the run's loop finds ``step``
        if getattr(module, "step", None) is step:
            monkeypatch.setattr(module, "step", stepped)


def test_a_nan_on_one_rank_stops_every_rank(comm, tmp_dir_shared, monkeypatch):
    """A NaN written into the tractions of one rank's points stops the run in the
    step it appears, on every rank, with the non-finite message."""
    def poison(model, state):
        p = state.points
        owner = comm.allreduce(comm.rank if len(p.Ts) else -1, op=MPI.MAX)
        if comm.rank == owner:
            p.Ts[len(p.Ts) // 2] = np.nan

    _inject_after(monkeypatch, 12, poison)
    scene = load_scene("case1", COARSE + ["loading.v_imp=10"])
    summary = runner.run_scene(scene, tmp_dir_shared / "nan", comm, quiet=True)
    assert not summary["complete"] and summary["steps"] == 12
    assert summary["watchdog"].startswith("watchdog stopped the run at t = ")
    assert "non-finite interface tractions or slip rates" in summary["watchdog"]
    assert "the interface update diverged at a stable bulk step" in summary["watchdog"]


def test_an_unstable_step_stops_on_negative_kinetic_energy(comm, tmp_dir_shared):
    """dt = 1.5 × the stable step is refused unless allowed; allowed, it diverges and the
    run stops on the negative kinetic energy, naming the step, keeping its outputs."""
    probe = load_scene("case1", COARSE + ["loading.v_imp=10"])
    _, model = build_model(probe, comm)
    dt = 1.5 * model.dt_crit
    args = COARSE + ["loading.v_imp=10", f"time.dt={dt!r}", "output.energy_every=5"]
    with pytest.raises(SceneError, match="exceeds the stable step"):
        runner.run_scene(load_scene("case1", args), tmp_dir_shared / "refused", comm, quiet=True)
    scene = load_scene("case1", args + ["time.allow_unstable_dt=true"])
    out = tmp_dir_shared / "unstable"
    summary = runner.run_scene(scene, out, comm, quiet=True)
    assert not summary["complete"]
    msg = summary["watchdog"]
    assert "negative discrete kinetic energy" in msg
    assert "1.50 × the stable step" in msg and "time.dt_safety < 1" in msg
    assert summary["steps"] < int(scene.t_end / dt)
    assert summary["energy"]["kinetic"] < 0.0
    if comm.rank == 0:
        assert json.loads((out / "summary.json").read_text())["watchdog"] == msg
        assert (out / "interface.h5").exists()


def test_an_unbooked_force_breaks_the_energy_budget(comm, tmp_dir_shared, monkeypatch):
    """Velocities kicked by 1 % in one step (energy no force in the budget did work
    for) stop the run at the next energy step with the closure message."""
    def kick(model, state):
        state.v.array[:] *= 1.01

    _inject_after(monkeypatch, 20, kick)
    scene = load_scene("case1", COARSE + ["loading.v_imp=10", "output.energy_every=5"])
    summary = runner.run_scene(scene, tmp_dir_shared / "kick", comm, quiet=True)
    assert not summary["complete"] and 20 < summary["steps"] <= 26
    assert "the energy budget does not close" in summary["watchdog"]
    e = summary["energy"]
    assert abs(e["balance_error"]) > 1e-6 * energy_scale(e)


def test_a_slip_rate_far_above_c_l_is_reported_not_stopped(comm, tmp_dir_shared):
    """Case II at 100 m/s on the coarse mesh: the slip rate peaks ~12 × c_l (the
    spring–slider's bounded spike, docs/friction_reference.md §4).  The run is not
    stopped; summary.json reports the peak, its place and time, as recorded in
    interface.h5; the energy budget closes to round-off throughout."""
    scene = load_scene("case2", COARSE + ["loading.v_imp=100", "output.energy_every=1"])
    out = tmp_dir_shared / "spike"
    summary = runner.run_scene(scene, out, comm, quiet=True)
    assert summary["complete"] and summary["watchdog"] is None
    assert summary["mode"]["label"] != "diverged"
    spike = summary["slip_rate_spike"]
    c_l = scene.material.c_l
    assert spike["threshold_m_s"] == pytest.approx(c_l)
    assert spike["above_threshold"] and spike["peak_m_s"] > 5 * c_l and spike["steps_above"] > 0
    assert spike["first_above"]["time_s"] <= spike["time_s"] <= scene.t_end
    if comm.rank == 0:
        assert json.loads((out / "summary.json").read_text())["slip_rate_spike"] == spike
        run = open_run(out)
        rate = run.quantity("slip_rate")  # a snapshot every step on this mesh
        i, q = np.unravel_index(np.argmax(rate), rate.shape)
        assert rate[i, q] == spike["peak_m_s"]
        assert run.t[i] == pytest.approx(spike["time_s"], abs=1e-12)
        assert run.x1[q] == spike["x1_m"]
        e = run.energy
        scale = np.maximum.reduce([np.abs(e["external"]), np.abs(e["kinetic"]) + np.abs(e["strain"]),
                                   np.abs(e["interface_work"]), np.full(len(e["time"]), 1e-12)])
        assert np.all(np.abs(e["balance_error"]) <= 1e-10 * scale)
        assert e["kinetic"].min() >= 0.0


def test_spikes_are_located_across_ranks(comm):
    """The peak's place comes from the rank that holds it; the first crossing of the
    threshold is kept while the peak moves on; NaN is left to the watchdog."""
    from fricfem.kernels.watch import look

    s = Spikes(100.0, comm)
    x1 = np.array([0.01, 0.02]) + 0.1 * comm.rank
    last = comm.size - 1
    for t, rates in ((1e-6, [5.0, 50.0]), (2e-6, [150.0, 0.0]), (3e-6, [0.0, 400.0]), (4e-6, [np.nan, 1.0])):
        mine = np.array(rates) if comm.rank == last else np.zeros(2)
        vmax = comm.allreduce(float(mine.max()), op=MPI.MAX)
        seen = np.empty(5)
        look(x1, mine, np.zeros(2), np.zeros(2), seen)  # the monitor's pass: this rank's largest and its x1
        s.see(vmax, t, (seen[2], seen[4]))
    r = s.report()
    assert r["peak_m_s"] == 400.0 and r["time_s"] == 3e-6 and r["x1_m"] == pytest.approx(0.02 + 0.1 * last)
    assert r["first_above"] == {"time_s": 2e-6, "x1_m": pytest.approx(0.01 + 0.1 * last)}
    assert r["steps_above"] == 2 and r["above_threshold"]
    assert "spike 400 m/s at x1 = " in s.text()
    quiet = Spikes(1e3, comm)
    quiet.see(5.0, 1e-6, (5.0, 0.0))
    assert quiet.text() == "" and not quiet.report()["above_threshold"]


def test_old_watchdog_keys_still_load():
    """Scenes written for the old watchdog (max_slip_rate as a stop, energy_factor)
    load unchanged; the closure bound is the tighter of energy_tol and energy_factor − 1."""
    from fricfem.observe import closure_bound

    old = load_scene("rupture_sw")  # ships [watchdog] max_slip_rate = 5e4, energy_factor = 1.5
    assert old.watchdog["max_slip_rate"] == 5e4 and old.watchdog["energy_factor"] == 1.5
    assert closure_bound(old.watchdog) == 1e-6
    tight = load_scene("case1", ["watchdog.energy_factor=1.000000001"])
    assert closure_bound(tight.watchdog) == pytest.approx(1e-9)
    with pytest.raises(SceneError, match="watchdog.energy_tol = 0.0 : must lie in"):
        load_scene("case1", ["watchdog.energy_tol=0.0"])


def test_look_agrees_with_numpy():
    """The monitor's one pass (kernels.watch.look) gives what NumPy gives: the tip,
    the first sliding, the largest slip rate and the x1 of its first point
    (np.argmax), the finite flag; with ties, all-stuck, a NaN and no points."""
    from fricfem.kernels.watch import look

    rng = np.random.default_rng(5)
    x1 = np.sort(rng.random(40))
    cases = [np.where(rng.random(40) < 0.3, rng.random(40), 0.0) for _ in range(20)]
    cases += [np.zeros(40), np.r_[np.zeros(10), 2.0, 1.0, 2.0, np.zeros(27)], np.r_[1.0, np.nan, np.zeros(38)]]
    for rates in cases:
        out = np.empty(5)
        look(x1, rates, np.zeros(40), np.zeros(40), out)
        slides = rates > 0
        nan = np.isnan(rates).any()
        assert out[0] == (-1.0 if nan or not slides.any() else x1[slides].max())
        assert out[1] == (-np.inf if nan or not slides.any() else -x1[slides].min())
        assert (np.isnan(out[2]) and nan) or out[2] == rates.max()
        if not nan:
            assert out[4] == x1[np.argmax(rates)]
        assert out[3] == float(nan)
    out = np.empty(5)
    look(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), out)
    assert list(out) == [-1.0, -np.inf, 0.0, 0.0, -np.inf]


def test_spikes_place_ties_at_the_first_point(comm):
    """With the monitor's pass, a peak held by several points of a rank is placed at
    the first of them (as np.argmax), on the rank that holds the largest value."""
    from fricfem.kernels.watch import look

    s = Spikes(100.0, comm)
    last = comm.size - 1
    x1 = np.array([0.01, 0.02, 0.03]) + 0.1 * comm.rank
    for t, rates in ((1e-6, [5.0, 50.0, 50.0]), (2e-6, [150.0, 0.0, 150.0]), (3e-6, [0.0, 400.0, 3.0])):
        mine = np.array(rates) * (1.0 + comm.rank)
        seen = np.empty(5)
        look(x1, mine, np.zeros(3), np.zeros(3), seen)
        vmax = comm.allreduce(float(mine.max()), op=MPI.MAX)
        s.see(vmax, t, (seen[2], seen[4]))
        if t == 2e-6:  # the tie of 150·(1 + rank) at the first and third points
            assert s.report()["x1_m"] == pytest.approx(0.01 + 0.1 * last)
    r = s.report()
    assert r["first_above"] == {"time_s": 2e-6, "x1_m": pytest.approx(0.01 + 0.1 * last)}
    assert r["peak_m_s"] == 400.0 * (1 + last) and r["x1_m"] == pytest.approx(0.02 + 0.1 * last)
