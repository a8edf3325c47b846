"""Second order in time of the rigid (split-node) verbs of the rate-dependent
laws (issue 26): the block slider run through fricfem's split-node step
(:func:`reference.laws.drive_rigid`) against scipy's Radau at tight
tolerances, at five steps (four halvings), on problems the verbs were not tuned
on (a stress step, a velocity step, a stick-slip pulse); and creep, where the
law is stiff against the block's inertia, settles with no step-to-step
alternation."""

import math

import numpy as np
import pytest

from fricfem.friction import get_law
from fricfem.friction import rate_state as rs
from reference import laws as ref
from fricfem.friction.base import as_params

MPa = 1e6
DTS = (40e-9, 20e-9, 10e-9, 5e-9, 2.5e-9)
FINE = DTS[-1] / 2  # the reference's grid: every half step of the finest run


def _errors(law, params, F, m, Tn, t_end, t_fix, V_init=0.0, state0=None):
    """Errors at the fixed time t_fix (the slip rate at t_fix + dt/2, where V^{n+½}
    lives; the slip and the state at t_fix), relative to the reference's peak rate,
    its slip and the state's scale, at each step of DTS."""
    tt = np.linspace(0.0, t_end, int(round(t_end / FINE)) + 1)
    r = ref.block_slider(law, params, tt, F, m, Tn, V_init=V_init, state0=state0, rtol=1e-11, max_step=DTS[-1])
    i_fix = int(round(t_fix / FINE))
    scale = np.maximum(np.abs(r.state).max(axis=0), 1e-30)
    out = []
    for dt in DTS:
        t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
        V, T, slip, work, st, nit = ref.drive_rigid(law, params, t, F, m, Tn, V_init=V_init, state0=state0)
        k = int(round(t_fix / dt))
        j = int(round(dt / FINE))
        eV = abs(V[k] - r.slip_rate[i_fix + j // 2]) / r.peak_rate
        es = abs(slip[k] - r.slip[i_fix]) / r.slip[i_fix]
        ex = (np.abs(st[k] - r.state[i_fix]) / scale).max()
        out.append((eV, es, ex))
    return np.array(out)


def _orders(e):
    """Observed orders between neighbouring steps (rows: halvings; columns: V, slip, state)."""
    return np.log2(e[:-1] / e[1:])


def _rsf(name):
    law = get_law(name)
    kind = rs.AGING if name.endswith("aging") else rs.SLIP
    return law, kind, as_params(law, None)


@pytest.mark.parametrize("name", ["rate_state_aging", "rate_state_slip"])
@pytest.mark.parametrize("case", ["stress step", "velocity step"])
def test_rate_state_rigid_second_order(name, case):
    """A block of 10 kg/m² under 10 MPa in steady sliding at 1 mm/s: the force
    stepped up by 1 MPa at t = 0 (stress step), or the block started at 10 mm/s
    with the force and the state of 1 mm/s (velocity step).  At t = 1.5 µs the
    errors in V, slip and state fall at order >= 1.8 at every halving from 40 to
    2.5 ns (measured from 20 ns on: stress step 1.99-2.16, velocity step
    1.93-2.02; from 40 to 20 ns 7.5-8.1 and 1.9-5.0, the 40 ns run still off the
    asymptote; the verb at the middle of the step against T^n was first order:
    0.95-1.07)."""
    law, kind, p = _rsf(name)
    Tn, Vi = 10 * MPa, 1e-3
    psi0 = rs.psi_ss_py(kind, p, Vi)
    F0 = rs.mu(p, Vi, psi0) * Tn
    if case == "stress step":
        e = _errors(law, None, lambda t: F0 + 1.0 * MPa, 10.0, Tn, 2e-6, 1.5e-6, V_init=Vi, state0=[psi0])
    else:
        e = _errors(law, None, lambda t: F0, 10.0, Tn, 2e-6, 1.5e-6, V_init=10 * Vi, state0=[psi0])
    orders = _orders(e)
    assert np.all(orders >= 1.8), (e, orders)
    assert e[-1].max() < 1e-4


def test_povirk_needleman_rigid_second_order():
    """Povirk–Needleman's rigid limit, a block of 0.1 kg/m² at rest under 10 MPa pushed
    by 8 MPa sin²(π t/4 µs): it sticks, slides and sticks again (the switches
    located by the reference as events).  At t = 2.5 µs, while it slides, the
    errors fall at order >= 1.8 over the three halvings from 20 to 2.5 ns
    (measured 1.94 in V, 1.93 in slip and state; 1.78, 2.18, 1.86 between
    neighbours: the onset of sliding falls anywhere within a step, which makes
    the order wobble; the verb at the middle of the step against T^n was first
    order, 0.92)."""
    law = get_law("povirk_needleman")
    F = lambda t: 8 * MPa * math.sin(math.pi * t / 4e-6) ** 2 if t < 4e-6 else 0.0  # noqa: E731
    e = _errors(law, {}, F, 0.1, 10 * MPa, 3e-6, 2.5e-6)
    orders = _orders(e)
    assert np.all(np.log2(e[1] / e[-1]) / 3 >= 1.8) and np.all(orders[1:] >= 1.7), (e, orders)
    assert e[-1].max() < 1e-4


def _increments_settle(V, n_last):
    """Over the last n_last steps: the sign changes of the increments V^{n+½} − V^{n−½}
    and the largest ratio |ΔV^{n+1}| / |ΔV^n|."""
    d = np.diff(V)[-n_last:]
    flips = int(np.sum(np.sign(d[1:]) != np.sign(d[:-1])))
    ratio = np.abs(d[1:]) / np.abs(d[:-1])
    return flips, ratio


@pytest.mark.parametrize("name", ["rate_state_aging", "rate_state_slip"])
def test_rate_state_rigid_creep_no_alternation(name):
    """Creep: 1 µm/s under 10 MPa, the force 0.2 MPa above the steady one; the law is
    stiff against the inertia (∂τ/∂V dt/m = 4e4 at 50 ns).  The slip rate goes to
    the rate at which the law carries the force within a few steps and then
    follows the state's slow evolution: the increments of V keep their sign (no
    alternation) and change by less than 1 % from step to step over the last 60
    steps, and the traction equals the force to 1e-9.  The trapezoidal form
    (the law at t^n with the mean of V^{n∓½}) flips the sign of every increment."""
    law, kind, p = _rsf(name)
    m, Tn, Vi = 0.1, 10 * MPa, 1e-6
    psi0 = rs.psi_ss_py(kind, p, Vi)
    F1 = rs.mu(p, Vi, psi0) * Tn + 0.2 * MPa
    t = np.linspace(0.0, 4e-6, 81)
    V, T, slip, work, st, nit = ref.drive_rigid(law, None, t, lambda x: F1, m, Tn, V_init=Vi, state0=[psi0])
    flips, ratio = _increments_settle(V, 60)
    assert flips == 0 and np.all(np.abs(ratio - 1.0) < 0.01), (flips, ratio)
    assert np.all(np.abs(T[5:] - F1) < 1e-9 * F1)
    # the quasi-static rate of the state at the middle of the step
    v_qs = 2 * p[rs.V0] * math.sinh(F1 / (p[rs.A] * Tn)) * math.exp(-st[-2, 0] / p[rs.A])
    assert V[-1] == pytest.approx(v_qs, rel=1e-3)
    # the same check catches the form trapezoidal in V (the law at t^n with
    # V^n = (V^{n−½} + V^{n+½})/2): it alternates at every step
    Vt = _trapezoidal(kind, p, F1, m, Tn, Vi, psi0, t)
    flips_t, ratio_t = _increments_settle(Vt, 60)
    assert flips_t == 59 and np.all(np.abs(ratio_t - 1.0) < 0.01)


def _trapezoidal(kind, p, F, m, Tn, V_init, psi0, t):
    """The block in the split-node step with the law at t^n and V^n the mean of
    V^{n∓½} (the trapezoidal form, here only to show what the checks catch):
    T_stick − Z V^{n+½} = μ((V^{n−½} + V^{n+½})/2, Ψ^n) T_n; Ψ^{n+1} exact at V^{n+½}."""
    from scipy.optimize import brentq

    V, vp, psi = [], V_init, psi0
    for k in range(len(t) - 1):
        dt = t[k + 1] - t[k]
        dm = 0.5 * (t[k + 1] - t[k - 1]) if k > 0 else 0.5 * dt
        Z, Tst = m / dm, m * vp / dm + F
        w = brentq(lambda x: Tst - Z * x - rs.mu(p, 0.5 * (vp + x), psi) * Tn, 0.0, Tst / Z, xtol=1e-30, rtol=1e-14)
        psi = rs.state_end(kind, p, psi, w, dt)[0]
        V.append(w)
        vp = w
    return np.array(V)

