"""Run a scene: build, step, record, diagnose — writing the run directory as it goes.

    scene ─► model (fricfem.model.build) ─► state, step, evolve (fricfem.step)
          ─► monitor (fricfem.monitor) ─► recorder, field writer (fricfem.output)
          ─► diagnostics (fricfem.analysis) ─► summary.json

The run directory's format: :mod:`fricfem.output.quantities`.  Files are
flushed as the run goes (every :data:`fricfem.monitor.FLUSH_ROWS` interface rows and every
``output.flush_every`` seconds), each so that a kill at any instant leaves it
readable (:mod:`fricfem.output.recorder`, :mod:`fricfem.output.fields`,
:mod:`fricfem.output.record`); ``summary.json`` says ``"complete": false``
until the run ends.  The directory is locked while the run writes it
(:mod:`fricfem.output.directory`).

An exception on one rank would leave the others waiting in a collective: on
more than one rank it ends the whole job (``MPI_Abort``) after printing one
line, and the outputs keep what was flushed (:func:`_guarded`).
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from . import scene as scene_mod
from .model.build import build_model
from .monitor import LOOP_PARTS, Monitor, Progress
from .output.quantities import ENERGY, FIELDS_FILE, INTERFACE_FILE
from .output.gauges import GAUGES_FILE, GaugeWriter
from .output import checkpoint, directory
from .output.directory import RunDirError
from .output.record import record_texts, replace_texts, whole, write_record
from .output.recorder import Recorder, planned_rows
from .scene import Scene, SceneError
from .scene.validate import check_identifier
from .scene.output_keys import frame_times
from .step import State
from .step.stepper import step

#: the files a run writes into its directory (``--overwrite`` removes what a manifest lists)
RUN_FILES = directory.RUN_FILES


def prepare_outdir(out: Path, comm, overwrite: bool):
    """Make, lock and (``overwrite``) clear the run directory before any heavy work
    (:func:`fricfem.output.directory.prepare`; collective); the lock on rank 0."""
    lock = problem = None
    if comm.rank == 0:
        try:
            lock = directory.prepare(out, overwrite)
        except RunDirError as err:
            problem = str(err)
    problem = comm.bcast(problem, root=0)
    if problem:
        raise RunDirError(problem)
    return lock


def check_laws(scene: Scene, comm) -> None:
    """The friction laws registered by the user are the same on every rank (collective:
    one allgather of their names and definitions), else a :class:`SceneError` on every
    rank naming the law and the ranks that have it (fricfem.register_law runs on each)."""
    if comm.size == 1:
        return
    from .friction import BUILT_IN, LAWS

    mine = {name: repr((law.params, law.state, law.memo)) for name, law in LAWS.items() if name not in BUILT_IN}
    everyone = comm.allgather((mine, scene.law))
    names = sorted({n for laws, _ in everyone for n in laws} | {law for _, law in everyone if law not in BUILT_IN})
    for name in names:
        held = [r for r, (laws, _) in enumerate(everyone) if name in laws]
        if len(held) != comm.size:
            raise SceneError(f"friction law {name!r} is registered on rank(s) {held} of {comm.size} only: call "
                             "fricfem.register_law on every rank (the same script runs on each)")
        if len({laws[name] for laws, _ in everyone}) > 1:
            raise SceneError(f"friction law {name!r} is registered with different parameters or state on "
                             "different ranks: register the same law on every rank")
    if len({law for _, law in everyone}) > 1:
        raise SceneError(f"friction.law differs between ranks ({[law for _, law in everyone]}): every rank runs "
                         "the same scene")


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


def _check_step(scene: Scene, model, comm) -> None:
    """Refuse a step above the stable one unless the scene allows it."""
    if model.dt <= model.dt_crit:
        return
    if not scene.allow_unstable_dt:
        raise SceneError(f"time.dt = {model.dt:.3g} s exceeds the stable step {model.dt_crit:.3g} s of this "
                         "mesh and interface; use time.dt_safety in (0, 1) (or set "
                         "time.allow_unstable_dt = true for a stability experiment)")
    if comm.rank == 0:
        then = ("the watchdog will stop the run if it diverges" if scene.watchdog["enabled"] else
                "a divergence marks the run diverged, never complete (watchdog.enabled = false: not stopped)")
        sys.stderr.write(f"fricfem: warning: time.dt = {model.dt:.3g} s exceeds the stable step "
                         f"{model.dt_crit:.3g} s; {then}\n")


def _summary(scene: Scene, pm, model, comm) -> dict:
    """The summary's head: what was run, on what."""
    return {
        "scene": scene.name, "description": scene.description, "complete": False, "ranks": comm.size,
        "dofs": 2 * pm.mesh.topology.index_map(0).size_global,
        "interface_points": int(comm.allreduce(len(model.interface.geometry.x1))),
        "dt_s": model.dt, "dt_crit_s": model.dt_crit, "steps": 0, "t_end_s": scene.t_end,
        "speeds": scene.material.speeds(), "input": scene.raw,
        # what fricfem plot needs for the isochromatic frames (output.frames, thickness, f_sigma)
        "photoelastic": {"thickness_m": scene.output["thickness"], "f_sigma_N_per_m": scene.output["f_sigma"],
                         "frames_s": frame_times(scene.output["frames"])},
    }


def _diagnose(rec: Recorder, tip_t, tip_x, speeds, every: int) -> dict:
    """Tip speed, fronts and mode from the recorded history (rank 0).

    The tip is tracked every step; V_tip is the 5-point progressive fit on the
    tip sampled at the interface-snapshot cadence (``every`` steps), so that a
    window spans a few Gauss-point spacings rather than one staircase step.
    """
    from . import analysis

    out = {}
    t = np.asarray(tip_t)
    x = np.asarray(tip_x)
    tv, v = analysis.tip_speed(t[::every], x[::every])
    out["tip"] = {"time_s": t, "x1_m": x, "v_tip_time_s": tv, "v_tip_m_s": v}
    times, rate = rec.history()
    if len(times) >= 2:
        fr = analysis.fronts(times, rec.x1, rate, speeds)
        label, evidence = analysis.classify(times, rec.x1, rate, speeds)
        out["fronts"] = [f.to_dict() for f in fr]
        out["mode"] = {"label": label, "evidence": evidence}
    return out


def n_steps(model, t_end: float) -> int:
    """The number of steps to ``t_end`` (as :func:`fricfem.step.evolve` counts them)."""
    return int(math.floor(t_end / model.dt + 1e-9))


def _steps(model, state, t_end: float, energy_every: int, monitor: Monitor):
    """:func:`fricfem.step.evolve` that also takes the energies in the last step:
    yields ``(state, energies on the cadence or None)``; the last step's energies
    (at t^n of that step, the last time the energies can be had) go to ``monitor.end["energy"]``.
    The wall time of each step goes to ``monitor.cost["step"]`` or, for a step that
    took the energies, ``["step_with_energy"]`` (counted in ``monitor.energy_steps``)."""
    n_end = n_steps(model, t_end)
    clock, cost, end = time.perf_counter, monitor.cost, monitor.end
    while state.n < n_end:
        cadence = bool(energy_every) and state.n % energy_every == 0
        e = {} if cadence or state.n == n_end - 1 else None
        t0 = clock()
        step(model, state, e)
        cost["step" if e is None else "step_with_energy"] += clock() - t0
        monitor.energy_steps += e is not None
        if state.n == n_end and e is not None:
            end["energy"] = e
        yield state, (e if cadence else None)


def _loop(model, state, scene: Scene, monitor: Monitor, progress: Progress, on_step, checkpoints=None) -> str | None:
    """Step to the end time or until the monitor says stop; returns why it stopped (None: the end).
    The first step (with the kernels' compilation or cache load) is timed alone
    (``monitor.first_step_s``); ``monitor.cost`` times the parts of the others."""
    stop = None
    previous = {}

    def request_stop(signum, frame):
        if signum == signal.SIGINT and monitor.stop_requested:  # a second Ctrl-C: stop now
            raise KeyboardInterrupt
        monitor.stop_requested = True  # every rank stops at the next check (Monitor), outputs finalised

    if threading.current_thread() is threading.main_thread():
        # SIGTERM and SIGINT (Ctrl-C) alike end the run cleanly: the summary finalised, the files compacted
        previous = {sig: signal.signal(sig, request_stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        for st, e in _steps(model, state, scene.t_end, scene.output["energy_every"], monitor):
            stop = monitor.observe(st, e)
            if monitor.first_step_s is None:  # the parts are timed from the second step on
                monitor.first_step_s = time.perf_counter() - monitor.t_loop0
                monitor.cost.update(dict.fromkeys(monitor.cost, 0.0))
                st.seconds.update(dict.fromkeys(st.seconds, 0.0))
                monitor.energy_steps = 0
            if on_step is not None:
                on_step(st)
            if checkpoints is not None and checkpoints.due(st.n, stop, monitor.glob[3] >= 2):
                _checkpoint(checkpoints, monitor, st)
            progress.update(st.t, monitor.tip_text())
            if stop:
                break
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return stop


def _checkpoint(checkpoints, monitor, st) -> None:
    """Flush every output, then write the checkpoint of ``st`` and the watchers (collective;
    :mod:`fricfem.output.checkpoint`)."""
    t0 = time.perf_counter()
    monitor.flush(st)
    monitor.rows_pending = 0
    monitor.last_flush = time.perf_counter()
    checkpoints.take(st, checkpoint.watchers(monitor, monitor.rec, monitor.writer, monitor.gauges))
    monitor.seconds += time.perf_counter() - t0


def loop_cost(monitor, steps: int, loop_wall: float) -> dict:
    """summary.json's ``loop_cost``: the time loop's wall time per step [µs] by part
    (:data:`fricfem.monitor.LOOP_PARTS`), over the steps after the first, on rank 0.

    ``energy``: what the energy evaluations added to their steps (their steps' time
    beyond as many steps without); ``step``: the rest of the steps' time; then the
    monitor's parts; ``outputs``
    all but the step; ``total`` their sum; ``wall``: the loop's measured wall time
    (``loop_wall`` [s], the first step excluded) per step, the parts and what is
    not in them (the progress line)."""
    c, n = monitor.cost, steps - 1
    if n < 1:
        return {"steps": max(n, 0)}
    ne = monitor.energy_steps
    plain = c["step"] / (n - ne) if n > ne else c["step_with_energy"] / n
    energy = max(c["step_with_energy"] - plain * ne, 0.0)
    parts = {"step": c["step"] + c["step_with_energy"] - energy, "energy": energy,
             **{k: c[k] for k in LOOP_PARTS[2:]}}
    total = sum(parts.values())
    return {"unit": "µs of wall-clock time per step (rank 0), the mean over the steps after the first",
            "steps": n, "energy_steps": ne, **{k: 1e6 * v / n for k, v in parts.items()},
            "outputs": 1e6 * (total - parts["step"]) / n, "total": 1e6 * total / n,
            "wall": 1e6 * (loop_wall - (monitor.first_step_s or 0.0)) / n,
            "outputs_share": (total - parts["step"]) / total if total > 0 else 0.0}


#: how long a rank that raised waits for every other rank to raise too [s] (:func:`_guarded`)
AGREE_S = 5.0


def _guarded(comm, out: Path, fn):
    """``fn()``; an exception on some ranks of several only ends the whole job: one
    line on stderr, then ``MPI_Abort`` (the other ranks wait in a collective that
    would never complete).  An exception raised on every rank (the same code
    failing alike everywhere: a library's error, a bad value) propagates on every
    rank as on one, so the caller sees it (pytest reports a failure instead of
    losing the job): the ranks that raised meet in a barrier of their own
    communicator, and a rank that is not met within :data:`AGREE_S` aborts.
    Errors raised on every rank by a collective check (SceneError, RunDirError)
    and any error on a single rank propagate as usual."""
    if comm.size == 1:
        return fn()
    raised = comm.Dup()  # apart from the run's own collectives
    try:
        return fn()
    except (SceneError, RunDirError):
        raise
    except Exception as err:
        met = raised.Ibarrier()
        deadline = time.monotonic() + AGREE_S
        while not met.Test() and time.monotonic() < deadline:
            time.sleep(0.01)
        if met.Test():
            raise
        what = f"{err.filename}: {err.strerror}" if isinstance(err, OSError) and err.filename and err.strerror \
            else f"{type(err).__name__}: {err}"
        sys.stderr.write(f"fricfem: error: rank {comm.rank} of {comm.size}: {' '.join(what.split())}; ending every "
                         f"rank (MPI_Abort); {str(out)!r} keeps what was flushed\n")
        sys.stderr.flush()
        comm.Abort(1)
    finally:
        raised.Free()


def run_scene(scene: Scene, out: Path, comm=MPI.COMM_WORLD, overwrite: bool = False, quiet: bool = False,
              on_step=None, build=build_model, resume: bool = False) -> dict:
    """Run ``scene`` writing the run directory ``out``; returns the run's whole record
    (summary and evidence, as :func:`fricfem.output.rundir.read_summary` reads them; all ranks).

    ``on_step(state)`` is called after every step (tests, custom monitors).
    ``build(scene, comm) -> (plate mesh, model)`` makes the model (default
    :func:`~fricfem.model.build.build_model`; a batch passes
    :meth:`fricfem.model.reuse.ModelCache.build` to reuse one across scenes).
    The directory is locked while the run writes it; an exception on one rank of
    several ends the job (:func:`_guarded`).

    ``resume``: continue the killed or stopped run in ``out`` from its checkpoint
    (:mod:`fricfem.output.checkpoint`; ``scene`` must be the one it was written for),
    with the same bits as a run never stopped.
    """
    t_start = time.perf_counter()
    out = Path(out)
    check_laws(scene, comm)
    checkpoint.check_scene(scene)
    lock = prepare_outdir(out, comm, overwrite) if not resume else _reopen(out, comm)
    try:
        header = checkpoint.check_resume(out, comm, scene) if resume else None
        return _guarded(comm, out, lambda: _run(scene, out, comm, quiet, on_step, build, t_start, header))
    finally:
        if lock is not None:
            lock.release()


def _reopen(out: Path, comm):
    """Lock the run directory of a run to resume, keeping its files (collective; the lock on rank 0)."""
    lock = problem = None
    if comm.rank == 0:
        try:
            lock = directory.reopen(out)
        except RunDirError as err:
            problem = str(err)
    problem = comm.bcast(problem, root=0)
    if problem:
        raise RunDirError(problem)
    return lock


def _run(scene: Scene, out: Path, comm, quiet: bool, on_step, build, t_start: float, header=None) -> dict:
    """:func:`run_scene` once its directory is ready."""
    pm, model = build(scene, comm)
    summary = _summary(scene, pm, model, comm)
    aside = checkpoint.set_aside(out, comm) if header is not None else None  # the files to continue
    _check_step(scene, model, comm)
    if not scene.watchdog["max_slip_rate"]:
        scene = scene._replace(watchdog={**scene.watchdog, "max_slip_rate": scene.material.c_l})
    every = max(1, int(round(scene.output["interface_every"] / model.dt)))
    rows = planned_rows(n_steps(model, scene.t_end), every, scene.output["energy_every"])
    rec = Recorder(out / INTERFACE_FILE, scene, model, summary["speeds"], rows)
    writer = None
    if scene.output["fields"] or scene.output["frames"]:
        from .output.fields import FieldWriter

        moduli = scene.material
        if model.bodies is not None:  # steel in the buffer and the projectile
            from .model.bodies import field_moduli

            moduli = field_moduli(model.V, scene.mesh, scene.material, scene.experiment)
        writer = FieldWriter(out / FIELDS_FILE, model.V, moduli, scene.sigma0, scene.tau0)
    t_setup = time.perf_counter() - t_start
    if comm.rank == 0:
        write_record(out, summary)

    background = Background()
    last_summary = [-math.inf]  # rank 0: when the periodic summary was last submitted

    def flush(st):
        rec.flush()
        if monitor.gauges is not None:
            monitor.gauges.flush()
        now = time.perf_counter()
        if comm.rank == 0 and now - last_summary[0] >= scene.output["flush_every"]:
            # the summary so far, every output.flush_every seconds (the rows go every flush):
            # the text now, the files while the loop goes on (a rename waits for the disk)
            last_summary[0] = now
            summary.update(steps=st.n, t_s=st.t, initiation=monitor.initiation,
                           slip_rate_spike=monitor.spikes.report())
            background.submit(replace_texts, record_texts(out, summary))

    state = State(model, skip_quiet=scene.skip_quiet)
    if model.bodies is not None:  # the projectile moves at t = 0
        from .model.bodies import launch

        launch(model, state)
    monitor = Monitor(scene, model, rec, writer, every, flush)
    monitor.background = background
    if scene.output["gauges"]:
        monitor.gauges = GaugeWriter(out / GAUGES_FILE, scene, model)
        if header is None:
            monitor.gauges.observe(state)  # the state at t = 0
    checkpoints = checkpoint.Checkpoints(out, scene, model) if checkpoint.enabled(scene) else None
    if checkpoints is not None:
        monitor.wall_checkpoint = checkpoints.wall_due if checkpoints.wall > 0 else None
    if header is not None:  # the state, the watchers and the files as the checkpoint has them
        checkpoint.resume(out, header, aside, model, state, monitor)
        summary.update(steps=state.n, t_s=state.t, initiation=monitor.initiation)
    progress = Progress(scene.t_end, enabled=(comm.rank == 0 and not quiet))
    monitor.t_loop0 = time.perf_counter()
    stop = _loop(model, state, scene, monitor, progress, on_step, checkpoints)
    loop_wall = time.perf_counter() - monitor.t_loop0
    t_loop = loop_wall - monitor.seconds
    progress.update(state.t, monitor.tip_text(), force=True)
    progress.close()
    return _finish(scene, out, comm, summary, state, rec, writer, monitor, stop, every,
                   {"setup": t_setup, "first_step_incl_jit": monitor.first_step_s or 0.0, "time_loop": t_loop,
                    "time_loop_with_outputs": loop_wall},
                   t_start)


def _finish(scene, out, comm, summary, state, rec, writer, monitor, stop, every, wall, t_start) -> dict:
    """Flush and close the outputs, diagnose, write the final summary (all ranks get it)."""
    t1 = time.perf_counter()
    rec.flush()
    monitor.background.close()  # the last periodic summary is on disk before the final one
    if writer is not None:
        writer.close()
    if monitor.gauges is not None:
        try:
            monitor.gauges.close()
        except OSError as err:  # as interface.h5 below: the laid-out file stays, its NaN rows not computed
            summary["gauges_file"] = (f"{GAUGES_FILE} kept as laid out (rows past the run's end are NaN), not "
                                      f"compacted: {err.filename}: {err.strerror}")
            if comm.rank == 0:
                sys.stderr.write(f"fricfem: warning: {summary['gauges_file']}\n")
    summary.update(
        steps=state.n, t_s=state.t, complete=stop not in ("signal", "watchdog") and monitor.diverged is None,
        interrupted=stop == "signal", **({"diverged": monitor.diverged} if monitor.diverged else {}),
        watchdog=monitor.stopped, ended_early=monitor.ended_early, initiation=monitor.initiation,
        energy=_energy(monitor),
    )
    # slip-rate spikes (peak, place, time; fricfem/monitor.py Spikes): reported, never a stop
    summary["slip_rate_spike"] = monitor.spikes.report()
    if comm.rank == 0 and monitor.diverged:
        sys.stderr.write(f"fricfem: warning: {monitor.diverged}\n")
    if comm.rank == 0 and scene.output["diagnostics"] and not monitor.stopped and not monitor.diverged:
        try:
            summary.update(_diagnose(rec, monitor.tip_t, monitor.tip_x, summary["speeds"], every))
        except Exception as err:  # keep the run's outputs; say what failed
            summary["diagnostics_error"] = f"diagnostics failed: {type(err).__name__}: {err}"
    if monitor.diverged:
        summary["mode"] = {"label": "unknown", "reason": monitor.diverged}
    if stop == "signal":  # the classifier needs the whole run: what it saw so far is evidence only
        partial = summary.get("mode") or {}
        summary["mode"] = {"label": "unknown", "reason": f"interrupted at t = {state.t * 1e6:.3f} µs, before "
                           f"time.end = {scene.t_end * 1e6:.3f} µs", "partial_label": partial.get("label"),
                           **({"evidence": partial["evidence"]} if "evidence" in partial else {})}
    try:
        rec.close()
    except OSError as err:  # the laid-out file stays, whole and readable: its NaN rows are not computed
        summary["interface_file"] = (f"{INTERFACE_FILE} kept as laid out (rows past the run's end are NaN), not "
                                     f"compacted: {err.filename}: {err.strerror}")
        if comm.rank == 0:
            sys.stderr.write(f"fricfem: warning: {summary['interface_file']}\n")
    output_s = monitor.seconds + time.perf_counter() - t1
    summary["wall_s"] = {**wall, "output": output_s, "total": time.perf_counter() - t_start}
    summary["us_per_step"] = 1e6 * wall["time_loop"] / max(state.n, 1)
    summary["loop_cost"] = loop_cost(monitor, state.n, wall["time_loop_with_outputs"])
    # the step's parts on every rank: a rank that waits for another shows it in "interface"
    # (the interface's exchanges) or "wait" (the ghost exchange)
    parts = {k: 1e6 * v / max(state.n - 1, 1) for k, v in state.seconds.items()}
    by_rank = comm.gather(parts, root=0)
    if by_rank is not None and state.n > 1:
        summary["loop_cost"]["step_by_rank"] = by_rank
    if comm.rank == 0:
        write_record(out, summary)
    return comm.bcast(whole(summary) if comm.rank == 0 else None, root=0)


def _energy(monitor) -> dict | None:
    """summary.json's energy budget [J/m]: at the run's last step (t^n of the step that
    reached time.end), or at the last evaluation when the run stopped early."""
    end = monitor.end.get("energy")
    e = end if end is not None else monitor.last_energy
    if e is None:
        return None
    return {"time_s": e["time"], "at": "end" if end is not None else "last evaluation (the run stopped early)",
            **{k: e[k] for k in ENERGY if k != "time"}, "interface": e["interface_elastic"]}


def resolve_and_run(ref, overrides=(), out=None, overwrite=False, quiet=False, comm=MPI.COMM_WORLD) -> dict:
    """Load + validate (before heavy work) and run; default ``out`` is ``runs/<scene>``."""
    scene = scene_mod.load(ref, overrides)
    if not out:  # runs/<name> under the current directory, and nowhere else
        check_identifier("name", scene.name, 128)
        out = Path("runs") / scene.name
    out = Path(out)
    return run_scene(scene, out, comm, overwrite=overwrite, quiet=quiet)
