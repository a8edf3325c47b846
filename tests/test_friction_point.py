"""The friction laws at one interface point (no finite elements).

Serial and deterministic: under ``mpirun -n 2`` every rank runs the same
checks on its own.  Reference numbers are measured by ``demos/friction_law.py``
and discussed in ``docs/friction.md``.
"""

import numba
import numpy as np
import pytest
from numba.core.caching import NullCache

from fricfem.friction import LAWS, defaults, get_law, pack, validate
from fricfem.friction import povirk_needleman as pn
from fricfem.friction import povirk_needleman_equations as pn_equations
from fricfem.friction import povirk_needleman_integrator as pn_integrator
from fricfem.friction import povirk_needleman_rate_tangent as rt
from fricfem.friction import slip_weakening as sw
from fricfem.friction.driver import drive_jump_rate, drive_slip_rate, ramp_jump, step_rates

MPa = 1e6
PN = get_law("povirk_needleman")
SW = get_law("slip_weakening")
P_PN = pack(PN, defaults(PN))
P_SW = pack(SW, defaults(SW))


def constant_slip(v, slip, ds):
    """Times and per-step rates for sliding at v [m/s] over slip [m], steps of ds [m]."""
    n = int(round(slip / ds))
    return np.linspace(0.0, slip / v, n + 1), np.full(n, v)


def slip_to_63(slip, y):
    """Slip after which y has covered 1 − 1/e of its change (linear interpolation)."""
    change = (y - y[-1]) / (y[0] - y[-1])  # 1 -> 0
    k = int(np.argmax(change <= np.exp(-1.0)))
    f = (change[k - 1] - np.exp(-1.0)) / (change[k - 1] - change[k])
    return slip[k - 1] + f * (slip[k] - slip[k - 1]) - slip[0]


# --- registry, parameters, compilation ---------------------------------------------------


def test_registry_has_the_laws():
    assert {"povirk_needleman", "slip_weakening", "stuck"} <= set(LAWS)
    with pytest.raises(ValueError, match="unknown friction law.*povirk_needleman"):
        get_law("coulomb")


@pytest.mark.parametrize(
    "law, values, match",
    [
        (PN, {"m": 0.5}, r"friction\.m = 0\.5: must lie in \[1, 100\]"),
        (PN, {"L0": -1e-6}, r"friction\.L0 = -1e-06 m: must lie in \[1e-09, 1\] m"),
        (PN, {"gamma": 0.25}, r"friction\.gamma = 0\.25: must lie in \[0\.5, 1\]"),
        (PN, {"V1": float("nan")}, r"friction\.V1 = nan m/s: must lie in"),
        (PN, {"mu_s": "high"}, r"friction\.mu_s: expected a number"),
        (PN, {"Dc": 0.4}, r"friction\.Dc: unknown parameter.*allowed: mu_s"),
        (SW, {"Dc": 0.0}, r"friction\.Dc = 0 m: must lie in \[1e-12, 100\] m"),
    ],
)
def test_parameter_validation_names_key_and_range(law, values, match):
    with pytest.raises(ValueError, match=match):
        validate(law, values)


def test_table1_defaults():
    d = defaults(PN)
    assert (d["mu_s"], d["mu_d"], d["V0"], d["V1"], d["B"], d["p"], d["m"]) == (
        0.6, 0.5, 100.0, 26.0, 4.6, 1.2, 5.0)
    assert d["L0"] == d["L1"] == d["L2"] == 20e-6 and (d["C"], d["D"]) == (0.7, 0.3)
    s0 = PN.initial_state(P_PN, 10 * MPa, 0.0)
    assert s0 == pytest.approx([20e-6 / (10 * 26.0), 7 * MPa, 3 * MPa])


@pytest.mark.parametrize("module", [pn_equations, pn_integrator, sw])
def test_kernels_cached_and_not_fastmath(module):
    """Every numba function of a law is compiled with cache=True, without fastmath."""
    kernels = [f for f in vars(module).values() if isinstance(f, numba.core.registry.CPUDispatcher)
               and f.py_func.__module__ == module.__name__]  # defined here, not imported
    assert kernels
    for f in kernels:
        assert not isinstance(f._cache, NullCache), f.__name__
        assert not f.targetoptions.get("fastmath", False), f.__name__


def test_stuck_law_through_the_driver():
    """The stuck interface: T_s = C_s Δu_s, never slides, has no slip-rate response."""
    law = get_law("stuck")
    t = np.linspace(0.0, 1e-6, 11)
    jump = ramp_jump(t, 100.0, 0.5e-6)
    h = drive_jump_rate(law, t, step_rates(t, jump), 10 * MPa, 1e11)
    assert np.allclose(h.Ts, 1e11 * jump, rtol=1e-12, atol=1e-6)
    assert not h.slip.any() and not h.slip_rate.any()
    with pytest.raises(ValueError, match="stuck.*no imposed-slip-rate"):
        drive_slip_rate(law, t, np.ones(10), 10 * MPa)


# --- steady state --------------------------------------------------------------------------


@pytest.mark.parametrize("v", [0.3, 5.0, 26.0, 100.0, 700.0])
def test_pn_steady_state_imposed_slip_rate(v):
    """Sliding at constant v from the initial state ends at the closed-form μ_ss."""
    Tn = 10 * MPa
    t, rates = constant_slip(v, 2e-3, 2e-6)  # 100 L1, 460 L0/B
    h = drive_slip_rate(PN, t, rates, Tn)
    assert abs(h.mu[-1] - PN.steady_mu(P_PN, v)) < 1e-6
    assert h.state[-1, 0] == pytest.approx(P_PN[pn.L0] / v, rel=1e-6)


@pytest.mark.parametrize("v", [1.0, 10.0, 100.0])
def test_pn_steady_state_elastic_interface(v):
    """``advance`` under a constant jump rate settles to v and μ_ss(v) (T_n = 1 MPa,
    where the elastic point is stable), from the initial state."""
    Tn, dt = 1 * MPa, 20e-9
    slip = 3e-3 if v < 10 else 6e-3
    t = np.linspace(0.0, slip / v, int(round(slip / v / dt)) + 1)
    h = drive_jump_rate(PN, t, np.full(len(t) - 1, v), Tn, 1e11)
    assert abs(h.mu[-1] - PN.steady_mu(P_PN, v)) < 1e-6
    assert h.slip_rate[-1] == pytest.approx(v, rel=1e-6)
    # steady sliding: sub-steps only from h C_s ∂v/∂|T_s| <= substep_stiff
    # (∂v/∂|T_s| = m V0 β^(m−1) / (g(θ0)(θ1 + θ2)))
    beta = (1 + v / P_PN[pn.V0]) ** (1 / P_PN[pn.M])
    stiff = 1e11 * P_PN[pn.M] * P_PN[pn.V0] * beta ** (P_PN[pn.M] - 1) / (h.Ts[-1] / beta)
    assert h.nsub[-1] <= 2 + dt * stiff / P_PN[pn.SUB_STIFF]


def test_slip_weakening_imposed_slip():
    """μ = μs at rest, falls linearly over Dc, then μd."""
    Tn, Dc = 10 * MPa, P_SW[sw.DC]
    t, rates = constant_slip(1.0, 2 * Dc, Dc / 100)
    h = drive_slip_rate(SW, t, rates, Tn)
    mu_s, mu_d = P_SW[sw.MU_S], P_SW[sw.MU_D]
    assert h.mu[0] == pytest.approx(mu_s, abs=1e-12)
    expected = mu_s - (mu_s - mu_d) * np.minimum(h.slip, Dc) / Dc
    assert np.abs(h.mu - expected).max() < 1e-6
    assert h.mu[-1] == pytest.approx(mu_d, abs=1e-12)
    assert SW.steady_mu(P_SW, 1.0) == mu_d and SW.steady_mu(P_SW, 0.0) == mu_s


def test_slip_weakening_return_map():
    """Elastic loading to μs T_n, then |T_s| = μ(δ) T_n at every step end; μd after Dc."""
    Tn, Cs, vs = 10 * MPa, 1e11, 10.0
    Dc = 1e-3
    prm = dict(Dc=Dc)
    t = np.linspace(0.0, 4e-4, 4001)
    h = drive_jump_rate(SW, t, np.full(4000, vs), Tn, Cs, params=prm)
    p = pack(SW, validate(SW, prm))
    stick = h.slip == 0.0
    assert np.allclose(h.Ts[stick], Cs * vs * t[stick])
    mu = np.array([sw.mu(p, d) for d in h.slip[~stick]])
    assert np.abs(np.abs(h.Ts[~stick]) - mu * Tn).max() < 1e-6 * Tn
    assert h.slip[-1] > Dc and h.mu[-1] == pytest.approx(p[sw.MU_D], abs=1e-12)
    assert h.slip_rate[-1] == pytest.approx(vs, rel=1e-9)


# --- transients: direct effect, evolution distances ----------------------------------------


def _rate_step(v_a, v_b, L0, ds=5e-9):
    """μ = T_s/T_n across a step v_a -> v_b from steady sliding (imposed slip rate)."""
    prm = dict(L0=L0)
    p = pack(PN, validate(PN, prm))
    Tn = 10 * MPa
    n_a, n_b = 100, int(round(60 * L0 / ds))
    rates = np.concatenate((np.full(n_a, v_a), np.full(n_b, v_b)))
    t = np.concatenate(([0.0], np.cumsum(ds / rates)))
    h = drive_slip_rate(PN, t, rates, Tn, params=prm, state0=pn.steady_state(p, v_a, Tn))
    return h.slip[n_a:], h.mu[n_a:]  # from the last sample before the step


def test_direct_effect_sign():
    """A step up in slip rate raises T_s/T_n at once, then it decays below the
    old value to μ_ss(v_b); a step down does the opposite."""
    L0 = P_PN[pn.L0]
    for v_a, v_b in ((1.0, 10.0), (10.0, 1.0)):
        slip, mu = _rate_step(v_a, v_b, L0)
        up = v_b > v_a
        direct = mu[1] - mu[0]
        assert (direct > 0) == up
        # the instantaneous jump: |T_s| ∝ (1 + v/V0)^(1/m) at fixed state
        factor = ((1 + v_b / P_PN[pn.V0]) / (1 + v_a / P_PN[pn.V0])) ** (1 / P_PN[pn.M])
        assert mu[1] / mu[0] == pytest.approx(factor, rel=1e-3)
        assert abs(mu[-1] - PN.steady_mu(P_PN, v_b)) < 1e-6
        assert (mu[-1] < mu[0]) == up  # velocity weakening in steady state


def test_rate_step_relaxation_scales_with_L0():
    """Doubling L0 doubles the slip over which μ relaxes after a rate step."""
    d1 = slip_to_63(*_rate_step(1.0, 10.0, 20e-6))
    d2 = slip_to_63(*_rate_step(1.0, 10.0, 40e-6))
    assert 5e-6 < d1 < 30e-6
    assert d2 / d1 == pytest.approx(2.0, rel=2e-3)


def _normal_step(L, Tn_a=30 * MPa, Tn_b=20 * MPa, v=10.0, ds=5e-9):
    """T_s across a step T_n_a -> T_n_b at constant slip rate, L1 = L2 = L."""
    prm = dict(L1=L, L2=L)
    p = pack(PN, validate(PN, prm))
    n_a, n_b = 100, int(round(15 * L / ds))
    t = np.concatenate(([0.0], np.arange(1, n_a + 1) * ds / v))
    t = np.concatenate((t, t[-1] + np.arange(0, n_b + 1) * ds / v))  # zero-length step
    Tn = np.where(np.arange(len(t)) <= n_a, Tn_a, Tn_b)
    h = drive_slip_rate(PN, t, np.full(len(t) - 1, v), Tn, params=prm,
                        state0=pn.steady_state(p, v, Tn_a))
    return h, n_a


def test_normal_step_gradual_shear_and_jump_in_mu():
    """Prakash–Clifton: T_s is continuous across a step in T_n, T_s/T_n jumps,
    and T_s reaches μ_ss T_n_new after a few L1."""
    h, k = _normal_step(20e-6)
    assert h.Ts[k + 1] == pytest.approx(h.Ts[k], rel=1e-12)
    assert h.mu[k + 1] == pytest.approx(h.mu[k] * 30 / 20, rel=1e-12)
    assert abs(h.mu[-1] - PN.steady_mu(P_PN, 10.0)) < 1e-6


def test_normal_step_relaxation_scales_with_L1_L2():
    """T_s follows T_n over the slip L1 = L2 (exactly, at constant slip rate)."""
    for L in (20e-6, 40e-6):
        h, k = _normal_step(L)
        assert slip_to_63(h.slip[k + 1:], h.Ts[k + 1:]) == pytest.approx(L, rel=1e-3)


# --- time integration ------------------------------------------------------------------------


def _smooth(dt, gamma):
    """Steady sliding at 10 m/s under 1 MPa, then Δu̇_s ramped to 100 m/s and T_n to
    0.7 MPa over 1 µs; 2 µs in all."""
    t = np.linspace(0.0, 2e-6, int(round(2e-6 / dt)) + 1)
    vs = step_rates(t, 10.0 * t + ramp_jump(t, 90.0, 1e-6))
    Tn = MPa * (1.0 - 0.3 * np.minimum(t / 1e-6, 1.0))
    prm = dict(gamma=gamma)
    return drive_jump_rate(PN, t, vs, Tn, 1e11, params=prm, Ts0=PN.steady_mu(P_PN, 10.0) * MPa,
                           state0=pn.steady_state(P_PN, 10.0, MPa))


@pytest.mark.parametrize("gamma, order", [(0.5, 2.0), (1.0, 1.0)])
def test_point_integrator_converges_in_dt(gamma, order):
    """Errors against a 1/32 ns run at dt = 4, 2, 1 ns: observed order 2.0–2.1
    for γ = 1/2 (trapezoidal, the default) and 1.0 for γ = 1 (backward Euler);
    max error / T_n at 1 ns: 3.4e-7 (γ = 1/2), 1.3e-4 (γ = 1)."""
    fine = _smooth(1e-9 / 32, gamma)
    errs = []
    for dt in (4e-9, 2e-9, 1e-9):
        h = _smooth(dt, gamma)
        errs.append(np.abs(h.Ts - fine.Ts[:: int(round(dt * 32e9))]).max() / MPa)
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - order) < 0.2), orders
    assert errs[-1] < (1e-6 if gamma == 0.5 else 3e-4)


def _stiffness(dt, advance=None):
    """T_n = 30 MPa, C_s = 1e11 Pa/m, Δu̇_s ramped 0 -> 700 m/s over 2 µs, then held."""
    t = np.linspace(0.0, 4e-6, int(round(4e-6 / dt)) + 1)
    vs = step_rates(t, ramp_jump(t, 700.0, 2e-6))
    return drive_jump_rate(PN, t, vs, 30 * MPa, 1e11, advance=advance)


@pytest.fixture(scope="module")
def stiffness_reference():
    return _stiffness(0.1e-9)


@pytest.mark.parametrize("dt, tol", [(50e-9, 0.01), (10e-9, 0.005)])
def test_stiffness_experiment(stiffness_reference, dt, tol):
    """At the bulk step the point stays finite and within tol · T_n of the 0.1 ns
    reference over the stick, the fast slip event (peak ~1e5 m/s) and sliding at
    700 m/s (measured: 0.56 % at 50 ns, 0.20 % at 10 ns)."""
    ref = stiffness_reference
    h = _stiffness(dt)
    assert np.all(np.isfinite(h.Ts)) and np.all(np.isfinite(h.state))
    assert ref.slip_rate.max() > 1e4  # the event is there
    err = np.abs(h.Ts - ref.Ts[:: int(round(dt / 0.1e-9))]).max() / (30 * MPa)
    assert err < tol
    assert h.mu[-1] == pytest.approx(PN.steady_mu(P_PN, 700.0), abs=1e-6)
    assert h.slip_rate[-1] == pytest.approx(700.0, rel=1e-4)


def test_plain_rate_tangent_fails_where_advance_does_not():
    """The paper's single rate-tangent step per bulk step breaks down in the
    stiffness experiment at 50 ns (θ0 driven negative in the slip event)."""
    h = _stiffness(50e-9, rt.rate_tangent_advance)
    assert not (np.all(np.isfinite(h.Ts)) and np.all(h.state[:, 0] > 0))


def test_advance_contract_outputs():
    """Slip rate, slip, work >= 0, sub-steps >= 1; a sign reversal of the jump
    rate reverses T_s and the slip follows sgn(T_s)."""
    t = np.linspace(0.0, 3e-6, 301)
    vs = np.where(t[1:] <= 1e-6, 150.0, -150.0)
    h = drive_jump_rate(PN, t, vs, 10 * MPa, 1e11)
    assert np.all(h.slip_rate >= 0) and np.all(np.diff(h.slip) >= 0)
    assert np.all(np.diff(h.work) >= 0) and np.all(h.nsub[1:] >= 1)
    assert h.Ts[100] > 0 and h.Ts[-1] < 0
    assert -h.Ts[-1] / (10 * MPa) == pytest.approx(PN.steady_mu(P_PN, 150.0), abs=1e-6)


@pytest.mark.parametrize("law", [PN, SW])
def test_energy_balance(law):
    """Work of the jump = interface elastic energy T_s²/(2 C_s) + frictional work,
    per step with the mean traction (exact up to the sub-step splitting)."""
    Cs = 1e11
    t = np.linspace(0.0, 2e-6, 201)
    vs = step_rates(t, ramp_jump(t, 100.0, 1e-6))
    prm = dict(Dc=20e-6) if law is SW else {}
    h = drive_jump_rate(law, t, vs, 10 * MPa, Cs, params=prm)
    w_ext = np.sum(0.5 * (h.Ts[1:] + h.Ts[:-1]) * vs * np.diff(t))
    stored = h.Ts[-1] ** 2 / (2 * Cs)
    assert h.work[-1] > 0.5 * w_ext
    assert w_ext == pytest.approx(stored + h.work[-1], rel=1e-4)
