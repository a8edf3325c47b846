"""The contract every friction law fulfils, and parameter validation.

A law is a :class:`Law` record: its parameters (with units and allowed ranges),
the names of its state variables, and numba-compiled point functions.  The
interface kernel is specialised per law: a copy of it calls ``law.advance``
(a numba dispatcher) by name, so there is no per-point dispatch on the law's
kind, and numba caches each law's copy on disk
(:func:`fricfem.kernels.interface.specialise`).

``advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt) -> (Ts1, slip_rate, dslip, dwork, nsub)``
    Integrate one interface point over one bulk step ``dt`` [s].

    p     float64[n_params]  the point's parameters, packed in ``law.params`` order
    s     float64[n_state + memo]  state at the start of the step, then the law's memo
                             (see ``storage``); updated in place
    Ts    shear traction at the start of the step [Pa] (signed)
    Tn0, Tn1  normal traction at the start / end of the step [Pa], compression
          positive, both >= 0 (an open interface never reaches the law); the law
          may take it linear in time between them
    vs    tangential jump rate d(Δu_s)/dt over the step [m/s], constant in the step
    Cs    elastic shear stiffness of the interface [Pa/m], > 0
    dt    the step [s]

    Returns the shear traction at the end of the step [Pa], the slip rate
    Δu̇_slip at the end of the step [m/s] (>= 0, in the direction of sgn(Ts)),
    the frictional slip accumulated over the step [m] (>= 0), the frictional
    work dissipated over the step per unit interface area [J/m²] (>= 0), and the
    number of local sub-steps used (1 when none were needed).

``steady_mu(p, v) -> μ_ss``: the steady-state friction coefficient at slip rate
``v`` [m/s] (numba function).

``initial_state(p, Tn0, Ts0) -> float64[n_state]``: state at t = 0 for the
initial normal / shear tractions [Pa] (plain Python, called once per point).

``slide(p, s, v, Tn0, Tn1, dt) -> |T_s|`` (optional): advance the state ``s``
in place over ``dt`` at the imposed slip rate ``v`` [m/s], without interface
elasticity, and return the frictional strength [Pa] at the end of the step;
used by the point driver (:mod:`.driver`) to trace the law's response.

Optional verbs (``None`` when a law does not provide them):

``rates(p, state, Ts, Tn) -> (v, dstate_dt)`` (plain Python/numpy, not numba):
    the law's continuous equations exactly as its paper writes them — the slip
    rate v >= 0 [m/s] at the shear traction ``Ts`` [Pa] (signed; the law uses
    |T_s|), normal traction ``Tn`` [Pa] and ``state`` (``law.state`` order),
    and the time derivative of the state at that slip rate (ndarray, same
    length as the state).  Written from the equations, never by calling the
    numba integrators; used only by the independent scipy references
    (tests/reference/laws).  A law whose slip rate switches off below a threshold
    (stick) may also accept a keyword ``branch``: ``"slide"`` returns the
    smooth continuation of the sliding branch's v (negative below the
    threshold), ``"stick"`` the sticking branch (v = 0); the references locate
    the switch as an event with it.  ``None`` for a rate-independent law
    (slip weakening), whose references are exact piecewise solutions.

``rigid(p, s, T_stick, Z, Tn0, Tn1, dt) -> (Ts, v, dslip, dwork, nsub)`` (numba):
    one step t^n → t^{n+1} of a *rigid* (split-node) interface point, in the
    central-difference step of the bulk (displacements and the state at
    whole steps, velocities at half steps).  It receives:

    s        the state at t^n (then the memo); updated in place to t^{n+1}
    T_stick  [Pa] the signed shear traction of the step that keeps the node
             pair from slipping from t^n to t^{n+1}: the force of the step
             (the central-difference force, which belongs to t^n) when the
             pair's half-step slip rate V^{n+½} is zero
    Z        > 0 [Pa·s/m] the drop of that traction per unit slip rate V^{n+½},
             so that Ts = T_stick − Z v sgn(T_stick)
    Tn1      [Pa] the normal traction of the step (the same time, t^n), > 0;
             Tn0 that of the step before (t^{n−1})
    dt       [s] the step

    and returns the shear traction of the step Ts [Pa] (the force of t^n;
    |Ts| <= the strength, = T_stick when v = 0), the pair's slip rate of the
    step v = V^{n+½} >= 0 [m/s] (along sgn(T_stick)), the slip from t^n to
    t^{n+1}, v·dt [m] (so the slip lives at whole steps: δ^{n+1} = δ^n + v dt),
    the frictional work |Ts|·v·dt >= 0 [J/m²] and the number of local
    iterations.  The slip runs along sgn(T_stick − Ts) (= sgn(T_stick) but
    where a two-step form slips against a T_stick crossing zero).  Each law
    says at which time within the step it evaluates its strength (slip
    weakening: μ(δ^n), at t^n, explicit; the rate-and-state laws and the
    rigid limit of Povirk–Needleman: at t^{n+½}, with V^{n+½} and the state
    integrated to the middle of the step, against the traction extrapolated
    to t^{n+½} from Ts and the previous step's, which they keep in their memo:
    second order).  The block slider of
    ``drive_rigid`` of tests/reference/laws runs the verb in the same
    step and is scored against scipy (tests/test_point_reference.py,
    tests/test_rate_state.py).

``kernel``, ``rigid_kernel``: interface kernels of the law's own, elastic and
    rigid, with the signatures of :func:`fricfem.kernels.interface.kernel_for`
    and :func:`~fricfem.kernels.interface.rigid_kernel_for` (None, as for every
    shipped law: the generic kernel is specialised for ``advance``/``rigid``
    when first needed and cached on disk).

``ADVANCE_TYPE`` and ``SLIDE_TYPE`` are the numba function types of ``advance``
and ``slide``: a numba function declared with them is compiled (and cached)
once for all laws, which pass their dispatcher in (see :mod:`.driver`).
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numba
import numpy as np
from numba import types


# numba types of the contract's functions, for code compiled once for any law
# (a law's dispatcher converts to these function types when passed in).
_f8 = types.float64
_vec = types.float64[::1]
ADVANCE_TYPE = types.FunctionType(
    types.Tuple((_f8, _f8, _f8, _f8, types.int64))(_vec, _vec, _f8, _f8, _f8, _f8, _f8, _f8)
)
SLIDE_TYPE = types.FunctionType(_f8(_vec, _vec, _f8, _f8, _f8, _f8))


class Param(NamedTuple):
    """One law parameter: name, default, unit, allowed closed range, meaning."""

    name: str
    default: float
    unit: str  # "" for a dimensionless parameter
    low: float
    high: float
    doc: str


class Law(NamedTuple):
    """A friction law: parameters, state names and its numba point functions."""

    name: str
    doc: str
    params: tuple  # tuple[Param, ...]
    state: tuple  # tuple[str, ...] state-variable names, in storage order
    advance: Callable  # numba dispatcher, see module docstring
    steady_mu: Callable  # numba dispatcher (p, v) -> mu_ss
    initial_state: Callable  # python (p, Tn0, Ts0) -> ndarray
    slide: Callable = None  # numba dispatcher (p, s, v, Tn0, Tn1, dt) -> |T_s|, optional
    memo: int = 0  # storage the law keeps after its state for itself (NaN at first), see ``storage``
    rates: Callable = None  # python (p, state, Ts, Tn) -> (v, dstate_dt), optional, see module docstring
    rigid: Callable = None  # numba (p, s, T_stick, Z, Tn0, Tn1, dt) -> (Ts, v, dslip, dwork, nsub), optional
    kernel: Callable = None  # an interface kernel of the law's own (None: the generic one specialised for ``advance``)
    rigid_kernel: Callable = None  # its rigid (split-node) interface kernel (None: specialised for ``rigid``)


def storage(law: Law, state) -> np.ndarray:
    """The array ``advance`` works on: the state (``law.state`` order) followed
    by ``law.memo`` entries the law may use to remember derived quantities
    between calls (NaN: nothing remembered).  Only the state is physics; the
    memo never changes a result of ``advance``; a ``rigid`` verb may keep the
    previous step's traction and slip rate there (its two-step form; NaN: the
    first step)."""
    return np.concatenate([np.asarray(state, dtype=np.float64), np.full(law.memo, np.nan)])


def param_names(law: Law) -> tuple:
    return tuple(p.name for p in law.params)


def defaults(law: Law) -> dict:
    """The law's default parameters as a dict."""
    return {p.name: p.default for p in law.params}


def validate(law: Law, values: dict, where: str = "friction") -> dict:
    """Return a complete, checked parameter dict (defaults filled in).

    Raises ``ValueError`` naming the key (prefixed by ``where``), the value, its
    unit and the allowed range for any unknown key, non-number or value out of
    range.
    """
    known = {p.name: p for p in law.params}
    for key in values:
        if key not in known:
            raise ValueError(
                f"{where}.{key}: unknown parameter for friction law "
                f"'{law.name}'; allowed: {', '.join(known)}"
            )
    out = {}
    for p in law.params:
        v = values.get(p.name, p.default)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(
                f"{where}.{p.name}: expected a number [{p.unit or 'dimensionless'}], got {v!r}"
            )
        v = float(v)
        unit = f" {p.unit}" if p.unit else ""
        if not math.isfinite(v) or v < p.low or v > p.high:
            raise ValueError(
                f"{where}.{p.name} = {v:g}{unit}: must lie in "
                f"[{p.low:g}, {p.high:g}]{unit} ({p.doc})"
            )
        out[p.name] = v
    return out


def as_params(law: Law, params) -> np.ndarray:
    """Packed parameters from a dict (validated, defaults filled in), None (the
    defaults) or an array already packed."""
    if params is None:
        params = {}
    if isinstance(params, dict):
        return pack(law, validate(law, params))
    return np.array(params, dtype=np.float64)


def pack(law: Law, values: dict) -> np.ndarray:
    """Pack a validated parameter dict into the float64 array ``advance`` reads."""
    return np.array([float(values[p.name]) for p in law.params], dtype=np.float64)


def param_index(params: tuple, *names: str) -> tuple:
    """The index in the packed array (:func:`pack`: the order of ``params``) of each
    parameter named, for a law's module-level constants
    (``MU_S, MU_D, DC = param_index(PARAMS, "mu_s", "mu_d", "Dc")``): numba reads
    them as compile-time constants, and packing and the kernel agree by
    construction — a reordered ``PARAMS`` moves the indices with it, a renamed or
    missing parameter stops the import with its name."""
    order = [p.name for p in params]
    missing = [n for n in names if n not in order]
    if missing:
        raise ValueError(f"parameter(s) {', '.join(missing)} not among the law's PARAMS ({', '.join(order)})")
    return tuple(order.index(n) for n in names)


@numba.njit(cache=True)
def sign(x):
    """sgn(x) with sgn(0) = +1 (a zero traction slips, if at all, forwards)."""
    return -1.0 if x < 0.0 else 1.0


@numba.njit(cache=True)
def frictional_work(Ts0, Ts1, dslip):
    """Work [J/m²] dissipated by the slip ``dslip`` >= 0 [m] of a (sub-)step
    from traction Ts0 to Ts1 [Pa].

    The mean traction times the slip, which balances the interface's elastic
    energy T_s²/(2 C_s) exactly for the updates used here; if the traction
    changed sign within the step it passed through zero where nothing slips,
    and the slip is charged at the end traction instead (keeps the work >= 0).
    """
    if Ts0 * Ts1 >= 0.0:
        return 0.5 * (abs(Ts0) + abs(Ts1)) * dslip
    return abs(Ts1) * dslip
