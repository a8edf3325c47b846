"""Run a scene: build, step, record, diagnose — writing the run directory as it goes.

Run directory (SPEC §5):

- ``interface.h5`` — every interface Gauss point, SI units: ``x1``, ``time`` and
  ``[n_time, n_point]`` arrays at the scene's cadence (``slip_rate``,
  ``jump_rate_s``, ``shear_traction``, ``normal_traction``,
  ``shear_traction_increment``, ``slip``, ``jump_s``, ``mu_app``, ``open``,
  ``state/<law state>``), station histories at every step under
  ``stations/<name>``, the energy history under ``energy/``.  Root attribute
  ``n_time`` (and ``n`` per station) counts the valid rows: the file is flushed
  as the run goes, so a killed run leaves a readable file.
- ``fields.xdmf/.h5`` — displacement, velocity and σ1 − σ2 (prestress included)
  at the requested times only (no stress work when none are requested).
- ``summary.json`` — scene, sizes, step, wall-time split, initiation, tip,
  fronts, mode, energy; ``"complete": false`` until the run ends.
"""

from __future__ import annotations

import json
import signal
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from . import config, friction, mesh, solver
from .config import Scene, SceneError

#: interface.h5 snapshot quantities: name -> function of the Points record.
QUANTITIES = {
    "slip_rate": lambda p: p.slip_rate,
    "jump_rate_s": lambda p: p.rate_s,
    "shear_traction": lambda p: p.Ts,
    "normal_traction": lambda p: p.Tn,
    "shear_traction_increment": lambda p: p.dTs,
    "slip": lambda p: p.slip,
    "jump_s": lambda p: p.jump_s,
    "mu_app": lambda p: np.divide(p.Ts, p.Tn, out=np.zeros_like(p.Ts), where=p.Tn > 0),
    "open": lambda p: p.is_open,
}
ENERGY_KEYS = ("time", "kinetic", "strain", "interface_work", "interface_elastic", "dissipated", "external",
               "balance_error")


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
            for name in ("interface.h5", "fields.xdmf", "fields.h5", "summary.json"):
                (out / name).unlink(missing_ok=True)
    problem = comm.bcast(problem, root=0)
    if problem:
        raise SceneError(problem)


class Recorder:
    """Interface snapshots, station histories and energies → ``interface.h5`` (rank 0 writes)."""

    def __init__(self, path: Path, scene: Scene, model, speeds: dict):
        self.itf = model.interface
        self.comm = model.comm
        self.law = self.itf.law
        geom = self.itf.geometry
        x1_all = np.concatenate(self.comm.allgather(geom.x1))
        self.order = np.argsort(x1_all, kind="stable")
        self.x1 = x1_all[self.order]
        self.n_point = len(self.x1)
        # stations: nearest Gauss point; its owner records every step
        self.stations = {}
        for name, xs in scene.output["stations"].items():
            k = int(np.argmin(np.abs(self.x1 - xs)))
            xq = self.x1[k]
            local = np.flatnonzero(geom.x1 == xq)
            self.stations[name] = (xq, int(local[0]) if len(local) else -1)
        self.station_buf = {name: [] for name in self.stations}
        self.snap_t: list = []
        self.snap_rows: dict = {q: [] for q in list(QUANTITIES) + [f"state/{s}" for s in self.law.state]}
        self.energy_rows: list = []
        self.pending = 0
        self.h5 = None
        if self.comm.rank == 0:
            import h5py

            self.h5 = h5py.File(path, "w")
            f = self.h5
            f.attrs.update(scene=scene.name, sigma0=scene.sigma0, v_imp=scene.pulse.v_imp, n_time=0,
                           law=scene.law, units="SI", **{k: v for k, v in speeds.items()})
            f["x1"] = self.x1
            f.create_dataset("time", (0,), maxshape=(None,), dtype="f8", chunks=(256,))
            chunk = (max(1, min(64, 2**20 // (8 * max(self.n_point, 1)))), max(self.n_point, 1))
            for q in self.snap_rows:
                dtype = "i1" if q == "open" else "f8"
                f.create_dataset(q, (0, self.n_point), maxshape=(None, self.n_point), dtype=dtype, chunks=chunk)
            for name, (xq, _) in self.stations.items():
                g = f.create_group(f"stations/{name}")
                g.attrs.update(x1=xq, n=0)
                for q in ["time", *QUANTITIES]:
                    g.create_dataset(q, (0,), maxshape=(None,), dtype="f8", chunks=(1024,))
            g = f.create_group("energy")
            for k in ENERGY_KEYS:
                g.create_dataset(k, (0,), maxshape=(None,), dtype="f8", chunks=(256,))

    def _gather(self, arr) -> np.ndarray | None:
        parts = self.comm.gather(np.ascontiguousarray(arr, dtype=np.float64), root=0)
        return None if parts is None else np.concatenate(parts)[self.order]

    def snapshot(self, t: float) -> dict | None:
        """Record every interface point now (collective); returns the rank-0 row dict."""
        p = self.itf.points
        row = {}
        for q, fn in QUANTITIES.items():
            row[q] = self._gather(fn(p))
        for k, s in enumerate(self.law.state):
            row[f"state/{s}"] = self._gather(p.state[:, k])
        if self.comm.rank == 0:
            self.snap_t.append(t)
            for q, v in row.items():
                self.snap_rows[q].append(v)
            self.pending += 1
        return row

    def station_step(self, t: float) -> None:
        """Record the stations this rank owns (every step, local, no communication)."""
        p = self.itf.points
        for name, (_, q) in self.stations.items():
            if q >= 0:
                self.station_buf[name].append([t] + [float(fn(p)[q]) for fn in QUANTITIES.values()])

    def energy(self, e: dict) -> None:
        if self.comm.rank == 0:
            self.energy_rows.append([e[k] for k in ENERGY_KEYS])

    def flush(self) -> None:
        """Append everything pending to the file and flush it (collective)."""
        bufs = {name: self.comm.gather(self.station_buf[name], root=0) for name in self.stations}
        for name in self.stations:
            self.station_buf[name] = []
        if self.comm.rank != 0:
            return
        f = self.h5
        n0 = f["time"].shape[0]
        new = self.snap_t[n0:]
        if new:
            n1 = n0 + len(new)
            f["time"].resize((n1,))
            f["time"][n0:n1] = new
            for q, rows in self.snap_rows.items():
                f[q].resize((n1, self.n_point))
                f[q][n0:n1] = np.array(rows[n0:n1])
            f.attrs["n_time"] = n1
        for name, parts in bufs.items():
            rows = [r for part in parts for r in part]
            if not rows:
                continue
            g = f[f"stations/{name}"]
            a = np.array(rows)
            m0 = g["time"].shape[0]
            for j, q in enumerate(["time", *QUANTITIES]):
                g[q].resize((m0 + len(a),))
                g[q][m0:] = a[:, j]
            g.attrs["n"] = m0 + len(a)
        g = f["energy"]
        m0 = g["time"].shape[0]
        if len(self.energy_rows) > m0:
            a = np.array(self.energy_rows[m0:])
            for j, k in enumerate(ENERGY_KEYS):
                g[k].resize((len(self.energy_rows),))
                g[k][m0:] = a[:, j]
        f.flush()

    def history(self):
        """(time, slip_rate[n_t, n_p]) recorded so far (rank 0; None elsewhere)."""
        if self.comm.rank != 0:
            return None
        return np.array(self.snap_t), np.array(self.snap_rows["slip_rate"])

    def close(self) -> None:
        if self.h5 is not None:
            self.h5.close()


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


def build_model(scene: Scene, comm):
    """Mesh + model for a validated scene."""
    pm = mesh.build(scene.mesh, comm)
    law = friction.get_law(scene.law)
    # no impact (a rupture problem): the edge is free, not held
    impact = (() if scene.pulse.v_imp == 0 else
              ("impact_lower", "impact_upper") if scene.symmetric else ("impact_lower",))
    model = solver.build(
        pm, scene.material, scene.pulse, law, lambda x1: config.point_params(scene, x1), scene.sigma0,
        scene.Cn, scene.Cs, tau0=lambda x1: config.point_tau0(scene, x1), impact_tags=impact,
        dt_safety=scene.dt_safety, dt=scene.dt, skip_quiet=scene.skip_quiet,
    )
    return pm, model


def _write_summary(out: Path, summary: dict, comm) -> None:
    if comm.rank == 0:
        tmp = out / "summary.json.tmp"
        tmp.write_text(json.dumps(summary, indent=2, default=_jsonable))
        tmp.replace(out / "summary.json")


def _jsonable(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if hasattr(o, "to_dict"):
        return o.to_dict()
    raise TypeError(f"not JSON serialisable: {type(o)}")


def _diagnose(rec: Recorder, tip_t, tip_x, speeds, every: int) -> dict:
    """Tip speed, fronts and mode from the recorded history (rank 0).

    The tip is tracked every step; V_tip is the 5-point progressive fit on the
    tip sampled at the interface-snapshot cadence (``every`` steps), so that a
    window spans a few Gauss-point spacings rather than one staircase step.
    """
    from . import diagnostics

    out = {}
    t = np.asarray(tip_t)
    x = np.asarray(tip_x)
    tv, v = diagnostics.tip_speed(t[::every], x[::every])
    out["tip"] = {"time_s": t, "x1_m": x, "v_tip_time_s": tv, "v_tip_m_s": v}
    times, rate = rec.history()
    if len(times) >= 2:
        fr = diagnostics.fronts(times, rec.x1, rate, speeds)
        label, evidence = diagnostics.classify(times, rec.x1, rate, speeds)
        out["fronts"] = [f.to_dict() if hasattr(f, "to_dict") else f for f in fr]
        out["mode"] = {"label": label, "evidence": evidence}
    return out


def run_scene(scene: Scene, out: Path, comm=MPI.COMM_WORLD, overwrite: bool = False, quiet: bool = False,
              on_step=None) -> dict:
    """Run ``scene`` writing the run directory ``out``; returns the summary (all ranks).

    ``on_step(state)`` is called after every step (tests, custom monitors).
    """
    t_start = time.perf_counter()
    out = Path(out)
    prepare_outdir(out, comm, overwrite)
    pm, model = build_model(scene, comm)
    speeds = scene.material.speeds()
    summary = {
        "scene": scene.name, "description": scene.description, "complete": False, "ranks": comm.size,
        "dofs": 2 * pm.mesh.topology.index_map(0).size_global,
        "interface_points": int(comm.allreduce(len(model.interface.geometry.x1))),
        "dt_s": model.dt, "dt_crit_s": model.dt_crit, "steps": 0, "t_end_s": scene.t_end,
        "speeds": speeds, "input": scene.raw,
    }
    if model.dt > model.dt_crit:
        if not scene.allow_unstable_dt:
            raise SceneError(f"time.dt = {model.dt:.3g} s exceeds the stable step {model.dt_crit:.3g} s of this "
                             "mesh and interface; use time.dt_safety in (0, 1) (or set "
                             "time.allow_unstable_dt = true for a stability experiment)")
        if comm.rank == 0:
            sys.stderr.write(f"fricfem: warning: time.dt = {model.dt:.3g} s exceeds the stable step "
                             f"{model.dt_crit:.3g} s; the watchdog will stop the run if it diverges\n")
    if not scene.watchdog["max_slip_rate"]:
        scene = scene._replace(watchdog={**scene.watchdog, "max_slip_rate": scene.material.c_l})
    rec = Recorder(out / "interface.h5", scene, model, speeds)
    writer = None
    if scene.output["fields"]:
        from .io import FieldWriter

        writer = FieldWriter(out / "fields.xdmf", model.V, scene.material, scene.sigma0, scene.tau0)
    t_setup = time.perf_counter() - t_start
    _write_summary(out, summary, comm)

    stop = {"flag": False}
    previous = None
    if threading_main():
        previous = signal.signal(signal.SIGTERM, lambda *_: stop.__setitem__("flag", True))

    state = solver.State(model)
    dt = model.dt
    every = max(1, int(round(scene.output["interface_every"] / dt)))
    field_steps = sorted({int(round(t / dt)) for t in scene.output["fields"]})
    x1 = model.interface.geometry.x1
    p = model.interface.points
    progress = Progress(scene.t_end, enabled=(comm.rank == 0 and not quiet))
    t_out = 0.0
    tip_t, tip_x = [], []
    initiation = None
    last_energy = None
    last_flush = time.perf_counter()
    interrupted = False
    stopped = None
    ended_early = None
    t_loop0 = time.perf_counter()
    first_step_s = None
    try:
        for st, e in solver.evolve(model, state, scene.t_end, scene.output["energy_every"]):
            if first_step_s is None:
                first_step_s = time.perf_counter() - t_loop0
            t0 = time.perf_counter()
            rec.station_step(st.t_interface)
            sliding = p.slip_rate > 0
            local = np.array([x1[sliding].max() if sliding.any() else -1.0,
                              -x1[sliding].min() if sliding.any() else -np.inf,
                              1.0 if stop["flag"] else 0.0,
                              1.0 if (comm.rank == 0 and time.perf_counter() - last_flush
                                      > scene.output["flush_every"]) else 0.0,
                              watchdog_code(p, e, scene.watchdog)])
            glob = np.empty(5)
            comm.Allreduce(local, glob, op=MPI.MAX)
            if glob[0] >= 0:
                tip_t.append(st.t_interface)
                tip_x.append(glob[0])
                if initiation is None:
                    initiation = {"time_s": st.t_interface, "x1_m": -glob[1], "x1_max_m": glob[0]}
            if e is not None:
                last_energy = e
                rec.energy(e)
            if (st.n - 1) % every == 0:  # the interface at t = 0, every, 2 every, ... steps
                rec.snapshot(st.t_interface)
            if st.n in field_steps and writer is not None:
                writer.write(st)
            if glob[3] > 0:
                rec.flush()
                summary.update(steps=st.n, t_s=st.t, initiation=initiation)
                _write_summary(out, summary, comm)
                last_flush = time.perf_counter()
            t_out += time.perf_counter() - t0
            if on_step is not None:
                on_step(st)
            progress.update(st.t, f"tip {glob[0] * 1e3:6.1f} mm" if glob[0] >= 0 else "no slip")
            if glob[4] > 0:
                stopped = _watchdog_message(int(glob[4]), st.t, model, scene.watchdog)
                break
            if scene.stop_at_tip and glob[0] > scene.stop_at_tip:
                ended_early = (f"the sliding tip passed x1 = {scene.stop_at_tip * 1e3:g} mm at "
                               f"t = {st.t_interface * 1e6:.3f} µs")
                break
            if glob[2] > 0:
                interrupted = True
                break
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    t_loop = time.perf_counter() - t_loop0 - t_out
    progress.update(state.t, force=True)
    progress.close()
    t1 = time.perf_counter()
    rec.flush()
    if writer is not None:
        writer.close()
    summary.update(
        steps=state.n, t_s=state.t, complete=not (interrupted or stopped), interrupted=interrupted,
        watchdog=stopped, ended_early=ended_early,
        initiation=initiation,
        energy=None if last_energy is None else {**{k: last_energy[k] for k in ENERGY_KEYS},
                                                 "interface": last_energy["interface_elastic"]},
    )
    failure = None
    if comm.rank == 0 and scene.output["diagnostics"] and not stopped:
        try:
            summary.update(_diagnose(rec, tip_t, tip_x, speeds, every))
        except Exception as err:  # keep the run's outputs; say what failed
            failure = f"diagnostics failed: {type(err).__name__}: {err}"
            summary["diagnostics_error"] = failure
    rec.close()
    t_out += time.perf_counter() - t1
    summary["wall_s"] = {"setup": t_setup, "first_step_incl_jit": first_step_s or 0.0, "time_loop": t_loop,
                         "output": t_out, "total": time.perf_counter() - t_start}
    summary["us_per_step"] = 1e6 * t_loop / max(state.n, 1)
    _write_summary(out, summary, comm)
    return comm.bcast(json.loads(json.dumps(summary, default=_jsonable)) if comm.rank == 0 else None, root=0)


def threading_main() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def resolve_and_run(ref, overrides=(), out=None, overwrite=False, quiet=False, comm=MPI.COMM_WORLD) -> dict:
    """Load + validate (before heavy work) and run; default ``out`` is ``runs/<scene>``."""
    scene = config.load(ref, overrides)
    out = Path(out) if out else Path("runs") / scene.name
    return run_scene(scene, out, comm, overwrite=overwrite, quiet=quiet)
