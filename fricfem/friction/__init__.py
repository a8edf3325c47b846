"""Friction laws: one module each, the same contract (see :mod:`.base`), a registry by name."""

import math
import re

import numpy as np

from .. import kernels  # noqa: F401  (numba's disk cache checked before a law compiles: fricfem.kernels.cache)
from .base import Law, Param, defaults, frictional_work, pack, param_names, sign, storage, validate
from . import povirk_needleman, povirk_needleman_rate_tangent, rate_state_aging, rate_state_slip, slip_weakening, stuck

LAWS = {law.name: law for law in (povirk_needleman.LAW, povirk_needleman_rate_tangent.LAW, slip_weakening.LAW,
                                   stuck.LAW, rate_state_aging.LAW, rate_state_slip.LAW)}

#: The laws fricfem ships (never replaced by :func:`register_law`).
BUILT_IN = frozenset(LAWS)


def get_law(name: str) -> Law:
    """The registered law called ``name``; a clear error lists the known ones."""
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(
            f"friction.law = {name!r}: unknown friction law; allowed: {', '.join(sorted(LAWS))}"
        ) from None


def _check_params(where: str, params) -> None:
    if not isinstance(params, tuple) or not all(isinstance(p, Param) for p in params):
        raise ValueError(f"{where}.params: expected a tuple of fricfem.friction.Param")
    names = [p.name for p in params]
    for p in params:
        if not p.name.isidentifier() or names.count(p.name) > 1:
            raise ValueError(f"{where}.params: {p.name!r} must be a unique Python identifier")
        if not (math.isfinite(p.low) and math.isfinite(p.high) and p.low <= p.default <= p.high):
            raise ValueError(f"{where}.params.{p.name}: default {p.default!r} must lie in its finite range "
                             f"[{p.low!r}, {p.high!r}]")


def _smoke(law: Law) -> None:
    """Call the law's functions once, as the interface kernel will (compiles them):
    the outputs of the contract (:mod:`.base`), finite, with the right sizes."""
    where = f"register_law({law.name!r})"
    p = pack(law, defaults(law))
    kept = p.copy()
    state = initial_state(law, p, 1e6, 0.0, where)
    _read_only(where, "advance", law.advance, (p, storage(law, state), 0.0, 1e6, 1e6, 0.0, 1e11, 1e-8))
    for vs in (0.0, 1e3):  # a sticking and a strongly loaded step
        _call(where, "advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)", "Ts1", law.advance,
              (p, storage(law, state), 0.0, 1e6, 1e6, vs, 1e11, 1e-8))
    if not np.array_equal(p, kept, equal_nan=True):
        raise ValueError(f"{where}: advance wrote into its parameter array p (read-only by the contract; "
                         f"{', '.join(param_names(law))} = {kept.tolist()} became {p.tolist()})")
    if math.isnan(float(law.steady_mu(p, 1.0))):
        raise ValueError(f"{where}: steady_mu(p, 1.0) is NaN")
    if law.rigid is not None:
        _smoke_rigid(law, p, state, where)


def initial_state(law: Law, p, Tn0: float, Ts0: float, where: str = "") -> np.ndarray:
    """``law.initial_state(p, Tn0, Ts0)`` checked against the contract: float64[n_state],
    finite; a failure is one ValueError naming the law, the call and its arguments."""
    where = where or f"friction law {law.name!r}"
    call = f"initial_state(p, Tn0 = {Tn0:.6g} Pa, Ts0 = {Ts0:.6g} Pa)"
    try:
        state = np.asarray(law.initial_state(p, Tn0, Ts0), dtype=np.float64)
    except Exception as err:
        raise ValueError(f"{where}: {call} failed: {type(err).__name__}: {err} "
                         f"(parameters {dict(zip(param_names(law), np.asarray(p).tolist()))})") from None
    if state.shape != (len(law.state),):
        raise ValueError(f"{where}: initial_state returned shape {state.shape}; the law declares "
                         f"{len(law.state)} state variable(s) {law.state}")
    if not np.isfinite(state).all():
        raise ValueError(f"{where}: {call} returned {state.tolist()}: every state variable "
                         f"({', '.join(law.state)}) must be finite")
    return state


def initial_storage(law: Law, params, Tn0, Ts0) -> np.ndarray:
    """Every point's initial state and memo, float64[n, n_state + memo] (set-up, once):
    ``params`` float64[n, n_params], ``Tn0`` and ``Ts0`` float64[n] [Pa].  A user's law
    has each call checked (:func:`initial_state`: finite, its size, a failure named
    with the law and the point's tractions); a shipped law is trusted."""
    n = len(Tn0)
    out = np.zeros((n, len(law.state) + law.memo))
    check = law.name not in BUILT_IN
    for q in range(n):
        state = initial_state(law, params[q], Tn0[q], Ts0[q]) if check else law.initial_state(params[q], Tn0[q], Ts0[q])
        out[q] = storage(law, state)
    return out


def _smoke_rigid(law: Law, p, state, where: str) -> None:
    """The optional ``rigid`` verb, called as the split-node kernel will: a stuck
    and a strongly loaded pair (Z = 1e7 Pa s/m, T_n = 1 MPa, dt = 10 ns)."""
    _read_only(where, "rigid", law.rigid, (p, storage(law, state), 0.0, 1e7, 1e6, 1e6, 1e-8))
    for T_stick in (0.0, 1e7):
        _call(where, "rigid(p, s, T_stick, Z, Tn0, Tn1, dt)", "Ts", law.rigid,
              (p, storage(law, state), T_stick, 1e7, 1e6, 1e6, 1e-8))


def _read_only(where: str, verb: str, fn, args) -> None:
    """Compile ``fn`` for a read-only parameter array, as a run's kernel holds it
    (the model's ``param_rows``): a verb that writes ``p`` anywhere, even on a
    branch no call takes, is refused here, by its name and line, before any run
    (numba refuses to compile the write).  Other failures are left to
    :func:`_call`, which calls the verb with a writeable ``p``."""
    p = np.array(args[0])
    p.setflags(write=False)
    try:
        fn(p, *args[1:])
    except Exception as err:
        text = str(err)
        if "readonly array" not in text:
            return
        at = re.findall(r'File "([^"]+)", line (\d+)', text)
        line = f" (line {at[-1][1]} of {at[-1][0]})" if at else ""
        raise ValueError(f"{where}: {verb} writes into its parameter array p{line}; p is read-only by the "
                         f"contract (a run's parameters are the model's, shared by every step and run): keep "
                         f"what changes in the state s") from None


def _call(where: str, signature: str, first: str, fn, args) -> None:
    """One call of a law's verb; its outputs checked against the contract (five
    finite numbers, slip rate, slip and work >= 0), else one ValueError naming it."""
    verb = signature.split("(")[0]
    try:
        out = fn(*args)
    except Exception as err:
        raise ValueError(f"{where}: {signature} failed: {type(err).__name__}: {err}") from None
    if not (isinstance(out, tuple) and len(out) == 5):
        raise ValueError(f"{where}: {verb} must return ({first}, slip_rate, dslip, dwork, nsub), got {out!r}")
    if not all(math.isfinite(float(v)) for v in out) or min(out[1], out[2], out[3]) < 0:
        raise ValueError(f"{where}: {verb} returned {out!r}: every output finite, slip rate, slip and work >= 0")
    if int(out[4]) < 0:  # 0 allowed: the built-in Povirk–Needleman point reports 0 for a step it need not integrate
        raise ValueError(f"{where}: {verb} returned nsub = {out[4]!r}: the number of sub-steps used, >= 0")


def register_law(law: Law, *, replace: bool = False) -> Law:
    """Register a user's friction law under ``law.name`` (then ``friction.law = "<name>"``
    in a scene, its parameters as ``friction.params.<name>``).

    ``law`` is a :class:`Law` on the contract of :mod:`.base`: ``advance`` and
    ``steady_mu`` numba functions (``@numba.njit``), ``initial_state`` a Python
    function, parameters as :class:`Param` with units and ranges.  Its functions
    are called once here (compiling them) and checked against the contract;
    the interface kernel is specialised for the law when a run first uses it.
    Under MPI every rank registers the law (the same script runs on each).
    ``replace``: allow replacing a law registered before (never a built-in one).
    Returns the law.  docs/api.md, "A law of your own".
    """
    if not isinstance(law, Law):
        raise TypeError(f"register_law: expected a fricfem.friction.Law, got {type(law).__name__}")
    where = f"register_law({law.name!r})"
    if not isinstance(law.name, str) or not law.name.isidentifier():
        raise ValueError(f"register_law: name {law.name!r} must be a Python identifier (it becomes friction.law)")
    if law.name in BUILT_IN or (law.name in LAWS and not replace):
        raise ValueError(f"{where}: a law of that name is registered already"
                         + ("" if law.name in BUILT_IN else "; pass replace=True to replace it"))
    _check_params(where, law.params)
    if not isinstance(law.state, tuple) or not all(isinstance(s, str) and s.isidentifier() for s in law.state):
        raise ValueError(f"{where}.state: expected a tuple of state-variable names (identifiers)")
    for verb in ("advance", "steady_mu") + (("rigid",) if law.rigid is not None else ()):
        if not hasattr(getattr(law, verb), "py_func"):
            raise ValueError(f"{where}.{verb}: must be a numba function (decorate it with @numba.njit)")
    _smoke(law)
    LAWS[law.name] = law
    return law


__all__ = ["Law", "Param", "LAWS", "BUILT_IN", "get_law", "register_law", "defaults", "frictional_work", "pack",
           "param_names", "sign", "storage", "validate"]
