"""What a run watches at every step to know whether to go on: the interface
points seen in one pass (:class:`Look`), divergence (:class:`Watchdog`, with a
user's law's contract, :class:`LawWatch`), the largest slip rate (:class:`Spikes`,
reported, never a stop), the leading tip and the first sliding (:class:`Tip`),
and SIGTERM / SIGINT (:class:`Signals`).

Observers of :func:`fricfem.step.evolve` (the contract: :mod:`fricfem.observe`).
Their global values come from the loop's one reduction a step, in named slots
(:class:`fricfem.step.Reduction`); nothing here changes the physics.
"""

from __future__ import annotations

import signal
import threading

import numpy as np
from mpi4py import MPI

from ..kernels.watch import look


def spike_threshold(scene) -> float:
    """The slip rate above which a spike is reported [m/s]: ``watchdog.max_slip_rate``, which
    the scene's validation resolved (0 written: the material's c_l; fricfem.scene.settings)."""
    return scene.watchdog.max_slip_rate


class Look:
    """This rank's interface points after a step, in one pass
    (:func:`fricfem.kernels.watch.look`): :attr:`seen` (the tip, minus the first
    sliding, the largest slip rate, non-finite?, the x1 of the largest), and over
    all ranks (slots ``tip``, ``first``, ``vmax``): :attr:`tip` (the largest x1
    sliding, −1: none), :attr:`first` (minus the smallest) and :attr:`vmax`.
    The observers after it read these."""

    slots = ("tip", "first", "vmax")
    part = "watch"

    def __init__(self, x1: np.ndarray):
        self.x1 = x1
        self.seen = np.empty(5)
        self.tip, self.first, self.vmax = -1.0, -np.inf, 0.0

    def bind(self, reduction) -> None:
        self.red = reduction
        self.i = [reduction.slot(name) for name in self.slots]

    def contribute(self, state, energy) -> None:
        p, seen, (i_tip, i_first, i_vmax) = state.points, self.seen, self.i
        look(self.x1, p.slip_rate, p.Ts, p.Tn, seen)
        local = self.red.local
        local[i_tip], local[i_first], local[i_vmax] = seen[0], seen[1], seen[2]

    def observe(self, state, energy) -> None:
        glob, (i_tip, i_first, i_vmax) = self.red.values, self.i
        self.tip, self.first, self.vmax = glob[i_tip], glob[i_first], glob[i_vmax]

    def snapshot(self) -> dict:
        return {"tip": float(self.tip), "first": float(self.first), "vmax": float(self.vmax)}

    def restore(self, d: dict) -> None:
        self.tip, self.first, self.vmax = d["tip"], d["first"], d["vmax"]


#: watchdog codes -> what they mean.  Each is a divergence, and only these stop a run:
#: a slip rate, however large, is reported (:class:`Spikes`), never a stop.
_WATCH = {1: "non-finite interface tractions or slip rates", 2: "non-finite energies",
          3: "negative discrete kinetic energy", 4: "the energy budget does not close"}

#: a user's law breaking its contract during a run (:class:`LawWatch`) -> what; codes above the watchdog's
_LAW = {11: "a negative slip rate (the contract: slip rate >= 0)",
        12: "negative frictional work: a point's dissipated energy decreased (the contract: work >= 0)",
        13: "nsub < 0 (the contract: the number of sub-steps used, >= 0)",
        15: "its work does not balance: interface work != stored elastic + dissipated energy"}

#: the relative bound of a user law's interface budget (:class:`LawWatch`), broken at two energy steps in a
#: row: the built-in laws run as user laws close it to 6e-17 (slip weakening, Coulomb) and ~2e-4 (rate and
#: state aging: its sub-steps' quadrature of the work against the step's trapezoid) once past their first steps
LAW_BUDGET_TOL = 0.02


class LawWatch:
    """A user's friction law checked as it runs (its checks at registration see a few
    calls only): slip rate >= 0, each point's dissipated energy never decreasing,
    nsub >= 0, its parameter rows unchanged, every step (vectorised,
    this rank's points, no communication); and at energy steps the interface's
    budget over this rank's points,

        W − E_el − D + Σ w T_s0 s = 0,

    W the work the bulk did on the interface (booked against the initial
    tractions), E_el the energy the interface springs store, D the work the law
    booked as dissipated and s the signed slip (tracked here), within
    :data:`LAW_BUDGET_TOL` of Σ w (|W| + E_el + |D| + |T_s0 s|), at two energy
    steps in a row: a law that slips but books no work, or books work it did not
    do, breaks it.  :meth:`code` returns 0 or a
    code of :data:`_LAW`.  Built-in laws are not watched (the suite checks them)."""

    def __init__(self, interface, points):
        self.p = points  # the run's points (fricfem.step.State.points), updated in place
        self.wq = interface.geometry.wq
        self.rigid = type(interface).__name__ == "RigidInterface"  # no interface spring: nothing stored
        self.d_last = self.p.dissipated.copy()
        self.slip_last = self.p.slip.copy()
        self.signed = np.zeros_like(self.p.slip)
        self.breaches = 0  # energy steps in a row whose budget broke the bound

    def code(self, energy_step: bool) -> int:
        p = self.p
        dslip = p.slip - self.slip_last
        self.signed += np.sign(p.Ts) * dslip
        self.slip_last[:] = p.slip
        if p.slip_rate.min(initial=0.0) < 0.0:
            return 11
        if np.any(p.dissipated < self.d_last):
            return 12
        self.d_last[:] = p.dissipated
        if p.nsub.min(initial=0) < 0:
            return 13
        if energy_step:
            # two energy steps in a row: the first steps of a law that always slides (rate and state) are a
            # transient of its own quadrature (measured 3.4 % at the first check, then 1e-3, then ~2e-4)
            self.breaches = self.breaches + 1 if self.budget_error() > LAW_BUDGET_TOL else 0
            if self.breaches >= 2:
                return 15
        return 0

    def snapshot(self) -> dict:
        """Its accumulators: ``breaches`` and this rank's per-point arrays (copies)."""
        return {"breaches": self.breaches, "d_last": self.d_last.copy(), "slip_last": self.slip_last.copy(),
                "signed": self.signed.copy()}

    def restore(self, d: dict) -> None:
        self.breaches = int(d["breaches"] or 0)
        self.d_last[:], self.slip_last[:], self.signed[:] = d["d_last"], d["slip_last"], d["signed"]

    def budget_error(self) -> float:
        """|W − E_el − D + Σ w T_s0 s| / Σ w (|W| + E_el + |D| + |T_s0 s|) over this rank's
        points (0: nothing yet)."""
        p, w = self.p, self.wq
        if self.rigid:
            elastic = np.zeros_like(p.work)
        else:
            closed = p.is_open == 0
            elastic = np.where(closed, 0.5 * p.Cn * p.jump_n ** 2, 0.0)
            elastic += np.where(p.Cs > 0, 0.5 * (p.Ts - p.Ts0) ** 2 / np.where(p.Cs > 0, p.Cs, 1.0), 0.0)
        pre = p.Ts0 * self.signed  # the initial traction's work on the slip (W is booked against it)
        res = float(np.dot(w, p.work - elastic - p.dissipated + pre))
        size = float(np.dot(w, np.abs(p.work) + elastic + np.abs(p.dissipated) + np.abs(pre)))
        return abs(res) / size if size > 1e-300 else 0.0


_LAW_MIN = min(_LAW)


def _law_message(code: int, t: float, law: str) -> str:
    return (f"the run was stopped at t = {t * 1e6:.3f} µs: friction law {law!r} broke its contract "
            f"(fricfem.friction.base): {_LAW[code]}")


#: Energies below this [J/m] are round-off (the floor of the energy scale at t = 0).
_ENERGY_FLOOR = 1e-12


def energy_scale(energy: dict) -> float:
    """The scale [J/m] the energy checks are relative to: the largest of the
    external work, kinetic + strain energy, the interface work and the energy the
    absorbing edges took (a rupture from an overstressed patch has no external
    work, but its released interface work is of the order of the others)."""
    return max(abs(energy["external"]), abs(energy["kinetic"]) + abs(energy["strain"]),
               abs(energy["interface_work"]), abs(energy["absorbed"]), abs(energy.get("viscous", 0.0)), _ENERGY_FLOOR)


def closure_bound(limits: dict) -> float:
    """The relative bound of the energy checks: ``watchdog.energy_tol``, or the older
    ``watchdog.energy_factor − 1`` when that is tighter (older scenes load unchanged)."""
    return min(limits["energy_tol"], limits["energy_factor"] - 1.0)


def watchdog_code(finite: bool, energy, limits: dict) -> int:
    """0 if the step looks sane, else a code of :data:`_WATCH` (local, no communication).
    ``finite``: whether this rank's interface tractions and slip rates are all
    finite (:class:`Look`'s one pass, :func:`fricfem.kernels.watch.look`).

    Every step: finite interface tractions and slip rates.  At energy steps
    (``output.energy_every``), with ε = :func:`closure_bound` and E the
    :func:`energy_scale`:

    * the energies are finite;
    * the kinetic energy ½ v^{n−½}·M v^{n+½} ≥ −ε E.  Central differences
      conserve it plus ½ u·K u at any step; beyond the stable step the growing
      mode alternates in sign from half-step to half-step and makes it negative
      (about −E/2 once the mode dominates).  No run at a stable step has shown a
      negative value (docs/model.md, "The watchdog");
    * the balance error K + S + W_int + W_abs − W_ext is at most ε E.  Every term
      is booked as the trapezoid over the step of the central-difference identity,
      so the budget closes to round-off (≤ 2.1e-13 E measured); a breach means a
      force acted that the budget does not see, or the sums lost their precision.

    Codes 1–3 are a divergence whatever ``watchdog.enabled`` says (no such state
    is a result); with the watchdog disabled the run goes on to its end but is
    marked diverged, never complete (:attr:`Watchdog.diverged`).  The budget's
    closure (4) is checked only with the watchdog enabled.

    A large slip rate is *not* a divergence: the Povirk–Needleman point's slip
    rate is bounded over any finite time, and peaks far above c_l are genuine at
    strong loading (docs/friction_reference.md §4).
    """
    if not finite:
        return 1
    if energy is not None:
        if not all(np.isfinite(energy[k]) for k in ("kinetic", "strain", "external", "interface_work",
                                                     "absorbed", "balance_error")):
            return 2
        eps = closure_bound(limits)
        scale = energy_scale(energy)
        if energy["kinetic"] < -eps * scale:
            return 3
        if limits["enabled"] and abs(energy["balance_error"]) > eps * scale:
            return 4
    return 0


def _watchdog_message(code: int, t: float, model, limits) -> str:
    ratio = model.dt / model.dt_crit
    if ratio >= 1.0:
        cause = (f"the explicit step is unstable: dt = {model.dt:.3g} s is {ratio:.2f} × the stable step "
                 f"{model.dt_crit:.3g} s — use time.dt_safety < 1 and no larger time.dt")
    elif code == 3:
        cause = ("the explicit step went unstable below the estimated stable step: the estimate of λmax is "
                 "short for this mesh and interface — lower time.dt_safety")
    elif code == 4:
        cause = ("a force acted that the energy budget does not book, or its sums lost their precision "
                 f"(bound {closure_bound(limits):.3g} × the energy scale; watchdog.energy_tol)")
    else:
        cause = ("the interface update diverged at a stable bulk step — check the friction parameters "
                 "and the interface stiffnesses")
    return f"watchdog stopped the run at t = {t * 1e6:.3f} µs: {_WATCH[code]}; likely cause: {cause}"


class Spikes:
    """The largest slip rate of a run, where and when, and the spikes above the
    report threshold ``watchdog.max_slip_rate`` (the material's c_l unless set):
    reported in summary.json (``slip_rate_spike``) and on the progress line,
    never a stop (docs/model.md, "The watchdog").

    :meth:`see` takes the step's largest slip rate over all ranks (from the
    loop's reduction) and this rank's own with its place; it reduces once
    more, to find the place, only in a step that sets a new peak (all ranks know
    it: collective).  As an observer (``look`` given: :class:`Look`), it sees
    each step's.
    """

    part = "watch"

    def __init__(self, threshold: float, comm, look=None):
        self.threshold = float(threshold)
        self.comm = comm
        self.look = look
        self.peak, self.x1, self.time = 0.0, None, None
        self.first = None  # (time, x1) of the first slip rate above the threshold
        self.steps_above = 0

    def observe(self, state, energy) -> None:
        vmax = self.look.vmax
        if vmax > self.threshold or vmax > self.peak:  # else :meth:`see` changes nothing (a NaN neither)
            seen = self.look.seen
            self.see(vmax, state.t_interface, (seen[2], seen[4]))

    def finish(self, state) -> dict:
        return {"slip_rate_spike": self.report()}

    def snapshot(self) -> dict:
        return {"peak": self.peak, "x1": self.x1, "time": self.time, "first": self.first,
                "steps_above": self.steps_above}

    def restore(self, d: dict) -> None:
        self.peak, self.x1, self.time, self.steps_above = d["peak"], d["x1"], d["time"], d["steps_above"]
        self.first = None if d["first"] is None else tuple(d["first"])

    def see(self, vmax: float, t: float, local) -> None:
        """After a step: ``vmax`` the largest slip rate on every rank at time ``t``;
        ``local``: this rank's largest slip rate and the x1 of its first point with
        it (:func:`fricfem.kernels.watch.look`: −inf for no points)."""
        if vmax > self.threshold:
            self.steps_above += 1
        if not vmax > self.peak:  # also a NaN (the watchdog stops on it)
            return
        here = float(local[1]) if local[0] == vmax else -np.inf
        if self.comm.size > 1:
            buf = np.array([here])
            self.comm.Allreduce(MPI.IN_PLACE, buf, op=MPI.MAX)
            here = float(buf[0])
        self.peak, self.time, self.x1 = float(vmax), t, here
        if self.first is None and vmax > self.threshold:
            self.first = (t, self.x1)

    def text(self) -> str:
        """The progress line's note: the peak once it passed the threshold, else ''."""
        if self.first is None:
            return ""
        return (f"  spike {self.peak:.3g} m/s at x1 = {self.x1 * 1e3:.1f} mm, t = {self.time * 1e6:.2f} µs "
                f"(> {self.threshold:.4g} m/s)")

    def report(self) -> dict:
        """summary.json's ``slip_rate_spike``: the peak slip rate with its place and
        time, and whether, when, where and for how many steps it passed the threshold."""
        first = None if self.first is None else {"time_s": self.first[0], "x1_m": self.first[1]}
        return {"threshold_m_s": self.threshold, "peak_m_s": self.peak, "x1_m": self.x1, "time_s": self.time,
                "above_threshold": first is not None, "first_above": first, "steps_above": self.steps_above}


class Watchdog:
    """Divergence, every step (:func:`watchdog_code`, from :class:`Look`'s pass and
    the energies when the step took them), and a user's law's contract
    (:class:`LawWatch`; ``law_watch`` None for a built-in law): the worst code
    over all ranks (slot ``watchdog``) stops the run (``"watchdog"``;
    :attr:`stopped` says why), or with ``watchdog.enabled = false`` marks it
    diverged (:attr:`diverged`) and lets it go on.  ``energy_every``: the
    energies' cadence (a user law's budget is checked at those steps)."""

    slots = ("watchdog",)
    part = "watch"

    def __init__(self, model, limits: dict, look_: Look, energy_every: int, law_watch=None):
        self.model = model
        self.limits = limits
        self.look = look_
        self.energy_every = energy_every
        self.law_watch = law_watch
        self.stopped = None
        self.diverged = None

    def bind(self, reduction) -> None:
        self.red = reduction
        self.i = reduction.slot("watchdog")

    def contribute(self, state, energy) -> None:
        finite = not self.look.seen[3]
        code = watchdog_code(finite, energy, self.limits) if energy is not None else (0 if finite else 1)
        # the watchdog disabled: a divergence is reduced as code / 10 (< 1, no stop; :meth:`observe`)
        mine = code if self.limits["enabled"] else 0.1 * code
        if self.law_watch is not None:  # a user's law: its contract, every step (codes above the watchdog's)
            every = self.energy_every
            cadence = energy is not None and bool(every) and (state.n - 1) % every == 0
            mine = max(mine, self.law_watch.code(cadence))
        self.red.local[self.i] = mine

    def observe(self, state, energy) -> str | None:
        worst = self.red.values[self.i]
        if worst >= _LAW_MIN:
            self.stopped = _law_message(int(worst), state.t, self.model.interface.law.name)
            return "watchdog"
        if worst >= 1:
            self.stopped = _watchdog_message(int(worst), state.t, self.model, self.limits)
            return "watchdog"
        if worst > 0 and self.diverged is None:  # watchdog.enabled = false: the run goes on, never complete
            self.diverged = (_watchdog_message(int(round(10 * worst)), state.t, self.model, self.limits)
                             .replace("watchdog stopped the run", "the run diverged (watchdog.enabled = false: "
                                      "not stopped)"))
        return None

    def finish(self, state) -> dict:
        return {"watchdog": self.stopped, **({"diverged": self.diverged} if self.diverged else {})}

    def snapshot(self) -> dict:
        """What it keeps (and its law watch's, ``law_watch``: :meth:`LawWatch.snapshot`)."""
        return {"stopped": self.stopped, "diverged": self.diverged,
                "law_watch": None if self.law_watch is None else self.law_watch.snapshot()}

    def restore(self, d: dict) -> None:
        self.stopped, self.diverged = d["stopped"], d["diverged"]
        if self.law_watch is not None:
            self.law_watch.restore(d["law_watch"])


class Tip:
    """The leading tip (the largest x1 sliding, every step: :attr:`tip_t`,
    :attr:`tip_x`) and the first sliding (:attr:`initiation`), from :class:`Look`;
    stops the run (``"tip"``; :attr:`ended_early`) once the tip passes ``stop_at``
    [m] (0: never)."""

    part = "watch"

    def __init__(self, look_: Look, stop_at: float = 0.0):
        self.look = look_
        self.stop_at = stop_at
        self.tip_t, self.tip_x = [], []
        self.initiation = None
        self.ended_early = None

    def observe(self, state, energy) -> str | None:
        tip = self.look.tip
        if tip >= 0:
            t = state.t_interface
            self.tip_t.append(t)
            self.tip_x.append(tip)
            if self.initiation is None:
                self.initiation = {"time_s": t, "x1_m": -self.look.first, "x1_max_m": tip}
            if self.stop_at and tip > self.stop_at:
                self.ended_early = (f"the sliding tip passed x1 = {self.stop_at * 1e3:g} mm at "
                                    f"t = {state.t_interface * 1e6:.3f} µs")
                return "tip"
        return None

    def finish(self, state) -> dict:
        return {"initiation": self.initiation, "ended_early": self.ended_early}

    def snapshot(self) -> dict:
        return {"tip_t": list(self.tip_t), "tip_x": list(self.tip_x), "initiation": self.initiation,
                "ended_early": self.ended_early}

    def restore(self, d: dict) -> None:
        self.tip_t, self.tip_x = [float(t) for t in d["tip_t"]], [float(x) for x in d["tip_x"]]
        self.initiation, self.ended_early = d["initiation"], d["ended_early"]

    def text(self) -> str:
        """The progress line's note on the tip."""
        return f"tip {self.look.tip * 1e3:6.1f} mm" if self.look.tip >= 0 else "no slip"


class Signals:
    """SIGTERM and SIGINT (Ctrl-C) end the run cleanly at the next step on every
    rank (slot ``signal``: ``"signal"``), its outputs finalised; a second Ctrl-C
    stops at once (KeyboardInterrupt).  A context manager: the handlers are
    installed (from the main thread only) on entry and the previous ones put
    back on exit."""

    slots = ("signal",)
    part = "watch"

    def __init__(self):
        self.requested = False
        self.previous = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.previous = {sig: signal.signal(sig, self._handle) for sig in (signal.SIGTERM, signal.SIGINT)}
        return self

    def __exit__(self, *exc) -> None:
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
        self.previous = {}

    def _handle(self, signum, frame) -> None:
        if signum == signal.SIGINT and self.requested:  # a second Ctrl-C: stop now
            raise KeyboardInterrupt
        self.requested = True

    def bind(self, reduction) -> None:
        self.red = reduction
        self.i = reduction.slot("signal")

    def contribute(self, state, energy) -> None:
        self.red.local[self.i] = 1.0 if self.requested else 0.0

    def observe(self, state, energy) -> str | None:
        return "signal" if self.red.values[self.i] > 0 else None
