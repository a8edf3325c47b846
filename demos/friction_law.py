# # The friction law at one interface point
#
# This demo drives fricfem's Povirk–Needleman friction law at a single
# interface point, with no finite elements, and reproduces the law's figures
# of the paper (section "Friction law parameters"):
#
# * Fig. 2a — the steady-state friction coefficient
#   μ_ss(v) = μd + (μs − μd) exp(−(v/V1)^p) against the fit
#   μ_ss = μ0 [1 + α v G / (2 c_s τ0)] the paper quotes from experiments;
# * Fig. 2b — a step in slip rate at constant T_n: T_s/T_n jumps in the
#   direction of the step (the direct effect), then decays to the new steady
#   state over a slip of a few L0/B;
# * Fig. 3 — a step in T_n at constant slip rate: T_s follows gradually, over
#   a slip ~L1 = L2, while T_s/T_n jumps.
#
# It then checks the time integration the finite-element kernel relies on:
#
# * the stiffness experiment — one point on the elastic interface
#   (C_s = 10¹¹ Pa/m, T_n = 30 MPa) under a jump rate ramped 0 → 700 m/s over
#   2 µs, at the bulk's explicit step (50 ns, 10 ns): the paper's plain
#   rate-tangent update against fricfem's integrator and a fine reference;
# * convergence in the step, and the choice of γ on six loading histories;
# * the cost of one call of ``advance``.
#
# Figures (PNG) and the numbers quoted in ``docs/friction.md`` (JSON) go to
# ``demos/output/friction_law/`` (``--out`` changes it).  Run with
# ``python3 demos/friction_law.py``; under ``mpirun`` only rank 0 writes.

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numba  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from fricfem.friction import defaults, get_law, pack  # noqa: E402
from fricfem.friction import povirk_needleman as pn
from fricfem.friction import povirk_needleman_rate_tangent as rt  # noqa: E402
from fricfem.friction.driver import (  # noqa: E402
    drive_jump_rate,
    drive_slip_rate,
    ramp_jump,
    step_rates,
)

comm = MPI.COMM_WORLD
parser = argparse.ArgumentParser(description="The friction law at one interface point")
parser.add_argument("--out", type=Path, default=Path(__file__).parent / "output" / "friction_law")
args = parser.parse_args()
out = args.out
if comm.rank == 0:
    out.mkdir(parents=True, exist_ok=True)
report = {}
law = get_law("povirk_needleman")
prm = defaults(law)  # Table 1
p = pack(law, prm)
MPa = 1e6


def slip_schedule(segments, ds):
    """Times and per-step slip rates for consecutive (rate [m/s], slip [m])
    segments, with the slip per step ds [m]."""
    rates = np.concatenate([np.full(int(round(s / ds)), v) for v, s in segments])
    return np.concatenate(([0.0], np.cumsum(ds / rates))), rates


def slip_to_fraction(slip, y, frac=1.0 - np.exp(-1.0)):
    """Slip after the first sample at which y has covered frac of its change."""
    change = (y - y[-1]) / (y[0] - y[-1])
    return slip[np.argmax(change <= 1.0 - frac)] - slip[0]


# ## Fig. 2a: steady state
#
# The point slides at constant v until the state is steady (a slip of many
# L0/B, L1, L2); |T_s|/T_n then equals the closed form μ_ss(v).  The paper's
# fit, with α = −0.4, G/τ0 = 136, μ0 = 0.6, c_s = 1255 m/s, is drawn as printed.

Tn = 10 * MPa
v_grid = np.linspace(0.25, 40.0, 60)
mu_point = []
for v in v_grid:
    t, rates = slip_schedule([(v, 2e-3)], 2e-6)
    mu_point.append(drive_slip_rate(law, t, rates, Tn, params=prm).mu[-1])
mu_point = np.array(mu_point)
mu_closed = np.array([law.steady_mu(p, v) for v in v_grid])
alpha, G_tau0, mu0, c_s = -0.4, 136.0, 0.6, 1255.0
mu_fit = mu0 * (1.0 + alpha * v_grid * G_tau0 / (2.0 * c_s))
# the G/τ0 for which the printed fit is closest (least squares) to the law
x = mu0 * alpha * v_grid / (2.0 * c_s)
G_tau0_best = float(np.dot(x, mu_closed - mu0) / np.dot(x, x))
report["fig2a"] = {
    "max_abs_point_minus_closed_form": float(np.abs(mu_point - mu_closed).max()),
    "mu_ss_law_at_40": float(law.steady_mu(p, 40.0)),
    "mu_fit_as_printed_at_40": float(mu_fit[-1]),
    "G_over_tau0_least_squares_to_law": G_tau0_best,
}
fig, ax = plt.subplots(figsize=(5, 3.6))
ax.plot(v_grid, mu_closed, "k-", label="law, closed form μ_ss")
ax.plot(v_grid[::4], mu_point[::4], "ko", mfc="none", label="point driver, steady")
ax.plot(v_grid, mu_fit, "k--", label="fit as printed (G/τ0 = 136)")
ax.plot(v_grid, mu0 * (1 + alpha * v_grid * G_tau0_best / (2 * c_s)), "k:",
        label=f"fit with G/τ0 = {G_tau0_best:.0f}")
ax.set(xlabel="slip rate Δu̇_slip [m/s]", ylabel="μ_ss", ylim=(0, 0.65))
ax.legend(fontsize=8)
fig.tight_layout()

# ## Fig. 2b: a step in slip rate
#
# Steady sliding at 1 m/s, then 10 m/s, then 1 m/s again, at T_n = 10 MPa.
# At the step, θ0 cannot change: |T_s| = g(θ0)(θ1 + θ2)(1 + v/V0)^(1/m)
# jumps by the factor ((V0 + 10)/(V0 + 1))^(1/m) (the direct effect), then θ0
# relaxes to L0/v over a slip of a few L0/B = 4.3 µm.

ds = 5e-9
t, rates = slip_schedule([(1.0, 40e-6), (10.0, 60e-6), (1.0, 60e-6)], ds)
h2b = drive_slip_rate(law, t, rates, Tn, params=prm, state0=pn.steady_state(p, 1.0, Tn))
k_up, k_down = int(round(40e-6 / ds)), int(round(100e-6 / ds))  # last samples before the steps
mu2b = h2b.mu
report["fig2b"] = {
    "mu_before": float(mu2b[k_up]),
    "mu_just_after_step_up": float(mu2b[k_up + 1]),
    "mu_steady_10": float(mu2b[k_down]),
    "slip_to_63pct_after_step_up_um": 1e6 * slip_to_fraction(
        h2b.slip[k_up + 1 : k_down + 1], mu2b[k_up + 1 : k_down + 1]),
    "mu_just_after_step_down": float(mu2b[k_down + 1]),
    "mu_steady_1": float(mu2b[-1]),
}
fig2b, ax = plt.subplots(figsize=(5, 3.6))
ax.plot(h2b.slip * 1e6, mu2b, "k-")
ax.set(xlabel="accumulated slip Δu_slip [µm]", ylabel="T_s / T_n",
       title="slip rate 1 → 10 → 1 m/s, T_n = 10 MPa")
fig2b.tight_layout()

# ## Fig. 3: a step in normal traction
#
# Steady sliding at 10 m/s under 30 MPa; T_n drops to 20 MPa, later returns
# to 30 MPa (zero-length steps of the driver).  θ1 + θ2 follow T_n over the
# slips L1, L2, so T_s changes gradually while T_s/T_n jumps.

v3 = 10.0
n1, n2, n3 = 8000, 40000, 40000  # steps of 5 nm
t = np.concatenate(([0.0], np.cumsum(np.full(n1 + n2 + n3, ds / v3))))
t = np.insert(t, [n1 + 1, n1 + n2 + 1], [t[n1], t[n1 + n2]])  # the two jumps
rates = np.full(len(t) - 1, v3)
Tn3 = np.full(len(t), 30 * MPa)
Tn3[n1 + 1 : n1 + n2 + 2] = 20 * MPa
h3 = drive_slip_rate(law, t, rates, Tn3, params=prm, state0=pn.steady_state(p, v3, 30 * MPa))
a, b = n1 + 1, n1 + n2 + 2  # first samples at 20 MPa / back at 30 MPa
report["fig3"] = {
    "Ts_before_drop_MPa": float(h3.Ts[a - 1] / MPa),
    "Ts_at_drop_MPa": float(h3.Ts[a] / MPa),
    "mu_before_drop": float(h3.mu[a - 1]),
    "mu_at_drop": float(h3.mu[a]),
    "slip_to_63pct_after_drop_um": 1e6 * slip_to_fraction(h3.slip[a:b], h3.Ts[a:b]),
    "L1_um": prm["L1"] * 1e6,
}
fig3, ax = plt.subplots(figsize=(5, 3.6))
ax.plot(h3.slip * 1e6, h3.Ts / MPa, "k-", label="T_s")
ax.plot(h3.slip * 1e6, h3.Tn / MPa, "k--", label="T_n")
ax.set(xlabel="accumulated slip Δu_slip [µm]", ylabel="traction [MPa]",
       title=f"T_n steps at constant slip rate {v3:g} m/s", ylim=(0, 32))
ax2 = ax.twinx()
ax2.plot(h3.slip * 1e6, h3.mu, color="0.6", lw=1)
ax2.set_ylabel("T_s / T_n", color="0.45")
ax.legend(loc="lower right", fontsize=8)
fig3.tight_layout()

# ## The stiffness experiment
#
# One point on the elastic interface, Ṫ_s = C_s (Δu̇_s − sgn(T_s) Δu̇_slip),
# T_n = 30 MPa, C_s = 10¹¹ Pa/m, Δu̇_s ramped 0 → 700 m/s over 2 µs, then
# held.  The jump rate in each step is the step average, as the bulk
# computes it.  Stuck, T_s reaches the healed strength at 1.0 µs; the point
# then slips in a fast event (the massless point is softer than the law's
# weakening, so slip rates reach ~10⁵ m/s for a nanosecond) and settles to
# sliding at 700 m/s, T_s/T_n → μ_ss(700) ≈ 0.5.

Tn_s, Cs_s, t_end = 30 * MPa, 1e11, 4e-6


def stiffness_run(dt, advance=None, gamma=0.5):
    t = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
    vs = step_rates(t, ramp_jump(t, 700.0, 2e-6))
    return drive_jump_rate(law, t, vs, Tn_s, Cs_s, params=dict(prm, gamma=gamma),
                           advance=advance)


dt_ref = 0.1e-9
ref = stiffness_run(dt_ref)
report["stiffness"] = {"reference_dt_ns": dt_ref * 1e9,
                       "reference_peak_slip_rate": float(ref.slip_rate.max())}
fig4, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
for ax, dt in zip(axes, (50e-9, 10e-9)):
    stride = int(round(dt / dt_ref))
    entry = {}
    tic = time.perf_counter()
    ours = stiffness_run(dt)
    entry["fricfem_run_time_s"] = time.perf_counter() - tic
    entry["fricfem_max_error_over_Tn"] = float(np.abs(ours.Ts - ref.Ts[::stride]).max() / Tn_s)
    entry["fricfem_substeps_total"] = int(ours.nsub.sum())
    entry["fricfem_substeps_max_in_a_step"] = int(ours.nsub.max())
    entry["steps"] = len(ours.t) - 1
    ax.plot(ref.t * 1e6, ref.Ts / Tn_s, "k-", lw=1, label=f"reference, {dt_ref * 1e9:g} ns")
    ax.plot(ours.t * 1e6, ours.Ts / Tn_s, "o", ms=3, mfc="none", label="fricfem advance")
    for gamma, style in ((0.5, "-"), (1.0, "--")):
        plain = stiffness_run(dt, rt.rate_tangent_advance, gamma)
        bad = ~np.isfinite(plain.Ts) | (plain.state[:, 0] <= 0.0)
        key = f"plain_rate_tangent_gamma_{gamma:g}"
        if bad.any():
            k = int(np.argmax(bad))
            entry[key] = f"fails at t = {plain.t[k] * 1e6:.3f} µs (θ0 <= 0 or NaN)"
            ax.plot(plain.t[:k] * 1e6, plain.Ts[:k] / Tn_s, style, lw=1,
                    label=f"plain rate tangent γ = {gamma:g} (fails at ×)")
            ax.plot(plain.t[k - 1] * 1e6, plain.Ts[k - 1] / Tn_s, "kx", ms=8)
        else:
            entry[key] = float(np.abs(plain.Ts - ref.Ts[::stride]).max() / Tn_s)
            ax.plot(plain.t * 1e6, plain.Ts / Tn_s, style, lw=1,
                    label=f"plain rate tangent γ = {gamma:g}")
    report["stiffness"][f"dt_{dt * 1e9:g}ns"] = entry
    ax.set(xlabel="t [µs]", title=f"bulk step {dt * 1e9:g} ns", ylim=(-0.05, 0.8))
    ax.legend(fontsize=7, loc="lower right")
axes[0].set_ylabel("T_s / T_n")
fig4.tight_layout()

# ## Convergence in the step, and γ
#
# A smooth history: steady sliding at 10 m/s under 1 MPa (a stable point:
# C_s exceeds the law's weakening stiffness there), the jump rate ramped to
# 100 m/s and T_n down to 0.7 MPa over 1 µs.  Errors are the largest
# |T_s − T_s,ref| / T_n(0) against a run at 1/32 ns.  Where no sub-steps are
# needed (dt <= 4 ns here) the observed order is that of the sub-step scheme.

Tn_c, t_c = 1 * MPa, 2e-6


def smooth_run(dt, gamma):
    t = np.linspace(0.0, t_c, int(round(t_c / dt)) + 1)
    vs = step_rates(t, 10.0 * t + ramp_jump(t, 90.0, 1e-6))
    Tn = Tn_c * (1.0 - 0.3 * np.minimum(t / 1e-6, 1.0))
    Ts0 = law.steady_mu(p, 10.0) * Tn_c
    return drive_jump_rate(law, t, vs, Tn, 1e11, params=dict(prm, gamma=gamma), Ts0=Ts0,
                           state0=pn.steady_state(p, 10.0, Tn_c))


dts = np.array([64, 32, 16, 8, 4, 2, 1, 0.5]) * 1e-9
dt_fine = 1e-9 / 32
conv = {}
for gamma in (0.5, 1.0):
    fine = smooth_run(dt_fine, gamma)
    errs = []
    for dt in dts:
        run = smooth_run(dt, gamma)
        errs.append(np.abs(run.Ts - fine.Ts[:: int(round(dt / dt_fine))]).max() / Tn_c)
    errs = np.array(errs)
    orders = np.log2(errs[4:-1] / errs[5:])  # dt = 4 → 0.5 ns
    conv[f"gamma_{gamma:g}"] = {"dt_ns": (dts * 1e9).tolist(), "error_over_Tn": errs.tolist(),
                                "observed_order_4_to_0.5ns": orders.tolist()}
report["convergence"] = conv
fig5, ax = plt.subplots(figsize=(5, 3.6))
for gamma, mark in ((0.5, "o-"), (1.0, "s--")):
    ax.loglog(dts * 1e9, conv[f"gamma_{gamma:g}"]["error_over_Tn"], mark, mfc="none",
              label=f"γ = {gamma:g}")
for gamma, order, style in ((0.5, 2, "k:"), (1.0, 1, "k-.")):
    e4 = conv[f"gamma_{gamma:g}"]["error_over_Tn"][4]  # at dt = 4 ns
    ax.loglog(dts[4:] * 1e9, 0.5 * e4 * (dts[4:] / dts[4]) ** order, style, lw=1,
              label=f"slope {order}")
ax.set(xlabel="bulk step dt [ns]", ylabel="max |T_s − T_s,ref| / T_n")
ax.legend(fontsize=8)
fig5.tight_layout()

# ## γ across loading histories
#
# The integrator's own error at the bulk step, apart from the error of a jump
# rate held constant in each step: each run is compared with a run under the
# same per-step jump rates on a grid finer by dt / 0.05 ns, with tight
# sub-step limits (substep_tol 1e-3, substep_stiff 0.2).  Default limits,
# γ = 1/2 against γ = 1; error = max |T_s − T_s,ref| / T_n(0).


def piecewise_jump(t, starts, rates):
    """Jump Δu_s(t) [m] for jump rates constant from each start time on."""
    ends = list(starts[1:]) + [np.inf]
    return sum(r * np.clip(t - a, 0.0, b - a) for a, b, r in zip(starts, ends, rates))


histories = {
    # name: (duration [s], C_s [Pa/m], Δu_s(t) [m], T_n(t) [Pa], steady slip rate at t = 0)
    "stiffness experiment, 30 MPa": (4e-6, 1e11, lambda t: ramp_jump(t, 700.0, 2e-6),
                                     lambda t: 30 * MPa + 0 * t, None),
    "smooth ramp, 1 MPa": (2e-6, 1e11, lambda t: 10.0 * t + ramp_jump(t, 90.0, 1e-6),
                           lambda t: MPa * (1 - 0.3 * np.minimum(t / 1e-6, 1)), 10.0),
    "jump-rate steps 10/100/10 m/s, 1 MPa": (
        2e-6, 1e11, lambda t: piecewise_jump(t, [0, 0.503e-6, 1.207e-6], [10, 100, 10]),
        lambda t: MPa + 0 * t, 10.0),
    "soft interface C_s = 1e10, 0.9 MPa": (3e-6, 1e10, lambda t: ramp_jump(t, 100.0, 1e-6),
                                           lambda t: 0.9 * MPa + 0 * t, None),
    "T_n 10 MPa -> 0 at 50 m/s": (2e-6, 1e11, lambda t: 50.0 * t,
                                  lambda t: 10 * MPa * np.maximum(1 - t / 1.5e-6, 0), 50.0),
    "reversal +-150 m/s, 10 MPa": (
        3e-6, 1e11, lambda t: piecewise_jump(t, [0, 1.003e-6], [150, -150]),
        lambda t: 10 * MPa + 0 * t, None),
}


def history_run(history, dt, params, refine=1):
    duration, Cs, jump, Tn_of_t, v0 = history
    t = np.linspace(0.0, duration, int(round(duration / dt)) + 1)
    vs, Tn = step_rates(t, jump(t)), Tn_of_t(t)
    if refine > 1:  # the same per-step jump rates on a finer grid
        fine_t = np.linspace(0.0, duration, (len(t) - 1) * refine + 1)
        vs, Tn, t = np.repeat(vs, refine), np.interp(fine_t, t, Tn), fine_t
    state0, Ts0 = None, 0.0
    if v0 is not None:
        state0, Ts0 = pn.steady_state(p, v0, Tn[0]), law.steady_mu(p, v0) * Tn[0]
    run = drive_jump_rate(law, t, vs, Tn, Cs, params=dict(prm, **params), Ts0=Ts0,
                          state0=state0)
    return run.Ts[::refine], int(run.nsub.sum())


table = {}
for name, history in histories.items():
    Tn0 = history[3](0.0)
    table[name] = {}
    for dt in (100e-9, 50e-9, 20e-9):
        ref_Ts, _ = history_run(history, dt, dict(substep_tol=1e-3, substep_stiff=0.2),
                                refine=int(round(dt / 0.05e-9)))
        row = {}
        for gamma in (0.5, 1.0):
            Ts, nsub = history_run(history, dt, dict(gamma=gamma))
            row[f"gamma_{gamma:g}"] = {"error_over_Tn": float(np.abs(Ts - ref_Ts).max() / Tn0),
                                       "substeps": nsub}
        table[name][f"dt_{dt * 1e9:g}ns"] = row
report["gamma_across_histories"] = table

# ## Cost of one call
#
# ``advance`` called in a compiled loop on a fresh copy of the state, at
# stick and at steady sliding (one bulk step of 50 ns).  The loop is not
# cached: it is specialised on the law's dispatcher passed in.


@numba.njit
def _calls(advance, p, s0, Ts, Tn, vs, Cs, dt, n):
    s = s0.copy()
    total = 0.0
    for _ in range(n):
        s[:] = s0
        total += advance(p, s, Ts, Tn, Tn, vs, Cs, dt)[0]
    return total


def ns_per_call(s0, Ts, vs, n=200_000):
    _calls(law.advance, p, s0, Ts, Tn_s, vs, Cs_s, 50e-9, 10)
    best = np.inf
    for _ in range(3):
        tic = time.perf_counter()
        _calls(law.advance, p, s0, Ts, Tn_s, vs, Cs_s, 50e-9, n)
        best = min(best, (time.perf_counter() - tic) / n * 1e9)
    return best


cost = {"stick": ns_per_call(pn.steady_state(p, 1.0, Tn_s), 0.3 * Tn_s, 1.0)}
for v in (10.0, 100.0, 700.0):
    s0 = pn.steady_state(p, v, Tn_s)
    Ts = law.steady_mu(p, v) * Tn_s  # steady sliding: θ0 = L0/v, θ1 + θ2 = T_n
    cost[f"steady_{v:g}_m_per_s"] = ns_per_call(s0, Ts, v)
report["advance_ns_per_call_dt_50ns"] = cost

# ## Output

if comm.rank == 0:
    for f, name in ((fig, "fig2a_steady_state.png"), (fig2b, "fig2b_slip_rate_step.png"),
                    (fig3, "fig3_normal_traction_step.png"),
                    (fig4, "stiffness_experiment.png"), (fig5, "convergence.png")):
        f.savefig(out / name, dpi=150)
    (out / "friction_law.json").write_text(json.dumps(report, indent=2, ensure_ascii=False))
    print(json.dumps(report, indent=2, ensure_ascii=False))
    print(f"figures and numbers written to {out}")
