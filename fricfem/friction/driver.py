"""Point driver: one interface point under prescribed histories, no finite elements.

Two ways to drive a law:

:func:`drive_jump_rate`
    the tangential jump rate Δu̇_s(t) and T_n(t) are imposed on the elastic
    interface C_s; every step calls ``law.advance`` exactly as the interface
    kernel does.
:func:`drive_slip_rate`
    the frictional slip rate Δu̇_slip(t) and T_n(t) are imposed (no interface
    elasticity); the law's ``slide`` integrates the state and returns the
    strength |T_s| (for Povirk–Needleman |T_s| = g(θ0)(θ1 + θ2)(1 + v/V0)^(1/m)).

Both loop over steps inside numba, so long histories are cheap; the loops
are compiled once for every law (they receive the law's function as a
first-class function of the contract's type) and cached.  Times are
non-decreasing; a zero-length step imposes a jump (e.g. a step in T_n).
"""

from __future__ import annotations

import functools
from typing import Callable, NamedTuple

import numba
import numpy as np
from numba import types

from ..kernels.cache import ensure_fresh
from .base import ADVANCE_TYPE, SLIDE_TYPE, Law, as_params, storage

_vec = types.float64[::1]


class PointHistory(NamedTuple):
    """Response of one point; arrays of length n + 1 (the times), state (n + 1, n_state)."""

    t: np.ndarray  # [s]
    Ts: np.ndarray  # shear traction [Pa], signed
    Tn: np.ndarray  # normal traction [Pa], compression positive
    slip_rate: np.ndarray  # Δu̇_slip at t [m/s] (>= 0)
    slip: np.ndarray  # accumulated frictional slip [m]
    work: np.ndarray  # accumulated frictional work [J/m²]
    nsub: np.ndarray  # local sub-steps of the step ending at t (0 at t[0])
    state: np.ndarray  # state variables, law.state order

    @property
    def mu(self) -> np.ndarray:
        """Apparent friction coefficient |T_s| / T_n."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.abs(self.Ts) / self.Tn


def _state0(law: Law, p, Tn0, Ts0, state0):
    if state0 is None:
        state0 = law.initial_state(p, Tn0, Ts0)
    return np.array(state0, dtype=np.float64)


def _check_times(t, n_steps, name):
    t = np.array(t, dtype=np.float64)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) < 0.0):
        raise ValueError("t: expected a non-decreasing 1-D array of at least two times [s]")
    if n_steps != len(t) - 1:
        raise ValueError(f"{name}: expected one value per step ({len(t) - 1}), got {n_steps}")
    return t


def _run_jump_rate(advance, p, s, Ts0, t, vs, Tn, Cs, Ts, rate, slip, work, nsub, state):
    nst = state.shape[1]  # ``s`` may carry the law's memo after its state
    state[0] = s[:nst]
    Ts[0] = Ts0
    for k in range(len(vs)):
        T1, v, ds, dw, ns = advance(p, s, Ts[k], Tn[k], Tn[k + 1], vs[k], Cs, t[k + 1] - t[k])
        Ts[k + 1] = T1
        rate[k + 1] = v
        slip[k + 1] = slip[k] + ds
        work[k + 1] = work[k] + dw
        nsub[k + 1] = ns
        state[k + 1] = s[:nst]


@functools.lru_cache(maxsize=None)
def _loops():
    """The two step loops, compiled (or loaded from the cache) on first use."""
    ensure_fresh()  # numba's disk cache matches the sources (fricfem.kernels.cache)
    f8, i8 = types.float64, types.int64
    jump = numba.njit(
        types.void(ADVANCE_TYPE, _vec, _vec, f8, _vec, _vec, _vec, f8,
                   _vec, _vec, _vec, _vec, i8[::1], f8[:, ::1]),
        cache=True,
    )(_run_jump_rate)
    slip = numba.njit(
        types.void(SLIDE_TYPE, _vec, _vec, _vec, _vec, _vec, _vec, _vec, _vec, f8[:, ::1]),
        cache=True,
    )(_run_slip_rate)
    return jump, slip


def drive_jump_rate(
    law: Law,
    t,
    jump_rate,
    Tn,
    Cs: float,
    params=None,
    Ts0: float = 0.0,
    state0=None,
    advance: Callable | None = None,
) -> PointHistory:
    """Impose the jump rate Δu̇_s and T_n on the elastic interface.

    t          (n+1,) times [s]
    jump_rate  (n,)   Δu̇_s in each step [m/s] (the bulk's (Δu_s(t+dt) − Δu_s(t))/dt)
    Tn         (n+1,) normal traction at the times [Pa] (>= 0), linear within a step
    Cs         interface shear stiffness [Pa/m]
    params     dict (validated, defaults filled in) or packed array
    Ts0        initial shear traction [Pa]; state0 defaults to law.initial_state
    advance    another function with the ``advance`` contract (default law.advance)
    """
    p = as_params(law, params)
    vs = np.array(jump_rate, dtype=np.float64)
    t = _check_times(t, len(vs), "jump_rate")
    Tn = np.array(np.broadcast_to(Tn, t.shape), dtype=np.float64)
    s = storage(law, _state0(law, p, Tn[0], Ts0, state0))
    n = len(t)
    out = [np.zeros(n) for _ in range(4)]
    nsub = np.zeros(n, dtype=np.int64)
    state = np.zeros((n, len(s) - law.memo))
    _loops()[0](advance or law.advance, p, s, float(Ts0), t, vs, Tn, float(Cs), *out, nsub, state)
    Ts, rate, slip, work = out
    rate[0] = _initial_rate(law, p, Ts0, state[0], Tn[0], float(Cs))
    return PointHistory(t, Ts, Tn, rate, slip, work, nsub, state)


def _initial_rate(law, p, Ts0, s0, Tn0, Cs):
    """Slip rate at t[0]: a zero-length step of the law."""
    return law.advance(p, storage(law, s0), Ts0, Tn0, Tn0, 0.0, Cs, 0.0)[1]


def _run_slip_rate(slide, p, s, t, v, Tn, Ts, slip, work, state):
    state[0] = s
    Ts[0] = slide(p, s, v[0], Tn[0], Tn[0], 0.0)
    for k in range(len(v)):
        Ts[k + 1] = slide(p, s, v[k], Tn[k], Tn[k + 1], t[k + 1] - t[k])
        ds = v[k] * (t[k + 1] - t[k])
        slip[k + 1] = slip[k] + ds
        work[k + 1] = work[k] + 0.5 * (Ts[k] + Ts[k + 1]) * ds
        state[k + 1] = s


def drive_slip_rate(law: Law, t, slip_rate, Tn, params=None, state0=None) -> PointHistory:
    """Impose the frictional slip rate Δu̇_slip and T_n; T_s is the strength.

    t          (n+1,) times [s]
    slip_rate  (n,)   Δu̇_slip in each step [m/s] (>= 0); the value at t[k+1]
               is that of the step ending there, at t[0] that of the first step
    Tn         (n+1,) normal traction [Pa], linear within a step
    """
    if law.slide is None:
        raise ValueError(f"friction law '{law.name}' has no imposed-slip-rate response (slide)")
    p = as_params(law, params)
    v = np.array(slip_rate, dtype=np.float64)
    t = _check_times(t, len(v), "slip_rate")
    if np.any(v < 0.0):
        raise ValueError("slip_rate: must be >= 0 m/s (slip is along T_s)")
    Tn = np.array(np.broadcast_to(Tn, t.shape), dtype=np.float64)
    s = _state0(law, p, Tn[0], 0.0, state0)
    n = len(t)
    Ts, slip, work = (np.zeros(n) for _ in range(3))
    state = np.zeros((n, len(s)))
    _loops()[1](law.slide, p, s, t, v, Tn, Ts, slip, work, state)
    rate = np.concatenate(([v[0]], v))
    nsub = np.ones(n, dtype=np.int64)
    nsub[0] = 0
    return PointHistory(t, Ts, Tn, rate, slip, work, nsub, state)


def ramp_jump(t, v_max: float, t_rise: float):
    """Jump Δu_s(t) [m] for a jump rate ramped linearly 0 -> v_max over t_rise, then held."""
    t = np.asarray(t, dtype=np.float64)
    tr = np.minimum(t, t_rise)
    return v_max * (0.5 * tr * tr / t_rise + np.maximum(t - t_rise, 0.0))


def step_rates(t, jump):
    """Per-step rates (Δu(t_k+1) − Δu(t_k)) / (t_k+1 − t_k), as the bulk computes them."""
    return np.diff(jump) / np.diff(t)
