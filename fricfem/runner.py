"""Run a scene: build, step, record, diagnose — writing the run directory as it goes.

    scene ─► model (fricfem.model.build) ─► state, evolve (fricfem.step)
          ─► observers (fricfem.observe) ─► recorder, field writer, gauges (fricfem.output)
          ─► diagnostics (fricfem.analysis) ─► summary.json

:func:`observers` makes a run's observers in one place, in the order the loop
calls them; :func:`fricfem.step.evolve` is the loop; :func:`_finish` finishes
the observers and writes the summary.

The run directory's format: :mod:`fricfem.output.quantities`.  Files are
flushed as the run goes (every :data:`fricfem.observe.FLUSH_ROWS` interface rows and every
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

import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from . import scene as scene_mod
from . import observe
from . import analysis
from .friction import BUILT_IN, LAWS
from .model.bodies import field_moduli, launch
from .output.fields import FieldWriter
from .model.build import build_model
from .output.quantities import FIELDS_FILE, GAUGES_FILE, INTERFACE_FILE
from .output.gauges import GaugeWriter
from .output import checkpoint, directory
from .output.directory import RunDirError
from .output.record import record_texts, whole, write_record
from .output.recorder import Recorder, planned_rows
from .scene import Scene, SceneError
from .scene.settings import field_steps
from .scene.values import check_identifier
from .scene.output_keys import frame_times
from .step import State, Timing, evolve, n_steps, run

#: the files a run writes into its directory (``--overwrite`` removes what a manifest lists)
RUN_FILES = directory.RUN_FILES


def prepare_outdir(out: Path, comm, overwrite: bool):
    """Make, lock and (``overwrite``) clear the run directory before any heavy work
    (:func:`fricfem.output.directory.prepare`; collective); the lock on rank 0."""
    return _lock_on_rank0(comm, lambda: directory.prepare(out, overwrite))


def _lock_on_rank0(comm, take):
    """``take()`` (a :mod:`fricfem.output.directory` call that locks the run directory) on
    rank 0; its :class:`RunDirError` raised on every rank (collective); the lock on rank 0."""
    lock = problem = None
    if comm.rank == 0:
        try:
            lock = take()
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


def _check_step(scene: Scene, model, comm) -> None:
    """Refuse a step above the stable one unless the scene allows it."""
    if model.dt <= model.dt_crit:
        return
    if not scene.allow_unstable_dt:
        raise SceneError(f"time.dt = {model.dt:.3g} s exceeds the stable step {model.dt_crit:.3g} s of this "
                         "mesh and interface; use time.dt_safety in (0, 1) (or set "
                         "time.allow_unstable_dt = true for a stability experiment)")
    if comm.rank == 0:
        then = ("the watchdog will stop the run if it diverges" if scene.watchdog.enabled else
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
        # the scale and mesh checks that warned but did not refuse the scene (printed on stderr too)
        "warnings": list(scene.warnings),
        # what fricfem plot needs for the isochromatic frames (output.frames, thickness, f_sigma)
        "photoelastic": {"thickness_m": scene.output.thickness, "f_sigma_N_per_m": scene.output.f_sigma,
                         "frames_s": frame_times(scene.output.frames)},
    }


def _diagnose(rec: Recorder, tip_t, tip_x, speeds, every: int) -> dict:
    """Tip speed, fronts and mode from the recorded history (rank 0).

    The tip is tracked every step; V_tip is the 5-point progressive fit on the
    tip sampled at the interface-snapshot cadence (``every`` steps), so that a
    window spans a few Gauss-point spacings rather than one staircase step.
    """
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
    out.update(analysis.rupture.from_run(rec.path.parent))  # a nucleated rupture's t_r, V_r (analysis/rupture.py)
    return out


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
    return _lock_on_rank0(comm, lambda: directory.reopen(out))


def _run(scene: Scene, out: Path, comm, quiet: bool, on_step, build, t_start: float, header=None) -> dict:
    """:func:`run_scene` once its directory is ready."""
    pm, model = build(scene, comm)
    summary = _summary(scene, pm, model, comm)
    aside = checkpoint.set_aside(out, comm) if header is not None else None  # the files to continue
    _check_step(scene, model, comm)
    state = State(model, skip_quiet=scene.skip_quiet)
    if model.bodies is not None:  # the projectile moves at t = 0

        launch(model, state)
    every = max(1, int(round(scene.output.interface_every / model.dt)))  # steps between interface snapshots
    rows = planned_rows(n_steps(model, scene.t_end), every, scene.output.energy_every)
    rec = Recorder(out / INTERFACE_FILE, scene, model, summary["speeds"], rows, state.points)
    writer = _field_writer(scene, model, out)
    t_setup = time.perf_counter() - t_start
    if comm.rank == 0:
        write_record(out, summary)
    obs = observers(scene, model, state, rec, writer, out, summary, every, quiet, on_step)
    if header is not None:  # the state, the observers and the files as the checkpoint has them
        checkpoint.resume_observed(out, header, aside, model, state, _watched(obs, rec, writer))
        summary.update(steps=state.n, t_s=state.t, initiation=obs.tip.initiation)
    timing = Timing(observe.LOOP_PARTS)
    t_loop0 = time.perf_counter()
    with obs.signals:  # SIGTERM and SIGINT end the run cleanly: the summary finalised, the files compacted
        stop = run(evolve(model, state, scene.t_end, scene.output.energy_every, obs.order, timing=timing,
                          end_energy=True))
    loop_wall = time.perf_counter() - t_loop0
    wall = {"setup": t_setup, "first_step_incl_jit": timing.first_step_s or 0.0,
            "time_loop": loop_wall - timing.observers_s, "time_loop_with_outputs": loop_wall}
    return _finish(Finish(scene, out, comm, summary, state, rec, obs, timing, every), stop, wall, t_start)


def _field_writer(scene: Scene, model, out: Path):
    """The field snapshots' writer (output.fields and the isochromatic frames), or None."""
    if not (scene.output.fields or scene.output.frames):
        return None

    moduli = scene.material
    if model.bodies is not None:  # steel in the buffer and the projectile

        moduli = field_moduli(model.V, scene.mesh, scene.material, scene.experiment)
    return FieldWriter(out / FIELDS_FILE, model.V, moduli, scene.sigma0, scene.tau0)


class Observers(NamedTuple):
    """A run's observers by name, and :attr:`order`: all of them in the order the
    loop calls them (a stop reason of an earlier one wins)."""

    look: observe.Look
    watchdog: observe.Watchdog
    spikes: observe.Spikes
    tip: observe.Tip
    energies: observe.Energies
    snapshots: observe.Snapshots
    flusher: observe.Flusher
    signals: observe.Signals
    order: list


def observers(scene: Scene, model, state, rec: Recorder, writer, out: Path, summary: dict, every: int,
              quiet: bool = True, on_step=None) -> Observers:
    """The observers of a run of ``scene`` (:mod:`fricfem.observe`), in the loop's order:
    stations, the one look at the interface, watchdog, spikes, tip, signals, energies,
    interface snapshots, fields, gauges, flushes (with the summary so far),
    ``on_step(state)``, the progress line.  Collective (the gauges' file)."""
    comm = model.comm
    look = observe.Look(model.interface.geometry.x1)

    law_watch = None if model.interface.law.name in BUILT_IN else observe.LawWatch(model.interface, state.points)
    watchdog = observe.Watchdog(model, scene.watchdog, look, scene.output.energy_every, law_watch)
    spikes = observe.Spikes(observe.spike_threshold(scene), comm, look)  # reported, never a stop
    tip = observe.Tip(look, scene.stop_at_tip)
    energies = observe.Energies(rec, scene.output.energy_every, n_steps(model, scene.t_end))
    snapshots = observe.Snapshots(rec, every)
    signals = observe.Signals()  # after the watchdog and the tip: their stop reasons come first
    order = [observe.Stations(rec), look, watchdog, spikes, tip, signals, energies, snapshots]
    if writer is not None:
        steps = field_steps(list(scene.output.fields) + frame_times(scene.output.frames), model.dt,
                            scene.t_end)
        order.append(observe.Fields(writer, steps))
    gauges = None
    if scene.output.gauges:
        gauges = GaugeWriter(out / GAUGES_FILE, scene, model)
        order.append(observe.Gauges(gauges, state))

    def so_far(st):  # the summary so far (rank 0, at a flush)
        summary.update(steps=st.n, t_s=st.t, initiation=tip.initiation, slip_rate_spike=spikes.report())
        return record_texts(out, summary)

    flusher = observe.Flusher(rec, snapshots, gauges, scene.output.flush_every, comm, so_far)
    order.append(flusher)
    if checkpoint.enabled(scene):  # after the flusher and the signals (a stop by a signal takes one too)
        watched = checkpoint.Watched(tip, spikes, watchdog, energies, flusher, rec, writer, gauges)
        order.append(checkpoint.Checkpointer(out, scene, model, watched, signals))
    if on_step is not None:
        order.append(observe.Callback(on_step))
    progress = observe.Progress(scene.t_end, enabled=(comm.rank == 0 and not quiet))
    order.append(observe.ProgressLine(progress, tip, spikes))
    return Observers(look, watchdog, spikes, tip, energies, snapshots, flusher, signals, order)


def _watched(obs: Observers, rec: Recorder, writer) -> "checkpoint.Watched":
    """What a checkpoint holds of a run's observers (:mod:`fricfem.output.checkpoint`)."""
    return checkpoint.Watched(obs.tip, obs.spikes, obs.watchdog, obs.energies, obs.flusher, rec, writer,
                              obs.flusher.gauges)


class Finish(NamedTuple):
    """What :func:`_finish` needs of a run."""

    scene: Scene
    out: Path
    comm: object
    summary: dict
    state: State
    rec: Recorder
    obs: Observers
    timing: Timing
    every: int  # steps between interface snapshots


def _finish(run_: Finish, stop: str | None, wall: dict, t_start: float) -> dict:
    """Finish the observers (their files closed), diagnose, write the final summary
    (all ranks get it)."""
    scene, out, comm, summary, state, rec, obs = run_[:7]
    t1 = time.perf_counter()
    done = {}
    for o in obs.order:
        fin = getattr(o, "finish", None)
        if fin is not None:
            done.update(fin(state))
    if "gauges_file" in done:  # as interface.h5 below: the laid-out file stays, its NaN rows not computed
        summary["gauges_file"] = done["gauges_file"]
        if comm.rank == 0:
            sys.stderr.write(f"fricfem: warning: {summary['gauges_file']}\n")
    diverged, stopped = done.get("diverged"), done["watchdog"]
    summary.update(
        steps=state.n, t_s=state.t, complete=stop not in ("signal", "watchdog") and diverged is None,
        interrupted=stop == "signal", **({"diverged": diverged} if diverged else {}),
        watchdog=stopped, ended_early=done["ended_early"], initiation=done["initiation"], energy=done["energy"],
    )
    # slip-rate spikes (peak, place, time; fricfem.observe.Spikes): reported, never a stop
    summary["slip_rate_spike"] = done["slip_rate_spike"]
    if comm.rank == 0 and diverged:
        sys.stderr.write(f"fricfem: warning: {diverged}\n")
    if comm.rank == 0 and scene.output.diagnostics and not stopped and not diverged:
        try:
            summary.update(_diagnose(rec, obs.tip.tip_t, obs.tip.tip_x, summary["speeds"], run_.every))
        except Exception as err:  # keep the run's outputs; say what failed
            summary["diagnostics_error"] = f"diagnostics failed: {type(err).__name__}: {err}"
    if diverged:
        summary["mode"] = {"label": "unknown", "reason": diverged}
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
    output_s = run_.timing.observers_s + time.perf_counter() - t1
    summary["wall_s"] = {**wall, "output": output_s, "total": time.perf_counter() - t_start}
    summary["us_per_step"] = 1e6 * wall["time_loop"] / max(state.n, 1)
    summary["loop_cost"] = observe.loop_cost(run_.timing, state.n, wall["time_loop_with_outputs"])
    # the step's parts on every rank: a rank that waits for another shows it in "interface"
    # (the interface's exchanges) or "wait" (the ghost exchange)
    parts = {k: 1e6 * v / max(state.n - 1, 1) for k, v in state.seconds.items()}
    by_rank = comm.gather(parts, root=0)
    if by_rank is not None and state.n > 1:
        summary["loop_cost"]["step_by_rank"] = by_rank
    if comm.rank == 0:
        write_record(out, summary)
    return comm.bcast(whole(summary) if comm.rank == 0 else None, root=0)


def resolve_and_run(ref, overrides=(), out=None, overwrite=False, quiet=False, comm=MPI.COMM_WORLD) -> dict:
    """Load + validate (before heavy work) and run; default ``out`` is ``runs/<scene>``."""
    scene = scene_mod.load(ref, overrides)
    if not out:  # runs/<name> under the current directory, and nowhere else
        check_identifier("name", scene.name, 128)
        out = Path("runs") / scene.name
    out = Path(out)
    return run_scene(scene, out, comm, overwrite=overwrite, quiet=quiet)
