"""The paper's plain rate-tangent update registered as a law of its own
(``povirk_needleman_rate_tangent``): the Povirk–Needleman parameters and state,
one rate-tangent step per bulk step.  Serial point tests (every rank runs them)."""

import numpy as np
import pytest

from fricfem.friction import LAWS, defaults, get_law, pack, storage, validate
from fricfem.friction import povirk_needleman_rate_tangent as rt
from fricfem.friction.driver import drive_jump_rate, ramp_jump, step_rates

MPa = 1e6
RT = get_law("povirk_needleman_rate_tangent")
PN = get_law("povirk_needleman")


def test_registered_with_the_povirk_needleman_parameters_and_state():
    assert "povirk_needleman_rate_tangent" in LAWS
    assert RT.params == PN.params and RT.state == PN.state
    assert RT.advance is rt.rate_tangent_advance and RT.memo == 0
    assert len(storage(RT, RT.initial_state(pack(RT, defaults(RT)), 1.0, 0.0))) == len(RT.state)


@pytest.mark.parametrize("values, match", [
    ({"m": 0.5}, r"friction\.m = 0\.5: must lie in \[1, 100\]"),
    ({"gamma": 0.25}, r"friction\.gamma = 0\.25: must lie in \[0\.5, 1\]"),
    ({"Dc": 0.4}, r"friction\.Dc: unknown parameter for friction law 'povirk_needleman_rate_tangent'"),
])
def test_parameters_validated(values, match):
    with pytest.raises(ValueError, match=match):
        validate(RT, values)


@pytest.mark.parametrize("dt", [10e-9, 50e-9])
def test_agrees_with_advance_at_small_slip_rates(dt):
    """T_n = 10 MPa, C_s = 1e11 Pa/m, Δu̇_s ramped to 5 m/s over 2 µs and held to
    20 µs: stick, onset (peak ≈ 5.7 m/s), steady sliding at 5 m/s.  The plain
    update follows the converged one to within 1e-3 T_n (measured 1.3e-4 at
    10 ns, 6.8e-4 at 50 ns); at 20 m/s it no longer does (1.4 % and 10 %)."""
    t = np.linspace(0.0, 20e-6, int(round(20e-6 / dt)) + 1)
    vs = step_rates(t, ramp_jump(t, 5.0, 2e-6))
    a = drive_jump_rate(PN, t, vs, 10 * MPa, 1e11)
    b = drive_jump_rate(RT, t, vs, 10 * MPa, 1e11)
    assert a.slip_rate.max() > 5.0 and np.all(np.isfinite(b.Ts))
    assert np.abs(a.Ts - b.Ts).max() < 1e-3 * 10 * MPa
    assert b.slip_rate.max() == pytest.approx(a.slip_rate.max(), rel=0.01)
    assert b.slip_rate[-1] == pytest.approx(5.0, rel=1e-3)


def test_a_scene_runs_with_it(comm, tmp_dir_shared):
    """A scene with friction.law = povirk_needleman_rate_tangent runs (its own
    kernel), and where the update is stable (coarse Case I at 10 m/s, slip rates
    of a few m/s, at a 50 ns step: at the coarse mesh's own 265 ns step it
    diverges at 10.6 µs) it slides where the converged law slides, to within
    1 % in peak slip rate and 0.2 µs in the first slip."""
    from fricfem import load_scene, open_run, runner

    peaks = {}
    for law in ("povirk_needleman", "povirk_needleman_rate_tangent"):
        scene = load_scene("case1", [f"friction.law='{law}'", "mesh.preset='coarse'", "loading.v_imp=10",
                                     "time.end=20e-6", "time.dt=5e-8", "output.fields=[]"])
        assert scene.law == law
        summary = runner.run_scene(scene, tmp_dir_shared / law, comm, quiet=True)
        assert summary["complete"] and summary["initiation"] is not None
        peak = float(open_run(tmp_dir_shared / law).slip_rate.max()) if comm.rank == 0 else None
        peaks[law] = (comm.bcast(peak), summary["initiation"]["time_s"])
    (v0, t0), (v1, t1) = peaks["povirk_needleman"], peaks["povirk_needleman_rate_tangent"]
    assert v0 > 1.0 and v1 == pytest.approx(v0, rel=0.01) and abs(t1 - t0) < 0.2e-6
