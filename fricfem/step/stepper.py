"""The explicit central-difference step and the time loop, as two verbs.

With ``f = K u − F_int(u)`` (Belytschko et al. 1976; the paper's Newmark
β = 0, γ = ½ with lumped mass)

    v^{n+½} = v^{n−½} − dt M⁻¹ f(u^n),      u^{n+1} = u^n + dt v^{n+½},

and on the struck edge u1 = U(t) = ∫V prescribed (or a traction load).
:func:`step` does it in one sweep over the rows of K
(:class:`fricfem.step.fused.FusedBulk`); :func:`evolve` is the loop as a
generator, so that output stays apart from stepping.
"""

from __future__ import annotations

import math
import time

import numpy as np
from mpi4py import MPI

from ..kernels.reduce import dot3


def step(model, state, energy: dict | None = None) -> None:
    """Advance ``state`` by one step ``model.dt`` (collective).  If ``energy`` is
    a dict it is filled with the energies at t^n [J/m]: kinetic, strain,
    interface work/elastic/dissipated, external work, the energy the absorbing
    edges took out, and the balance error."""
    if energy is not None:
        v_old = state.v.array_r.copy()
    uku, work, absorbed = model.bulk.advance(state)
    state.u, state.u_next = state.u_next, state.u  # u^{n+1}; u^n's buffer takes the next output
    state.work_ext += work
    state.absorbed += absorbed
    if energy is not None:
        kinetic = 0.5 * dot3(model.mass, v_old, state.v.array_r)  # in a fixed order, not BLAS's (.kernels.reduce)
        loc = np.array([kinetic, state.work_ext, 0.5 * uku, state.absorbed, state.viscous - state.viscous_ahead])
        tot = np.zeros(5)
        model.comm.Allreduce(loc, tot, op=MPI.SUM)
        energy.update(model.interface.energy(state))
        energy.update(time=state.t, kinetic=tot[0], strain=tot[2], external=tot[1], absorbed=tot[3], viscous=tot[4])
        energy["balance_error"] = (
            energy["kinetic"] + energy["strain"] + energy["interface_work"] + energy["absorbed"]
            + energy["viscous"] - energy["external"]
        )
    state.t_interface = state.t
    state.t += model.dt
    state.n += 1


def n_steps(model, t_end: float) -> int:
    """The number of steps from t = 0 to ``t_end`` [s] (the last whole step)."""
    return int(math.floor(t_end / model.dt + 1e-9))


class Reduction:
    """The loop's one collective of a step: a MAX-Allreduce of named slots.

    Observers that need a value over all ranks take a slot by name once, before
    the loop (:meth:`slot`: its index), write this rank's value into
    :attr:`local` in their :meth:`contribute`, and read the result in
    :attr:`glob` (or :attr:`values`, the same as Python floats) in their
    :meth:`observe` (one reduction, however many
    observers; none without slots).  A slot's value is reset to −inf before
    every step's contributions."""

    def __init__(self, comm):
        self.comm = comm
        self.names: list = []
        self.local = np.zeros(0)
        self.glob = np.zeros(0)
        self.values: list = []  # :attr:`glob` as Python floats (cheaper to read and compare)

    def slot(self, name: str) -> int:
        """The index of the new slot ``name`` (a name is taken once)."""
        if name in self.names:
            raise ValueError(f"Reduction: the slot {name!r} is taken")
        self.names.append(name)
        self.local = np.full(len(self.names), -np.inf)
        self.glob = np.full(len(self.names), -np.inf)
        return len(self.names) - 1

    def reduce(self) -> None:
        """Every rank's slots to :attr:`glob` (their maximum; collective)."""
        self.comm.Allreduce(self.local, self.glob, op=MPI.MAX)
        self.values = self.glob.tolist()

    def __getitem__(self, name: str) -> float:
        """The value of slot ``name`` over all ranks after the last :meth:`reduce`."""
        return float(self.glob[self.names.index(name)])


class Timing:
    """The loop's wall-clock times [s], by part: ``step`` and ``step_with_energy``
    (a step that also took the energies; counted in :attr:`energy_steps`), and
    each observer's :attr:`part` (the reduction is booked to ``watch``).  The
    first step (the kernels' compilation or cache load) is timed alone
    (:attr:`first_step_s`) and the parts from the second step on;
    :attr:`observers_s` is every observer's time, the first step's included."""

    def __init__(self, parts=("step", "step_with_energy")):
        self.cost = dict.fromkeys(parts, 0.0)
        self.first_step_s = None
        self.energy_steps = 0
        self.observers_s = 0.0
        self.t0 = None  # when the loop started
        self.wall = 0.0  # the loop's wall time so far

    def first_done(self, state, now: float) -> None:
        """After the first step: its time apart, the parts from zero."""
        self.first_step_s = now - self.t0
        self.cost.update(dict.fromkeys(self.cost, 0.0))
        state.seconds.update(dict.fromkeys(state.seconds, 0.0))
        self.energy_steps = 0


def evolve(model, state, t_end: float, energy_every: int = 0, observers=(), *, timing: Timing | None = None,
           end_energy: bool = False, stepper=None):
    """The time loop: step ``state`` until ``t_end`` [s] or until an observer says
    stop; yields ``(state, energy or None)`` after every step and its observers,
    the energies at t^n of the step every ``energy_every`` steps (0: never).
    With ``end_energy``, a run that reaches ``t_end`` takes the energies at its
    end time t^N as well (:func:`energies_at`: one more step, undone) and hands
    them to each observer that has ``at_end(state, energy)``, then yields
    ``(state, energy)`` once more (the state is unchanged: t^N).
    Its return value (``StopIteration.value``; :func:`run`) is why it stopped:
    the first stop reason of the observers in their order, or None (``t_end``).

    Each observer has ``observe(state, energy) -> stop reason or None`` (after
    every step; ``energy`` as yielded) and may have ``slots`` (names) with
    ``bind(reduction)`` and ``contribute(state, energy)``: the loop makes one
    :class:`Reduction` of every observer's slots, binds it before the first
    step and, after each step, has the contributors fill it and reduces it
    once, before any observer observes.  ``part``: the name the observer's
    time is booked under in ``timing`` (:class:`Timing`).  Nothing is done
    about an observer's outputs here: whoever made the observers finishes them.

    ``stepper``: the step (default :func:`step`, looked up at the call; tests
    pass the two-pass reference)."""
    stepper = step if stepper is None else stepper
    n_end = n_steps(model, t_end)
    reduction = Reduction(model.comm)
    contributors = []
    for o in observers:
        if getattr(o, "slots", ()):
            o.bind(reduction)
            contributors.append(o)
    reduce = reduction.reduce if reduction.names else None
    if timing is None:
        return (yield from _plain(model, state, n_end, energy_every, end_energy, stepper, contributors, reduce,
                                  observers))
    return (yield from _timed(model, state, n_end, energy_every, end_energy, stepper, contributors, reduce,
                              observers, timing))


def _plain(model, state, n_end, energy_every, end_energy, stepper, contributors, reduce, observers):
    """:func:`evolve` without timing."""
    while state.n < n_end:
        e = {} if energy_every and state.n % energy_every == 0 else None
        stepper(model, state, e)
        for o in contributors:
            o.contribute(state, e)
        if reduce is not None:
            reduce()
        stop = None
        for o in observers:
            why = o.observe(state, e)
            if stop is None:
                stop = why
        yield state, e
        if stop is not None:
            return stop
    if end_energy and state.n == n_end:
        yield state, _at_end(model, state, stepper, observers)
    return None


def energies_at(model, state, stepper=None) -> dict:
    """The energies at the state's time t^n [J/m] (collective), as :func:`step`
    gives them for t^n: the kinetic energy there needs v^{n+½}, so this takes one
    more step and puts the state back as it was (:meth:`State.snapshot` /
    :meth:`State.restore`; the per-phase wall times too)."""
    stepper = step if stepper is None else stepper
    saved, seconds = state.snapshot(), dict(state.seconds)
    energy: dict = {}
    stepper(model, state, energy)
    state.restore(saved)
    state.seconds = seconds
    return energy


def _at_end(model, state, stepper, observers) -> dict:
    """The energies at the end time, handed to the observers that take them."""
    energy = energies_at(model, state, stepper)
    for o in observers:
        at_end = getattr(o, "at_end", None)
        if at_end is not None:
            at_end(state, energy)
    return energy


def _groups(observers, verb: str) -> list:
    """``[(part, [bound verbs])]``: consecutive observers of one part timed together."""
    out = []
    for o in observers:
        part = getattr(o, "part", "other")
        if out and out[-1][0] == part:
            out[-1][1].append(getattr(o, verb))
        else:
            out.append((part, [getattr(o, verb)]))
    return out


def _timed(model, state, n_end, energy_every, end_energy, stepper, contributors, reduce, observers, timing):
    """:func:`evolve` with each part's wall time booked in ``timing`` (consecutive
    observers of one part under one clock reading)."""
    clock, cost = time.perf_counter, timing.cost
    feeds, looks = _groups(contributors, "contribute"), _groups(observers, "observe")
    for name in {p for p, _ in feeds} | {p for p, _ in looks} | {"watch"}:
        cost.setdefault(name, 0.0)
    timing.t0 = clock()
    while state.n < n_end:
        e = {} if energy_every and state.n % energy_every == 0 else None
        t0 = clock()
        stepper(model, state, e)
        t1 = ts = clock()
        if e is None:
            cost["step"] += t1 - t0
        else:
            cost["step_with_energy"] += t1 - t0
            timing.energy_steps += 1
        for part, verbs in feeds:
            for contribute in verbs:
                contribute(state, e)
            t2 = clock()
            cost[part] += t2 - t1
            t1 = t2
        if reduce is not None:
            reduce()
            t2 = clock()
            cost["watch"] += t2 - t1
            t1 = t2
        stop = None
        for part, verbs in looks:
            for look in verbs:
                why = look(state, e)
                if stop is None:
                    stop = why
            t2 = clock()
            cost[part] += t2 - t1
            t1 = t2
        timing.observers_s += t1 - ts
        timing.wall = t1 - timing.t0
        if timing.first_step_s is None:
            timing.first_done(state, t1)
        yield state, e
        if stop is not None:
            return stop
    if end_energy and state.n == n_end:
        t0 = clock()
        energy = _at_end(model, state, stepper, observers)
        cost["step_with_energy"] += clock() - t0
        timing.energy_steps += 1
        yield state, energy
    return None


def run(loop):
    """Drain :func:`evolve`'s generator ``loop``; returns why it stopped (None: the end time)."""
    while True:
        try:
            next(loop)
        except StopIteration as done:
            return done.value
