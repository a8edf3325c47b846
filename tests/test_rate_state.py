"""The regularized rate-and-state laws (aging and slip) at one point.

Serial and deterministic: under ``mpirun -n 2`` every rank runs the same
checks.  The closed forms below are written here from the equations
(docs/friction_reference.md), independently of fricfem/friction/rate_state.py.
"""

import math

import numba
import numpy as np
import pytest
from numba.core.caching import NullCache

from fricfem.friction import LAWS, defaults, get_law, pack, validate
from fricfem.friction import rate_state as rs
from fricfem.friction import rate_state_aging, rate_state_slip
from reference import laws as ref
from fricfem.friction.base import storage
from fricfem.friction.driver import drive_jump_rate, drive_slip_rate

MPa = 1e6
AG = get_law("rate_state_aging")
SL = get_law("rate_state_slip")
LAWS_RS = (AG, SL)


def P(law, **kw):
    return pack(law, validate(law, kw))


def asinh_mu(a, V0, v, psi):
    """μ = a asinh[V/(2V0) exp(Ψ/a)], written with numpy for moderate arguments."""
    return a * np.arcsinh(v / (2.0 * V0) * np.exp(psi / a))


# --- registry, parameters, compilation ---------------------------------------------------


def test_registered_with_contract():
    assert LAWS["rate_state_aging"] is AG and LAWS["rate_state_slip"] is SL
    for law in LAWS_RS:
        assert law.state == ("psi",) and law.memo == 2  # the rigid verb's T^{n−1}, V^{n−½}
        assert law.rates is not None and law.rigid is not None
        d = defaults(law)
        assert (d["a"], d["b"], d["L"], d["V0"], d["f0"], d["V_ini"]) == (0.008, 0.012, 1e-6, 1e-6, 0.6, 1e-12)
    assert SL.params[-2].name == "f_w" and SL.params[-1].name == "V_w"
    with pytest.raises(ValueError, match=r"friction\.L = 0 m: must lie in \[1e-09, 10\] m"):
        validate(AG, {"L": 0.0})
    with pytest.raises(ValueError, match=r"friction\.V_w: unknown parameter"):
        validate(AG, {"V_w": 0.1})


@pytest.mark.parametrize("module", [rs, rate_state_aging, rate_state_slip])
def test_kernels_cached_and_not_fastmath(module):
    kernels = [f for f in vars(module).values() if isinstance(f, numba.core.registry.CPUDispatcher)
               and f.py_func.__module__ == module.__name__ and f.__name__ != "kernel"]
    assert kernels
    for f in kernels:
        assert not isinstance(f._cache, NullCache), f.__name__
        assert not f.targetoptions.get("fastmath", False), f.__name__


# --- steady state -------------------------------------------------------------------------


@pytest.mark.parametrize("v", [1e-9, 1e-6, 1e-3, 1.0, 20.0, 1e3])
def test_steady_state_closed_forms(v):
    """μ_ss(V): aging a asinh[V/(2V0) exp((f0 − b ln(V/V0))/a)]; slip f0 − (b − a) ln(V/V0);
    TPV103's strong weakening f_w + (f_LV − f_w)/[1 + (V/V_w)^8]^(1/8)."""
    a, b, V0, f0 = 0.008, 0.012, 1e-6, 0.6
    p = P(AG)
    expect = a * math.asinh(v / (2 * V0) * math.exp((f0 - b * math.log(v / V0)) / a))
    assert AG.steady_mu(p, v) == pytest.approx(expect, rel=1e-13)
    flv = f0 - (b - a) * math.log(v / V0)
    assert SL.steady_mu(P(SL), v) == pytest.approx(flv, rel=1e-13)
    ps = P(SL, V_w=0.1, f_w=0.2)
    assert SL.steady_mu(ps, v) == pytest.approx(0.2 + (flv - 0.2) / (1 + (v / 0.1) ** 8) ** 0.125, rel=1e-12)
    # the regularized law equals the logarithmic one once V ≫ V0 exp(−f0/a)
    if v >= 1e-6:
        assert AG.steady_mu(p, v) == pytest.approx(f0 + (a - b) * math.log(v / V0), abs=1e-12)


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
@pytest.mark.parametrize("v", [1e-4, 1.0, 100.0])
def test_imposed_slip_rate_reaches_steady_state(law, v):
    """Sliding at v from the initial state ends at μ_ss(v) (aging: after ≫ L/v in time,
    slip: ≫ L in slip)."""
    Tn = 10 * MPa
    p = P(law)
    t = np.linspace(0.0, 60e-6 / v, 601)
    h = drive_slip_rate(law, t, np.full(600, v), Tn)
    assert h.mu[-1] == pytest.approx(law.steady_mu(p, v), abs=1e-12)


# --- velocity step -------------------------------------------------------------------------


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
@pytest.mark.parametrize("v1, v2", [(1e-3, 1e-2), (1.0, 10.0), (10.0, 1.0)])
def test_velocity_step(law, v1, v2):
    """Steady sliding at V1, then V2 imposed: the direct effect a asinh[V2/(2V0) e^(Ψ/a)]
    − a asinh[V1/(2V0) e^(Ψ/a)] (≈ a ln(V2/V1)), then the closed-form evolution at constant
    V2 — aging: φ = e^((Ψ − f0)/b) relaxes to V0/V2 exponentially in time with L/V2,
    slip: Ψ relaxes to Ψ_ss(V2) exponentially in slip over L — along steps of uneven size."""
    a, b, L, V0, f0 = 0.008, 0.012, 1e-6, 1e-6, 0.6
    p = P(law)
    Tn = 5 * MPa
    kind = rs.AGING if law is AG else rs.SLIP
    if kind == rs.AGING:
        psi_ss = lambda v: f0 + b * math.log(V0 / v)  # noqa: E731
    else:
        psi_ss = lambda v: a * math.log(2 * V0 / v * math.sinh((f0 - (b - a) * math.log(v / V0)) / a))  # noqa: E731
    psi1 = psi_ss(v1)
    # steady: dΨ/dt = 0 (to a round-off of 1e-12 in Ψ, times the rate V/L of the slip law)
    dpsi1 = law.rates(p, [psi1], asinh_mu(a, V0, v1, psi1) * Tn, Tn)[1][0]
    assert dpsi1 == pytest.approx(0.0, abs=1e-12 * max(1.0, v1 / L))
    # uneven steps over 8 L of slip at V2
    rng = np.random.default_rng(1)
    dts = rng.uniform(0.2, 1.8, 400)
    dts *= 8 * L / v2 / dts.sum()
    t = np.concatenate(([0.0, 0.0], np.cumsum(dts)))  # a zero-length first step: the jump
    h = drive_slip_rate(law, t, np.concatenate(([v2], np.full(400, v2))), Tn, state0=[psi1])
    mu_before = asinh_mu(a, V0, v1, psi1)
    direct = asinh_mu(a, V0, v2, psi1) - mu_before
    assert h.mu[1] - mu_before == pytest.approx(direct, rel=1e-10)
    assert direct == pytest.approx(a * math.log(v2 / v1), rel=1e-6)
    tt = t[1:]
    if kind == rs.AGING:
        phi1 = math.exp((psi1 - f0) / b)
        phi = V0 / v2 + (phi1 - V0 / v2) * np.exp(-v2 * tt / L)
        psi = f0 + b * np.log(phi)
    else:
        psi = psi_ss(v2) + (psi1 - psi_ss(v2)) * np.exp(-v2 * tt / L)
    assert np.abs(h.state[1:, 0] - psi).max() < 1e-12
    assert np.abs(h.mu[1:] - asinh_mu(a, V0, v2, psi)).max() < 1e-12
    # e^−8 of the way left: |Ψ − Ψ_ss| <= b max(V2/V1, V1/V2) e^−8 (aging: φ/φ_ss − 1 <= V2/V1)
    assert h.mu[-1] == pytest.approx(law.steady_mu(p, v2), abs=1.2 * b * max(v2 / v1, v1 / v2) * math.exp(-8.0))


# --- initial state, rates, integrator details --------------------------------------------


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
def test_initial_state_reproduces_tau0(law):
    """|Ts0| = μ(V_ini, Ψ0) Tn0 (TPV102), the slip rate at t = 0 is V_ini; Ts0 = 0: Ψ_ss(V_ini)."""
    p = P(law, V_ini=1e-9)
    for Tn0, Ts0 in [(30 * MPa, 18 * MPa), (10 * MPa, -6.5 * MPa), (1 * MPa, 1e3)]:
        psi0 = law.initial_state(p, Tn0, Ts0)[0]
        assert rs.mu(p, 1e-9, psi0) * Tn0 == pytest.approx(abs(Ts0), rel=1e-12)
        assert rs.rate(p, abs(Ts0), Tn0, psi0) == pytest.approx(1e-9, rel=1e-11)
        h = drive_jump_rate(law, [0.0, 1e-9], [0.0], Tn0, 1e11, params=p, Ts0=Ts0)
        assert h.slip_rate[0] == pytest.approx(1e-9, rel=1e-11)
    kind = rs.AGING if law is AG else rs.SLIP
    assert law.initial_state(p, 10 * MPa, 0.0)[0] == pytest.approx(rs.psi_ss_py(kind, p, 1e-9), rel=1e-15)


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
@pytest.mark.parametrize("v, psi", [(1e-3, 0.7), (10.0, 0.55), (10.0, 0.8), (500.0, 0.4)])
def test_exact_state_update_matches_rates(law, v, psi):
    """The integrators' exact constant-rate state update, differentiated at h -> 0,
    gives the state rate of ``rates`` (the equations), and its derivative in v is right."""
    p = P(law)
    kind = rs.AGING if law is AG else rs.SLIP
    Tn = 5 * MPa
    T = rs.mu(p, v, psi) * Tn
    v_eq, dpsi = law.rates(p, [psi], T, Tn)
    assert v_eq == pytest.approx(v, rel=1e-12)
    h = 1e-5 * p[rs.L] / v

    def fd(h):
        return (rs.state_end(kind, p, psi, v, h)[0] - psi) / h
    assert 2.0 * fd(h / 2) - fd(h) == pytest.approx(dpsi[0], rel=1e-7)  # Richardson: O(h²)
    H = 3 * p[rs.L] / v
    e, dv = 1e-6 * v, rs.state_end(kind, p, psi, v, H)[1]
    fdv = (rs.state_end(kind, p, psi, v + e, H)[0] - rs.state_end(kind, p, psi, v - e, H)[0]) / (2 * e) * v
    assert dv == pytest.approx(fdv, rel=1e-6, abs=1e-10)


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
def test_fast_steady_sliding_at_bulk_steps(law):
    """Steady sliding at 10³ m/s under 5 MPa at 20-100 ns bulk steps stays there (no
    oscillation of the trapezoidal rule: the stiffness limit h C_s ∂V/∂|T_s| <= κ)."""
    p = P(law)
    v, Tn = 1000.0, 5 * MPa
    kind = rs.AGING if law is AG else rs.SLIP
    psi = rs.psi_ss_py(kind, p, v)
    for dt in (20e-9, 50e-9, 100e-9):
        t = np.arange(41) * dt
        h = drive_jump_rate(law, t, np.full(40, v), Tn, 1e11, Ts0=rs.mu(p, v, psi) * Tn, state0=[psi])
        assert np.abs(h.slip_rate / v - 1.0).max() < 1e-9
        assert np.abs(h.mu - law.steady_mu(p, v)).max() < 1e-11
        # sub-steps from h C_s ∂V/∂T <= κ alone, ∂V/∂T = V/(a T_n) here (the limit is
        # approached from below by factors 0.9)
        kap = p[rs.SUB_STIFF]
        assert h.nsub[1:].max() <= math.ceil(dt * 1e11 * v / (p[rs.A] * Tn) / (0.9 * kap)) + 1


def test_velocity_strengthening_and_sign_reversal():
    """a > b (velocity strengthening): from steady sliding at 50 m/s the jump rate reverses
    to −50 m/s; T_s and the slip reverse, the work stays >= 0 and the point settles to
    −μ_ss(50) T_n."""
    p = P(AG, a=0.016)
    Tn, v = 10 * MPa, 50.0
    psi = rs.psi_ss_py(rs.AGING, p, v)
    t = np.linspace(0.0, 10e-6, 1001)
    vs = np.where(t[1:] <= 1e-6, v, -v)
    h = drive_jump_rate(AG, t, vs, Tn, 1e11, params=p, Ts0=AG.steady_mu(p, v) * Tn, state0=[psi])
    assert np.all(np.isfinite(h.Ts)) and np.all(np.diff(h.work) >= 0.0) and np.all(np.diff(h.slip) >= 0.0)
    assert h.Ts[100] > 0 > h.Ts[-1]
    assert h.Ts[-1] / Tn == pytest.approx(-AG.steady_mu(p, v), rel=1e-6)
    assert h.slip_rate[-1] == pytest.approx(v, rel=1e-5)


# --- the rigid verb against scipy --------------------------------------------------------


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
def test_rigid_against_block_reference(law):
    """A block of 0.1 kg/m² sliding at 1 mm/s in steady state, pushed by a sin² pulse of
    3 MPa over 4 µs under 10 MPa: ``rigid`` in the split-node step (``drive_rigid``:
    the velocity at the half steps, T_stick = m V^{n−½}/Δ + F(tⁿ), Z = m/Δ) against
    the Radau solution of m V̇ = F − τ(V, Ψ), Ψ' from ``rates``, at the half steps.
    Measured: velocity error / peak 3.5e-4 (aging) and 2.9e-4 (slip) at 50 ns,
    1.4e-5 / 1.1e-5 at 10 ns: second order (2.01, 2.02).  The law is taken at the
    middle of the step (V^{n+½}, Ψ^{n+½}) against the traction of t^{n+½}
    extrapolated from T^n and T^{n−1} (the form against T^n itself, half a step
    late, was first order: 2.8e-3 at 50 ns; the end-of-step form 1.8e-2)."""
    kind = rs.AGING if law is AG else rs.SLIP
    p = P(law)
    m, Tn, Vi, tF, t_end = 0.1, 10 * MPa, 1e-3, 4e-6, 6e-6
    psi0 = rs.psi_ss_py(kind, p, Vi)
    F0 = rs.mu(p, Vi, psi0) * Tn
    F = lambda t: F0 + 3 * MPa * math.sin(math.pi * t / tF) ** 2 if t < tF else F0  # noqa: E731
    tt = np.linspace(0.0, t_end, 1201)  # every 5 ns: the half steps of the 10 ns run
    r = ref.block_slider(law, None, tt, F, m, Tn, V_init=Vi, state0=[psi0], max_step=10e-9)
    assert 60.0 < r.peak_rate < 90.0
    errs = []
    for dt in (50e-9, 20e-9, 10e-9):
        t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
        V, T, slip, work, st, nit = ref.drive_rigid(law, None, t, F, m, Tn, V_init=Vi, state0=[psi0])
        k = int(round(dt / 5e-9))
        errs.append(np.abs(V - r.slip_rate[k // 2::k][:len(V)]).max() / r.peak_rate)
        assert np.all(np.diff(work) >= 0.0) and np.all(V > 0.0)
        # the law holds at the middle of every step but the first: |3 T^n − T^{n−1}|/2 =
        # μ(V^{n+½}, Ψ^{n+½}) T_n, the state of tⁿ integrated exactly over dt/2 at the
        # half step's mean rate (V^{n−½} + 3 V^{n+½})/4; and Ψ^{n+1} at V^{n+½} over dt
        mid = np.array([rs.state_end(kind, p, s, 0.25 * (v0 + 3 * v), 0.5 * dt)[0]
                        for v0, v, s in zip(V[:-1], V[1:], st[1:-1, 0])])
        strength = np.array([rs.mu(p, v, s) for v, s in zip(V[1:], mid)]) * Tn
        assert np.abs(np.abs(1.5 * T[1:] - 0.5 * T[:-1]) - strength).max() < 1e-6 * Tn
        end = np.array([rs.state_end(kind, p, s, v, dt)[0] for v, s in zip(V, st[:-1, 0])])
        assert np.allclose(st[1:, 0], end, rtol=1e-14, atol=0)
    assert errs[0] < 5e-4 and errs[2] < 2e-5
    assert math.log(errs[0] / errs[2]) / math.log(5.0) > 1.9


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
def test_rigid_settles_at_creep(law):
    """At creep the law is stiff against the block's inertia (∂τ/∂V dt/m ~ 10⁵ at
    1 nm/s, 50 ns): a force stepped by 0.5 MPa must bring the block to the rate at
    which the law carries the new force, without ringing.  The law held at the middle
    of the step (implicit in V^{n+½}) against the traction of t^{n+½} extrapolated
    from T^n and T^{n−1} (the BDF2 rule's damping: a perturbation shrinks ~1e-3
    times a step) does so in two steps; a form trapezoidal in the slip rate (the
    law at tⁿ with V^n = the mean of V^{n∓½}) would alternate between ~1e-6 and
    ~1e-9 m/s from step to step."""
    kind = rs.AGING if law is AG else rs.SLIP
    p = P(law)
    m, Tn, Vi, dF = 0.1, 10 * MPa, 1e-9, 0.5 * MPa
    psi0 = rs.psi_ss_py(kind, p, Vi)
    F1 = rs.mu(p, Vi, psi0) * Tn + dF
    t = np.linspace(0.0, 2e-6, 41)
    V, T, slip, work, st, nit = ref.drive_rigid(law, None, t, lambda x: F1, m, Tn, V_init=Vi, state0=[psi0])
    # the quasi-static rate: μ(V, Ψ) T_n = F with the state of the step (it barely moves)
    v_qs = np.array([2 * p[rs.V0] * math.sinh(F1 / (p[rs.A] * Tn)) * math.exp(-s / p[rs.A]) for s in st[:-1, 0]])
    assert np.all(np.abs(V / v_qs - 1.0) < 1e-3), (V[:4], v_qs[:4])
    # the contact carries the force, step after step (the first half step also speeds the
    # block up by 5e-7 m/s: 2 Pa of the 6.8 MPa; 1.3e-5 Pa at the third; then round-off)
    assert np.all(np.abs(T - F1) < 1e-6 * F1) and np.all(np.abs(T[3:] - F1) < 1e-12 * F1)
    assert 3e-7 < V[-1] < 1e-6


@pytest.mark.parametrize("law", LAWS_RS, ids=lambda l: l.name)
def test_rigid_degenerate_cases(law):
    """T_stick = 0 slips nothing; a huge Z gives v -> 0 with T_s = T_stick; the result
    satisfies T = T_stick − Z v and |T| = μ(v, Ψ^{n+½}) T_n to round-off, Ψ^{n+½} the
    state integrated at v over dt/2, and the state returned is Ψ^{n+1}, over dt."""
    p = P(law)
    kind = rs.AGING if law is AG else rs.SLIP
    s = storage(law, [rs.psi_ss_py(kind, p, 1.0)])
    Ts, v, ds, dw, it = law.rigid(p, s.copy(), 0.0, 1e6, 10 * MPa, 10 * MPa, 1e-8)
    assert Ts == 0.0 and v == 0.0 and ds == 0.0 and dw == 0.0
    for Tst, Z in [(-6 * MPa, 1e6), (6 * MPa, 1e4), (4 * MPa, 1e12), (9 * MPa, 3e7)]:
        s1 = s.copy()
        Ts, v, ds, dw, it = law.rigid(p, s1, Tst, Z, 10 * MPa, 10 * MPa, 5e-8)
        assert v > 0.0 and np.sign(Ts) == np.sign(Tst) and 0 < it < 60
        assert Ts == pytest.approx(Tst - Z * v * np.sign(Tst), rel=1e-12, abs=1e-9 * abs(Tst))
        mid = rs.state_end(kind, p, s[0], v, 0.5 * 5e-8)[0]  # the law at the middle of the step
        assert abs(Ts) == pytest.approx(rs.mu(p, v, mid) * 10 * MPa, rel=1e-11)
        assert s1[0] == pytest.approx(rs.state_end(kind, p, s[0], v, 5e-8)[0], rel=1e-14)
        assert ds == pytest.approx(v * 5e-8, rel=1e-15) and dw == pytest.approx(abs(Ts) * ds, rel=1e-15)
