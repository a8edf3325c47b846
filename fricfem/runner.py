"""Run a scene: build, step, record, diagnose — writing the run directory as it goes.

    scene ─► model (fricfem.model.build) ─► state, step, evolve (fricfem.step)
          ─► monitor (fricfem.monitor) ─► recorder, field writer (fricfem.output)
          ─► diagnostics (fricfem.analysis) ─► summary.json

The run directory's format: :mod:`fricfem.output.quantities`.  Files are
flushed as the run goes and ``summary.json`` says ``"complete": false`` until
the run ends.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from . import scene as scene_mod
from .model.build import build_model
from .monitor import Monitor, Progress
from .output.quantities import ENERGY, FIELDS_FILE, INTERFACE_FILE
from .output.recorder import Recorder
from .output.rundir import jsonable, write_summary
from .scene import Scene, SceneError
from .step import State, evolve

#: the files a run writes into its directory (``--overwrite`` removes these)
RUN_FILES = (INTERFACE_FILE, FIELDS_FILE, "fields.h5", "summary.json")


def prepare_outdir(out: Path, comm, overwrite: bool) -> None:
    """Refuse a non-empty run directory unless ``overwrite`` (checked before any heavy work)."""
    problem = None
    if comm.rank == 0:
        if out.exists() and not out.is_dir():
            problem = f"--out {str(out)!r}: exists and is not a directory"
        elif out.exists() and any(out.iterdir()) and not overwrite:
            problem = f"--out {str(out)!r}: directory is not empty; pass --overwrite to replace its run"
        else:
            out.mkdir(parents=True, exist_ok=True)
            for name in RUN_FILES:
                (out / name).unlink(missing_ok=True)
    problem = comm.bcast(problem, root=0)
    if problem:
        raise SceneError(problem)


def _check_step(scene: Scene, model, comm) -> None:
    """Refuse a step above the stable one unless the scene allows it."""
    if model.dt <= model.dt_crit:
        return
    if not scene.allow_unstable_dt:
        raise SceneError(f"time.dt = {model.dt:.3g} s exceeds the stable step {model.dt_crit:.3g} s of this "
                         "mesh and interface; use time.dt_safety in (0, 1) (or set "
                         "time.allow_unstable_dt = true for a stability experiment)")
    if comm.rank == 0:
        sys.stderr.write(f"fricfem: warning: time.dt = {model.dt:.3g} s exceeds the stable step "
                         f"{model.dt_crit:.3g} s; the watchdog will stop the run if it diverges\n")


def _summary(scene: Scene, pm, model, comm) -> dict:
    """The summary's head: what was run, on what."""
    return {
        "scene": scene.name, "description": scene.description, "complete": False, "ranks": comm.size,
        "dofs": 2 * pm.mesh.topology.index_map(0).size_global,
        "interface_points": int(comm.allreduce(len(model.interface.geometry.x1))),
        "dt_s": model.dt, "dt_crit_s": model.dt_crit, "steps": 0, "t_end_s": scene.t_end,
        "speeds": scene.material.speeds(), "input": scene.raw,
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


def _loop(model, state, scene: Scene, monitor: Monitor, progress: Progress, on_step) -> str | None:
    """Step to the end time or until the monitor says stop; returns why it stopped (None: the end)."""
    stop = None
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, lambda *_: setattr(monitor, "stop_requested", True))
    try:
        for st, e in evolve(model, state, scene.t_end, scene.output["energy_every"]):
            if monitor.first_step_s is None:
                monitor.first_step_s = time.perf_counter() - monitor.t_loop0
            stop = monitor.observe(st, e)
            if on_step is not None:
                on_step(st)
            progress.update(st.t, monitor.tip_text())
            if stop:
                break
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    return stop


def run_scene(scene: Scene, out: Path, comm=MPI.COMM_WORLD, overwrite: bool = False, quiet: bool = False,
              on_step=None) -> dict:
    """Run ``scene`` writing the run directory ``out``; returns the summary (all ranks).

    ``on_step(state)`` is called after every step (tests, custom monitors).
    """
    t_start = time.perf_counter()
    out = Path(out)
    prepare_outdir(out, comm, overwrite)
    pm, model = build_model(scene, comm)
    summary = _summary(scene, pm, model, comm)
    _check_step(scene, model, comm)
    if not scene.watchdog["max_slip_rate"]:
        scene = scene._replace(watchdog={**scene.watchdog, "max_slip_rate": scene.material.c_l})
    rec = Recorder(out / INTERFACE_FILE, scene, model, summary["speeds"])
    writer = None
    if scene.output["fields"]:
        from .output.fields import FieldWriter

        writer = FieldWriter(out / FIELDS_FILE, model.V, scene.material, scene.sigma0, scene.tau0)
    t_setup = time.perf_counter() - t_start
    if comm.rank == 0:
        write_summary(out, summary)

    def flush(st):
        rec.flush()
        summary.update(steps=st.n, t_s=st.t, initiation=monitor.initiation)
        if comm.rank == 0:
            write_summary(out, summary)

    state = State(model, skip_quiet=scene.skip_quiet)
    every = max(1, int(round(scene.output["interface_every"] / model.dt)))
    monitor = Monitor(scene, model, rec, writer, every, flush)
    progress = Progress(scene.t_end, enabled=(comm.rank == 0 and not quiet))
    monitor.t_loop0 = time.perf_counter()
    stop = _loop(model, state, scene, monitor, progress, on_step)
    t_loop = time.perf_counter() - monitor.t_loop0 - monitor.seconds
    progress.update(state.t, force=True)
    progress.close()
    return _finish(scene, out, comm, summary, state, rec, writer, monitor, stop, every,
                   {"setup": t_setup, "first_step_incl_jit": monitor.first_step_s or 0.0, "time_loop": t_loop},
                   t_start)


def _finish(scene, out, comm, summary, state, rec, writer, monitor, stop, every, wall, t_start) -> dict:
    """Flush and close the outputs, diagnose, write the final summary (all ranks get it)."""
    t1 = time.perf_counter()
    rec.flush()
    if writer is not None:
        writer.close()
    e = monitor.last_energy
    summary.update(
        steps=state.n, t_s=state.t, complete=stop not in ("signal", "watchdog"), interrupted=stop == "signal",
        watchdog=monitor.stopped, ended_early=monitor.ended_early, initiation=monitor.initiation,
        energy=None if e is None else {**{k: e[k] for k in ENERGY}, "interface": e["interface_elastic"]},
    )
    if comm.rank == 0 and scene.output["diagnostics"] and not monitor.stopped:
        try:
            summary.update(_diagnose(rec, monitor.tip_t, monitor.tip_x, summary["speeds"], every))
        except Exception as err:  # keep the run's outputs; say what failed
            summary["diagnostics_error"] = f"diagnostics failed: {type(err).__name__}: {err}"
    rec.close()
    output_s = monitor.seconds + time.perf_counter() - t1
    summary["wall_s"] = {**wall, "output": output_s, "total": time.perf_counter() - t_start}
    summary["us_per_step"] = 1e6 * wall["time_loop"] / max(state.n, 1)
    if comm.rank == 0:
        write_summary(out, summary)
    return comm.bcast(jsonable(summary) if comm.rank == 0 else None, root=0)


def resolve_and_run(ref, overrides=(), out=None, overwrite=False, quiet=False, comm=MPI.COMM_WORLD) -> dict:
    """Load + validate (before heavy work) and run; default ``out`` is ``runs/<scene>``."""
    scene = scene_mod.load(ref, overrides)
    out = Path(out) if out else Path("runs") / scene.name
    return run_scene(scene, out, comm, overwrite=overwrite, quiet=quiet)
