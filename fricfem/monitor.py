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


#: watchdog codes -> what they mean
_WATCH = {1: "non-finite interface tractions or slip rates", 2: "slip rate beyond the bound",
          3: "energy growth beyond the input work"}


def watchdog_code(points, energy, limits: dict) -> int:
    """0 if the step looks sane, else a code of :data:`_WATCH` (local, no communication).

    Checks every step: finite interface tractions and slip rates, slip rate below
    ``max_slip_rate``; at energy steps: energies finite, and the energy not
    accounted for by the work of the struck edge (the balance error) at most
    ``energy_factor − 1`` times the larger of that work and the kinetic + strain
    energy (a diverging step grows the latter without input; a rupture driven by
    an overstressed patch has no input work but a balanced budget).
    """
    if not limits["enabled"]:
        return 0
    if not (np.isfinite(points.Ts).all() and np.isfinite(points.Tn).all()
            and np.isfinite(points.slip_rate).all()):
        return 1
    if points.slip_rate.size and points.slip_rate.max() > limits["max_slip_rate"]:
        return 2
    if energy is not None:
        excess = energy["balance_error"]
        scale = max(energy["external"], abs(energy["kinetic"]) + abs(energy["strain"]), 1e-12)
        if not np.isfinite(excess) or excess > (limits["energy_factor"] - 1.0) * scale:
            return 3
        # ½ v^{n−½}·M v^{n+½} + ½ u·K u is conserved by central differences at any
        # step; beyond the stable step the growing mode makes the kinetic part negative
        if energy["kinetic"] < -1e-6 * scale:
            return 3
    return 0


def _runaway_note(model) -> str:
    """The Povirk–Needleman law's finite-time slip-rate runaway criterion, if that law is used."""
    law = model.interface.law
    if law.name != "povirk_needleman":
        return "the friction law's slip rate ran away"
    from .friction import povirk_needleman as pn

    p = model.interface.points
    limit = float(np.min(p.params[:, pn.M] * p.params[:, pn.L0] * p.Cs)) if len(p.Cs) else float("nan")
    limit = model.comm.allreduce(limit if np.isfinite(limit) else np.inf, op=MPI.MIN)
    return ("the Povirk–Needleman slip rate runs away in finite time once |T_s| exceeds "
            f"m·L0·C_s = {limit / 1e6:.3g} MPa — a property of the law with these parameters, not of the "
            "step: the loading is beyond what the law can represent (raise interface.Cs or L0, or lower "
            "the loading)")


def _watchdog_message(code: int, t: float, model, limits) -> str:
    ratio = model.dt / model.dt_crit
    if ratio >= 1.0:
        cause = (f"the explicit step is unstable: dt = {model.dt:.3g} s is {ratio:.2f} × the stable step "
                 f"{model.dt_crit:.3g} s — use time.dt_safety < 1 and no larger time.dt")
    elif code == 2:
        cause = _runaway_note(model)
    else:
        cause = ("the interface update diverged at a stable bulk step — check the friction parameters "
                 "and the interface stiffnesses")
    what = _WATCH[code] + (f" ({limits['max_slip_rate']:g} m/s, the material's c_l unless set)"
                           if code == 2 else "")
    return f"watchdog stopped the run at t = {t * 1e6:.3f} µs: {what}; likely cause: {cause}"


class Monitor:
    """Per-step bookkeeping of one run (collective: one small reduction per step).

    After each step, :meth:`observe` records the stations, tracks the leading
    tip (the largest x1 sliding) and the first sliding, takes the energies and
    interface snapshots due, writes the field snapshots due, flushes when the
    wall-clock interval has passed, and returns why the run must stop, if it
    must: ``"watchdog"`` (divergence; :attr:`stopped` says why), ``"tip"``
    (the tip passed ``time.stop_at_tip``; :attr:`ended_early`), ``"signal"``
    (SIGTERM) or None.
    """

    def __init__(self, scene, model, recorder, writer, every: int, flush):
        self.scene = scene
        self.model = model
        self.rec = recorder
        self.writer = writer
        self.every = every  # interface snapshot every this many steps
        self.flush = flush  # callable(state): write what is pending and the summary so far
        self.field_steps = field_steps(scene.output["fields"], model.dt, scene.t_end)
        self.comm = model.comm
        self.tip_t, self.tip_x = [], []
        self.initiation = None
        self.last_energy = None
        self.last_flush = time.perf_counter()
        self.stop_requested = False  # set by the SIGTERM handler
        self.stopped = None
        self.ended_early = None
        self.seconds = 0.0  # wall time spent here [s]
        self.glob = np.full(5, -1.0)
        self.t_loop0 = time.perf_counter()  # when the loop started (reset by the caller)
        self.first_step_s = None  # wall time of the first step, JIT compilation included [s]

    def observe(self, st, e) -> str | None:
        """Bookkeeping after the step that left ``st`` at t^{n+1} (energies ``e`` at t^n or None)."""
        t0 = time.perf_counter()
        scene, p, x1 = self.scene, self.model.interface.points, self.model.interface.geometry.x1
        self.rec.station_step(st.t_interface)
        sliding = p.slip_rate > 0
        local = np.array([x1[sliding].max() if sliding.any() else -1.0,
                          -x1[sliding].min() if sliding.any() else -np.inf,
                          1.0 if self.stop_requested else 0.0,
                          1.0 if (self.comm.rank == 0 and time.perf_counter() - self.last_flush
                                  > scene.output["flush_every"]) else 0.0,
                          watchdog_code(p, e, scene.watchdog)])
        glob = self.glob
        self.comm.Allreduce(local, glob, op=MPI.MAX)
        if glob[0] >= 0:
            self.tip_t.append(st.t_interface)
            self.tip_x.append(glob[0])
            if self.initiation is None:
                self.initiation = {"time_s": st.t_interface, "x1_m": -glob[1], "x1_max_m": glob[0]}
        if e is not None:
            self.last_energy = e
            self.rec.energy(e)
        if (st.n - 1) % self.every == 0:  # the interface at t = 0, every, 2 every, ... steps
            self.rec.snapshot(st.t_interface)
        if st.n in self.field_steps and self.writer is not None:
            self.writer.write(st)
        if glob[3] > 0:
            self.flush(st)
            self.last_flush = time.perf_counter()
        self.seconds += time.perf_counter() - t0
        return self._stop(st, glob)

    def _stop(self, st, glob) -> str | None:
        if glob[4] > 0:
            self.stopped = _watchdog_message(int(glob[4]), st.t, self.model, self.scene.watchdog)
            return "watchdog"
        if self.scene.stop_at_tip and glob[0] > self.scene.stop_at_tip:
            self.ended_early = (f"the sliding tip passed x1 = {self.scene.stop_at_tip * 1e3:g} mm at "
                                f"t = {st.t_interface * 1e6:.3f} µs")
            return "tip"
        if glob[2] > 0:
            return "signal"
        return None

    def tip_text(self) -> str:
        """The progress line's note on the tip."""
        return f"tip {self.glob[0] * 1e3:6.1f} mm" if self.glob[0] >= 0 else "no slip"
