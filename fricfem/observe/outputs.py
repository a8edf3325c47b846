"""What a run writes as it goes, as observers of :func:`fricfem.step.evolve`:
the stations' rows (:class:`Stations`), the energies (:class:`Energies`), the
interface snapshots (:class:`Snapshots`), field snapshots (:class:`Fields`),
gauges (:class:`Gauges`), the flushes and the periodic summary
(:class:`Flusher`, :class:`Background`), the progress line (:class:`Progress`,
:class:`ProgressLine`) and a caller's function (:class:`Callback`); and the
loop's cost by part (:func:`loop_cost`).

The writers themselves are :mod:`fricfem.output`'s; an observer decides when
they write, and is finished by whoever made it (:meth:`finish`).
"""

from __future__ import annotations

import sys
import threading
import time

from ..output.quantities import ENERGY, GAUGES_FILE
from ..output.record import replace_texts

#: the parts of the time loop timed in summary.json's ``loop_cost``: the step
#: (``step``: the steps without energies; ``energy``: what the energy evaluation
#: adds to a step, estimated as the energy steps' time beyond that of as many
#: steps without), and after each step the observers' parts: the stations'
#: rows, the watch (the one reduction: tip, initiation, watchdog, spikes, the
#: energies' row), interface snapshots, field snapshots and gauges, flushes
#: (the rows' gather and write, the summary so far)
LOOP_PARTS = ("step", "step_with_energy", "stations", "watch", "snapshots", "fields_gauges", "flush")

#: interface rows between two flushes: a kill loses at most this many rows (and
#: ``output.flush_every`` seconds) of a run, whatever the wall time per row
FLUSH_ROWS = 10


class Stations:
    """The stations' rows, every step (:meth:`fricfem.output.recorder.Recorder.station_step`)."""

    part = "stations"

    def __init__(self, recorder):
        self.rec = recorder

    def observe(self, state, energy) -> None:
        self.rec.station_step(state.t_interface)


class Energies:
    """The energies: a row of the recorder at each step on the cadence
    ``energy_every`` (:attr:`last`, the latest), and those at the run's end time
    (:attr:`end`: the state after its last step ``n_end``, t^N; the loop hands
    them to :meth:`at_end`)."""

    part = "watch"

    def __init__(self, recorder, energy_every: int, n_end: int):
        self.rec = recorder
        self.every = energy_every
        self.n_end = n_end
        self.last = None
        self.end = None

    def observe(self, state, energy) -> None:
        if energy is None:
            return
        if self.every and (state.n - 1) % self.every == 0:
            self.last = energy
            self.rec.energy(energy)

    def at_end(self, state, energy) -> None:
        """The energies at the end time t^N (``state.t``), the loop's last hand-out."""
        self.end = energy

    def snapshot(self) -> dict:
        return {"last": self.last, "end": self.end}

    def restore(self, d: dict) -> None:
        self.last, self.end = d["last"], d["end"]

    def finish(self, state) -> dict:
        """summary.json's ``energy`` budget [J/m]: at the run's last step, or at the last
        evaluation when the run stopped early."""
        e = self.end if self.end is not None else self.last
        if e is None:
            return {"energy": None}
        return {"energy": {"time_s": e["time"], "at": "end" if self.end is not None else
                           "last evaluation (the run stopped early)",
                           **{k: e[k] for k in ENERGY if k != "time"}, "interface": e["interface_elastic"]}}


class Snapshots:
    """An interface snapshot into the recorder every ``every`` steps (the interface at
    t = 0, every, 2 every, ... steps); :attr:`pending` rows since the last flush."""

    part = "snapshots"

    def __init__(self, recorder, every: int):
        self.rec = recorder
        self.every = every
        self.pending = 0

    def observe(self, state, energy) -> None:
        if (state.n - 1) % self.every == 0:
            self.rec.snapshot(state.t_interface)
            self.pending += 1

    def snapshot(self) -> dict:
        return {"pending": self.pending}

    def restore(self, d: dict) -> None:
        self.pending = int(d["pending"])


class Fields:
    """Field snapshots at the steps ``steps`` (a set: output.fields and the frames)."""

    part = "fields_gauges"

    def __init__(self, writer, steps):
        self.writer = writer
        self.steps = steps

    def observe(self, state, energy) -> None:
        if state.n in self.steps:
            self.writer.write(state)

    def finish(self, state) -> dict:
        self.writer.close()
        return {}


class Gauges:
    """The gauges' row every step (:class:`fricfem.output.gauges.GaugeWriter`; the
    state at t = 0 is written when this is made)."""

    part = "fields_gauges"

    def __init__(self, writer, state, at_start: bool = True):
        self.writer = writer
        if at_start:  # the state at t = 0 (not when a run resumes)
            writer.observe(state)

    def observe(self, state, energy) -> None:
        self.writer.observe(state)

    def finish(self, state) -> dict:
        """Close the file; one that cannot be compacted stays as laid out, and says so."""
        try:
            self.writer.close()
        except OSError as err:  # the laid-out file stays, its NaN rows not computed

            return {"gauges_file": f"{GAUGES_FILE} kept as laid out (rows past the run's end are NaN), not "
                                   f"compacted: {err.filename}: {err.strerror}"}
        return {}


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

    def due(self) -> bool:
        """Whether :meth:`update` would draw now (half a second since the last line)."""
        return self.enabled and time.perf_counter() - self.last >= 0.5

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


class Background:
    """Rank 0's periodic ``summary.json``, its file written by a thread while the
    loop goes on: replacing a file waits for the disk (~2 ms on ext4, little of it
    CPU), ~40 steps' worth of waiting per flush on the reference mesh otherwise;
    the text is made in the run's thread (the thread only makes system calls,
    which release Python's lock).  One thread for the run, started with the first
    write; a write submitted while another waits replaces it (the newer summary
    supersedes the older).  :meth:`wait` returns once nothing is pending; it and
    :meth:`submit` raise, in the run's thread, the error of a write that failed
    (so a full disk still ends the run with its message)."""

    def __init__(self):
        self.cond = threading.Condition()
        self.pending = None
        self.busy = False
        self.error = None
        self.thread = None
        self.closing = False

    def submit(self, fn, *args) -> None:
        self._raise()
        with self.cond:
            self.pending = (fn, args)
            self.cond.notify_all()
        if self.thread is None:
            self.thread = threading.Thread(target=self._work, daemon=True, name="fricfem-summary")
            self.thread.start()

    def _work(self) -> None:
        while True:
            with self.cond:
                while self.pending is None and not self.closing:
                    self.cond.wait()
                if self.pending is None:  # closing, nothing left
                    return
                (fn, args), self.pending, self.busy = self.pending, None, True
            try:
                fn(*args)
            except BaseException as err:  # raised in the run's thread
                self.error = err
            with self.cond:
                self.busy = False
                self.cond.notify_all()

    def wait(self) -> None:
        with self.cond:
            while self.pending is not None or self.busy:
                self.cond.wait()
        self._raise()

    def close(self) -> None:
        """:meth:`wait`, then end the thread (a sweep runs many scenes in one process)."""
        try:
            self.wait()
        finally:
            with self.cond:
                self.closing = True
                self.cond.notify_all()
            if self.thread is not None:
                self.thread.join()
                self.thread = None

    def _raise(self) -> None:
        if self.error is not None:
            err, self.error = self.error, None
            raise err


class Flusher:
    """Writes what is pending: every :data:`FLUSH_ROWS` interface snapshots
    (``snapshots``: :class:`Snapshots`) and whenever ``flush_every`` seconds of
    wall time have passed on rank 0 (slot ``flush``, so every rank flushes in
    the same step): the recorder's rows, the gauges' (``gauges``: a
    GaugeWriter or None), and the summary so far, ``summary(state)`` -> the
    texts of :func:`fricfem.output.record.record_texts` (rank 0; at most every
    ``flush_every`` seconds), written by a thread (:class:`Background`) while the
    loop goes on.  :meth:`finish` waits for that thread: the last periodic
    summary is on disk before the final one."""

    slots = ("flush",)
    part = "flush"

    def __init__(self, recorder, snapshots: Snapshots, gauges, flush_every: float, comm, summary):
        self.rec = recorder
        self.snapshots = snapshots
        self.gauges = gauges
        self.flush_every = flush_every
        self.rank0 = comm.rank == 0
        self.summary = summary
        self.background = Background()
        self.last = time.perf_counter()
        self.last_summary = -float("inf")

    def bind(self, reduction) -> None:
        self.red = reduction
        self.i = reduction.slot("flush")

    def contribute(self, state, energy) -> None:
        due = self.rank0 and time.perf_counter() - self.last > self.flush_every
        self.red.local[self.i] = 1.0 if due else 0.0

    def observe(self, state, energy) -> None:
        if self.red.values[self.i] > 0 or self.snapshots.pending >= FLUSH_ROWS:
            self.flush(state)

    def flush(self, state) -> None:
        self.rec.flush()
        if self.gauges is not None:
            self.gauges.flush()
        now = time.perf_counter()
        if self.rank0 and now - self.last_summary >= self.flush_every:
            # the text now, the files while the loop goes on (a rename waits for the disk)
            self.last_summary = now
            self.background.submit(replace_texts, self.summary(state))
        self.last = time.perf_counter()
        self.snapshots.pending = 0

    def finish(self, state) -> dict:
        self.rec.flush()
        self.background.close()
        return {}


class Callback:
    """A caller's ``fn(state)`` after every step (tests, custom monitors)."""

    part = "callback"

    def __init__(self, fn):
        self.fn = fn

    def observe(self, state, energy) -> None:
        self.fn(state)


class ProgressLine:
    """The progress line (:class:`Progress`) after every step, with the tip and the
    spikes' notes (``tip``: :class:`fricfem.observe.watch.Tip`, ``spikes``:
    :class:`fricfem.observe.watch.Spikes`); :meth:`finish` draws the last one."""

    part = "progress"

    def __init__(self, progress: "Progress", tip, spikes):
        self.progress = progress
        self.tip = tip
        self.spikes = spikes

    def observe(self, state, energy) -> None:
        if self.progress.due():  # the notes are formatted only for a line drawn
            self.progress.update(state.t, self.tip.text() + self.spikes.text())

    def finish(self, state) -> dict:
        self.progress.update(state.t, self.tip.text() + self.spikes.text(), force=True)
        self.progress.close()
        return {}


def loop_cost(timing, steps: int, loop_wall: float) -> dict:
    """summary.json's ``loop_cost``: the time loop's wall time per step [µs] by part
    (:data:`LOOP_PARTS`), over the steps after the first, on rank 0
    (``timing``: the loop's :class:`fricfem.step.Timing`).

    ``energy``: what the energy evaluations added to their steps (their steps' time
    beyond as many steps without); ``step``: the rest of the steps' time; then the
    observers' parts; ``outputs`` all but the step; ``total`` their sum; ``wall``:
    the loop's measured wall time (``loop_wall`` [s], the first step excluded) per
    step, the parts and what is not in them (the progress line)."""
    c, n = timing.cost, steps - 1
    if n < 1:
        return {"steps": max(n, 0)}
    ne = timing.energy_steps
    plain = c["step"] / (n - ne) if n > ne else c["step_with_energy"] / n
    energy = max(c["step_with_energy"] - plain * ne, 0.0)
    parts = {"step": c["step"] + c["step_with_energy"] - energy, "energy": energy,
             **{k: c.get(k, 0.0) for k in LOOP_PARTS[2:]}}
    total = sum(parts.values())
    return {"unit": "µs of wall-clock time per step (rank 0), the mean over the steps after the first",
            "steps": n, "energy_steps": ne, **{k: 1e6 * v / n for k, v in parts.items()},
            "outputs": 1e6 * (total - parts["step"]) / n, "total": 1e6 * total / n,
            "wall": 1e6 * (loop_wall - (timing.first_step_s or 0.0)) / n,
            "outputs_share": (total - parts["step"]) / total if total > 0 else 0.0}
