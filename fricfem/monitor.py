"""What a run watches every step: the leading tip and the initiation of
sliding, the outputs due (stations, snapshots, energies, fields, flushes),
divergence (the watchdog), and its progress on the terminal.

All of it is bookkeeping around :func:`fricfem.step.evolve`; nothing here
changes the physics.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from mpi4py import MPI

from .kernels.watch import look
from .scene.output_keys import frame_times
from .scene.validate import field_steps


class Progress:
    """A progress bar with ETA on stderr (rank 0): redrawn every half second on a
    terminal, one line per 10 % otherwise (logs, CI)."""

    def __init__(self, t_end: float, enabled: bool):
        self.t_end = t_end
        self.enabled = enabled
        self.tty = sys.stderr.isatty()
        self.start = time.perf_counter()
        self.last = 0.0
        self.decile = -1

    def update(self, t: float, extra: str = "", force: bool = False) -> None:
        now = time.perf_counter()
        if not self.enabled or (now - self.last < 0.5 and not force):
            return
        decile = int(10 * min(1.0, t / self.t_end))
        if not self.tty and decile == self.decile and not force:
            return
        self.decile = decile
        self.last = now
        frac = min(1.0, t / self.t_end)
        eta = (now - self.start) * (1 - frac) / frac if frac > 0 else float("nan")
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        head, tail = ("\r", "") if self.tty else ("", "\n")
        sys.stderr.write(f"{head}[{bar}] {100 * frac:5.1f}%  t = {t * 1e6:7.2f} / {self.t_end * 1e6:.2f} µs"
                         f"  ETA {eta:6.1f} s  {extra}   {tail}")
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled and self.tty:
            sys.stderr.write("\n")


#: watchdog codes -> what they mean.  Each is a divergence, and only these stop a run:
#: a slip rate, however large, is reported (:class:`Spikes`), never a stop.
_WATCH = {1: "non-finite interface tractions or slip rates", 2: "non-finite energies",
          3: "negative discrete kinetic energy", 4: "the energy budget does not close"}

#: a user's law breaking its contract during a run (:class:`LawWatch`) -> what; codes above the watchdog's
_LAW = {11: "a negative slip rate (the contract: slip rate >= 0)",
        12: "negative frictional work: a point's dissipated energy decreased (the contract: work >= 0)",
        13: "nsub < 0 (the contract: the number of sub-steps used, >= 0)",
        14: "it wrote into its parameter array p (read-only by the contract)",
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

    def __init__(self, interface):
        self.p = interface.points
        self.wq = interface.geometry.wq
        self.rigid = type(interface).__name__ == "RigidInterface"  # no interface spring: nothing stored
        self.params0 = self.p.param_rows.copy()
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
        if not np.array_equal(p.param_rows, self.params0):
            return 14
        if energy_step:
            # two energy steps in a row: the first steps of a law that always slides (rate and state) are a
            # transient of its own quadrature (measured 3.4 % at the first check, then 1e-3, then ~2e-4)
            self.breaches = self.breaches + 1 if self.budget_error() > LAW_BUDGET_TOL else 0
            if self.breaches >= 2:
                return 15
        return 0

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
               abs(energy["interface_work"]), abs(energy["absorbed"]), _ENERGY_FLOOR)


def closure_bound(limits: dict) -> float:
    """The relative bound of the energy checks: ``watchdog.energy_tol``, or the older
    ``watchdog.energy_factor − 1`` when that is tighter (older scenes load unchanged)."""
    return min(limits["energy_tol"], limits["energy_factor"] - 1.0)


def watchdog_code(finite: bool, energy, limits: dict) -> int:
    """0 if the step looks sane, else a code of :data:`_WATCH` (local, no communication).
    ``finite``: whether this rank's interface tractions and slip rates are all
    finite (the monitor's one pass, :func:`fricfem.kernels.watch.look`).

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
    marked diverged, never complete (:attr:`Monitor.diverged`).  The budget's
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

    :meth:`observe` takes the step's largest slip rate over all ranks (from the
    monitor's reduction) and this rank's own with its place; it reduces once
    more, to find the place, only in a step that sets a new peak (all ranks know
    it: collective).
    """

    def __init__(self, threshold: float, comm):
        self.threshold = float(threshold)
        self.comm = comm
        self.peak, self.x1, self.time = 0.0, None, None
        self.first = None  # (time, x1) of the first slip rate above the threshold
        self.steps_above = 0

    def observe(self, vmax: float, t: float, local) -> None:
        """After a step: ``vmax`` the largest slip rate on every rank at time ``t``;
        ``local``: this rank's largest slip rate and the x1 of its first point with
        it (the monitor's pass, :func:`fricfem.kernels.watch.look`: −inf for no points)."""
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


#: the parts of the time loop timed in summary.json's ``loop_cost``: the step
#: (``step``: the steps without energies; ``energy``: what the energy evaluation
#: adds to a step, estimated as the energy steps' time beyond that of as many
#: steps without), and after each step the monitor's parts: the stations'
#: rows, the watch (the one reduction: tip, initiation, watchdog, spikes, the
#: energies' row), interface snapshots, field snapshots and gauges, flushes
#: (the rows' gather and write, the summary so far)
LOOP_PARTS = ("step", "step_with_energy", "stations", "watch", "snapshots", "fields_gauges", "flush")

#: interface rows between two flushes: a kill loses at most this many rows (and
#: ``output.flush_every`` seconds) of a run, whatever the wall time per row
FLUSH_ROWS = 10


class Monitor:
    """Per-step bookkeeping of one run (collective: one small reduction per step).

    After each step, :meth:`observe` records the stations, tracks the leading
    tip (the largest x1 sliding) and the first sliding, takes the energies and
    interface snapshots due, writes the field snapshots due, flushes every
    :data:`FLUSH_ROWS` interface rows and when the wall-clock interval
    ``output.flush_every`` has passed, and returns why the run must stop, if it
    must: ``"watchdog"`` (divergence; :attr:`stopped` says why), ``"tip"``
    (the tip passed ``time.stop_at_tip``; :attr:`ended_early`), ``"signal"``
    (SIGTERM or SIGINT) or None.
    """

    def __init__(self, scene, model, recorder, writer, every: int, flush):
        self.scene = scene
        self.model = model
        self.rec = recorder
        self.writer = writer
        self.every = every  # interface snapshot every this many steps
        self.flush = flush  # callable(state): write what is pending and the summary so far
        # field snapshots: output.fields and the isochromatic frames (output.frames)
        self.field_steps = field_steps(list(scene.output["fields"]) + frame_times(scene.output["frames"]),
                                       model.dt, scene.t_end)
        self.gauges = None  # a fricfem.output.gauges.GaugeWriter, set by the runner when the scene has gauges
        self.comm = model.comm
        self.tip_t, self.tip_x = [], []
        self.initiation = None
        self.last_energy = None
        self.end = {}  # "energy": the energies taken in the run's last step (set by the runner's loop)
        self.rows_pending = 0  # interface rows since the last flush (the same on every rank)
        self.last_flush = time.perf_counter()
        self.stop_requested = False  # set by the SIGTERM and SIGINT handler
        self.stopped = None
        from .friction import BUILT_IN

        self.law_watch = None if model.interface.law.name in BUILT_IN else LawWatch(model.interface)
        self.diverged = None  # the watchdog disabled: why the run diverged (it went on; never complete)
        self.ended_early = None
        self.seconds = 0.0  # wall time spent here [s]
        self.glob = np.full(6, -1.0)
        self.local = np.empty(6)  # this rank's part of the step's one reduction
        self.seen = np.empty(5)  # this rank's points after a step (fricfem.kernels.watch.look)
        self.background = None  # the runner's writer of the periodic summary (fricfem.runner.Background)
        self.wall_checkpoint = None  # rank 0: callable(now) -> whether a checkpoint is due by wall time
        self.spikes = Spikes(scene.watchdog["max_slip_rate"], model.comm)  # reported, never a stop
        self.t_loop0 = time.perf_counter()  # when the loop started (reset by the caller)
        self.first_step_s = None  # wall time of the first step, JIT compilation included [s]
        self.cost = dict.fromkeys(LOOP_PARTS, 0.0)  # wall time per part of the loop [s] (steps 2..n)
        self.energy_steps = 0  # steps (after the first) that also took the energies

    def observe(self, st, e) -> str | None:
        """Bookkeeping after the step that left ``st`` at t^{n+1} (energies ``e`` at t^n or None);
        the wall time of each part goes to :attr:`cost` (:data:`LOOP_PARTS`)."""
        clock, cost = time.perf_counter, self.cost
        t0 = clock()
        scene, p, x1 = self.scene, self.model.interface.points, self.model.interface.geometry.x1
        self.rec.station_step(st.t_interface)
        t1 = clock()
        cost["stations"] += t1 - t0
        seen, local = self.seen, self.local
        look(x1, p.slip_rate, p.Ts, p.Tn, seen)  # tip, first sliding, largest slip rate, finite?
        code = watchdog_code(not seen[3], e if e is not None else self.end.get("energy"), scene.watchdog)
        # the watchdog disabled: a divergence is reduced as code / 10 (< 1, no stop; :meth:`_stop`)
        local[0], local[1], local[5] = seen[0], seen[1], seen[2]
        local[4] = code if scene.watchdog["enabled"] else 0.1 * code
        if self.law_watch is not None:  # a user's law: its contract, every step (codes above the watchdog's)
            local[4] = max(local[4], self.law_watch.code(e is not None))
        local[2] = 1.0 if self.stop_requested else 0.0
        local[3] = 1.0 if (self.comm.rank == 0 and t1 - self.last_flush > scene.output["flush_every"]) else 0.0
        if self.wall_checkpoint is not None and self.comm.rank == 0 and self.wall_checkpoint(t1):
            local[3] = 2.0  # a checkpoint due by wall time: a flush, then the checkpoint (fricfem.runner._checkpoint)
        glob = self.glob
        self.comm.Allreduce(local, glob, op=MPI.MAX)
        self.spikes.observe(glob[5], st.t_interface, (seen[2], seen[4]))
        if glob[0] >= 0:
            self.tip_t.append(st.t_interface)
            self.tip_x.append(glob[0])
            if self.initiation is None:
                self.initiation = {"time_s": st.t_interface, "x1_m": -glob[1], "x1_max_m": glob[0]}
        if e is not None:
            self.last_energy = e
            self.rec.energy(e)
        t2 = clock()
        cost["watch"] += t2 - t1
        if (st.n - 1) % self.every == 0:  # the interface at t = 0, every, 2 every, ... steps
            self.rec.snapshot(st.t_interface)
            self.rows_pending += 1
        t3 = clock()
        cost["snapshots"] += t3 - t2
        if st.n in self.field_steps and self.writer is not None:
            self.writer.write(st)
        if self.gauges is not None:
            self.gauges.observe(st)
        t4 = clock()
        cost["fields_gauges"] += t4 - t3
        if glob[3] > 0 or self.rows_pending >= FLUSH_ROWS:
            self.flush(st)
            self.last_flush = clock()
            self.rows_pending = 0
            cost["flush"] += self.last_flush - t4
        self.seconds += clock() - t0
        return self._stop(st, glob)

    def _stop(self, st, glob) -> str | None:
        if glob[4] >= min(_LAW):
            self.stopped = _law_message(int(glob[4]), st.t, self.model.interface.law.name)
            return "watchdog"
        if glob[4] >= 1:
            self.stopped = _watchdog_message(int(glob[4]), st.t, self.model, self.scene.watchdog)
            return "watchdog"
        if glob[4] > 0 and self.diverged is None:  # watchdog.enabled = false: the run goes on, never complete
            self.diverged = (_watchdog_message(int(round(10 * glob[4])), st.t, self.model, self.scene.watchdog)
                             .replace("watchdog stopped the run", "the run diverged (watchdog.enabled = false: "
                                      "not stopped)"))
        if self.scene.stop_at_tip and glob[0] > self.scene.stop_at_tip:
            self.ended_early = (f"the sliding tip passed x1 = {self.scene.stop_at_tip * 1e3:g} mm at "
                                f"t = {st.t_interface * 1e6:.3f} µs")
            return "tip"
        if glob[2] > 0:
            return "signal"
        return None

    def tip_text(self) -> str:
        """The progress line's note on the tip."""
        tip = f"tip {self.glob[0] * 1e3:6.1f} mm" if self.glob[0] >= 0 else "no slip"
        return tip + self.spikes.text()
