# # End-to-end time of `fricfem run case1`
#
# How long a user waits for ``mpirun -n 2 fricfem run case1`` on the reference
# mesh, from the shell prompt back to the prompt, and where that time goes:
#
# * **startup** — mpirun, the interpreter, MPI and the imports (dolfinx,
#   PETSc, numba, fricfem: the time the command takes beyond its own
#   ``summary.json`` ``wall_s.total``);
# * **setup** — mesh generation (gmsh + dolfinx), assembly of K and the lumped
#   mass, the stable step (power iteration), the recorders;
# * **JIT** — ffcx compiling the forms (C code, a C compiler, a CFFI module)
#   and numba compiling the kernels, or loading both from their caches;
# * **time loop** and **output** (snapshots, fields, diagnostics, files).
#
# *Cold* means empty caches: ``XDG_CACHE_HOME`` (dolfinx/ffcx keep compiled
# forms in ``$XDG_CACHE_HOME/fenics``) and ``NUMBA_CACHE_DIR`` point to fresh
# temporary directories; *warm* is the next run with the same directories.
# Without ``NUMBA_CACHE_DIR`` numba's ``cache=True`` writes its ``.nbi``/``.nbc``
# files into ``__pycache__`` next to each source file (``fricfem/**/__pycache__``);
# the script checks that ``NUMBA_CACHE_DIR`` moves them and that the run leaves
# the package's own ``__pycache__`` untouched.
#
# Two kinds of measurement, both under ``mpirun -n 2``:
#
# 1. the command itself, uninstrumented: the wall time around the subprocess
#    and the run's ``summary.json`` split (setup / loop / output);
# 2. a *probe*: the same run in a Python process that first wraps
#    ``dolfinx.jit.ffcx_jit``, numba's ``Dispatcher.compile`` (compilation
#    *and* cache loading), ``fricfem.model.mesh.build``, ``assembly.stiffness``,
#    ``assembly.lumped_mass`` and ``assembly.max_eigenvalue`` with timers, so that
#    JIT time is separated from the phase it happens in (mean over ranks, so
#    that the phases add up).
#
# Also timed: ``mpirun -n 2 python -c "from mpi4py import MPI"`` (launcher and
# interpreter), and ``fricfem mesh --preset reference`` alone.  Cold runs are
# repeated (``--cold-repeats``, each with fresh directories) and warm runs too
# (``--warm-repeats``); the tables give the median and the minimum — on a
# shared machine the minimum is the better estimate of an idle one.  Target:
# **≤ 10 s warm** for the whole command.
#
# Run (a plain ``python``: the script launches ``mpirun`` itself)::
#
#     .venv/bin/python benchmarks/end_to_end.py [--warm-repeats 3]
#
# writes ``benchmarks/results/end_to_end.json`` and ``end_to_end.md`` and
# prints the table.  ``--smoke`` runs only the probe, in-process on the
# caller's communicator, on the coarse mesh to 5 µs (tests under mpirun).

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
VENV = ROOT / ".venv" / "bin"
TARGET_WARM_S = 10.0
LAST_CPU = [0.0, None]  # CPU seconds of the last command, others' share of the CPUs meanwhile


# ## The probe: one run with JIT timers
#
# The wrappers are installed before fricfem is imported, because fricfem
# compiles its kernels with explicit signatures at import time.  Nested
# numba compilations (a kernel compiling the functions it calls) are counted
# once, at the outermost level.


class Timers:
    """Wall time per named activity, each call logged as (name, start, duration)."""

    def __init__(self):
        self.calls = []
        self.depth = {}
        self.wrapped = []

    def wrap(self, owner, attr: str, name: str, outermost: bool = True):
        inner = getattr(owner, attr)
        self.wrapped.append((owner, attr, inner))
        timers = self

        def timed(*args, **kwargs):
            depth = timers.depth.get(name, 0)
            timers.depth[name] = depth + 1
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                timers.depth[name] = depth
                if depth == 0 or not outermost:
                    timers.calls.append((name, t0, time.perf_counter() - t0))

        setattr(owner, attr, timed)

    def restore(self) -> None:
        """Put the wrapped functions back (the probe may run inside a longer process)."""
        for owner, attr, inner in reversed(self.wrapped):
            setattr(owner, attr, inner)
        self.wrapped.clear()

    def total(self, name: str, start: float = -1e300, end: float = 1e300) -> float:
        return sum(d for n, t0, d in self.calls if n == name and start <= t0 < end)

    def inside(self, names: tuple, outer: str) -> float:
        """Time of the ``names`` calls that started inside a call of ``outer``."""
        spans = [(t0, t0 + d) for n, t0, d in self.calls if n == outer]
        return sum(d for n, t0, d in self.calls if n in names and any(a <= t0 < b for a, b in spans))

    def count(self, name: str) -> int:
        return sum(1 for n, _, _ in self.calls if n == name)


def probe(scene: str, sets: list, out: Path, comm=None) -> dict:
    """Run ``scene`` in this process with JIT and phase timers (collective); the split on every rank."""
    timers = Timers()
    try:
        t_start = time.perf_counter()
        import numba.core.dispatcher  # timers go in before fricfem compiles anything

        timers.wrap(numba.core.dispatcher.Dispatcher, "compile", "numba")
        t_numba_import = time.perf_counter() - t_start
        t0 = time.perf_counter()
        import dolfinx.jit

        timers.wrap(dolfinx.jit, "ffcx_jit", "ffcx")
        from mpi4py import MPI

        t_mid = time.perf_counter()
        from fricfem.model import mesh as mesh
        from fricfem import load_scene
        from fricfem import runner
        from fricfem.model import build as build_mod

        t_import = time.perf_counter() - t0 + t_numba_import
        t_fricfem_import = time.perf_counter() - t_mid
        comm = comm or MPI.COMM_WORLD
        timers.wrap(mesh, "build", "mesh")
        timers.wrap(build_mod, "canonical_rows", "stiffness")
        timers.wrap(build_mod, "canonical_mass", "mass")
        timers.wrap(build_mod, "max_eigenvalue", "dt")

        timers.wrap(runner, "run", "loop")  # the time loop (fricfem.step.run over evolve)
        from fricfem import observe

        for cls in {type(o) for o in vars(observe).values() if isinstance(o, type)}:
            for verb in ("observe", "contribute"):  # the loop's outputs (the observers)
                if verb in vars(cls):
                    timers.wrap(cls, verb, "observe")

        cfg = load_scene(scene, sets)
        t_run = time.perf_counter()
        summary = runner.run_scene(cfg, out, comm, overwrite=True, quiet=True)
        t_done = time.perf_counter()
    finally:
        timers.restore()
    w = summary["wall_s"]
    # the phases from the probe's own clock: setup until the loop starts, the loop less the
    # observers' outputs inside it, the outputs (inside the loop and after it); JIT goes to the
    # phase it started in (a kernel first compiled in a snapshot is output JIT)
    (_, loop0, loop_s), = [c for c in timers.calls if c[0] == "loop"]
    loop1 = loop0 + loop_s
    observe_s = timers.total("observe")  # the observers are called only inside the loop
    in_observe = {k: timers.inside((k,), "observe") for k in ("ffcx", "numba")}
    jit_setup = {k: timers.total(k, t_run, loop0) for k in ("ffcx", "numba")}
    jit_loop = {k: timers.total(k, loop0, loop1) - in_observe[k] for k in ("ffcx", "numba")}
    jit_output = {k: in_observe[k] + timers.total(k, loop1, t_done) for k in ("ffcx", "numba")}
    numba_import = timers.total("numba", end=t_run)
    local = {
        "import_s": t_import, "import_fricfem_s": t_fricfem_import, "numba_jit_in_import_s": numba_import,
        "mesh_s": timers.total("mesh"), "jit_in_mesh_s": timers.inside(("ffcx", "numba"), "mesh"),
        "stiffness_s": timers.total("stiffness"), "mass_s": timers.total("mass"),
        "dt_power_iteration_s": timers.total("dt"),
        "ffcx_jit_setup_s": jit_setup["ffcx"], "numba_jit_setup_s": jit_setup["numba"],
        "ffcx_jit_loop_s": jit_loop["ffcx"], "numba_jit_loop_s": jit_loop["numba"],
        "ffcx_jit_output_s": jit_output["ffcx"], "numba_jit_output_s": jit_output["numba"],
        "setup_s": loop0 - t_run, "first_step_s": w["first_step_incl_jit"], "time_loop_s": loop_s - observe_s,
        "output_s": observe_s + t_done - loop1, "run_total_s": t_done - t_run,
    }
    # the mean over ranks keeps the phases additive (a max per phase would mix ranks)
    mean = {k: comm.allreduce(v, op=MPI.SUM) / comm.size for k, v in local.items()}
    mean["run_total_max_s"] = comm.allreduce(local["run_total_s"], op=MPI.MAX)
    mean["numba_compilations"] = comm.allreduce(timers.count("numba"), op=MPI.MAX)
    mean["ffcx_calls"] = comm.allreduce(timers.count("ffcx"), op=MPI.MAX)
    mean.update(steps=summary["steps"], dofs=summary["dofs"], dt_s=summary["dt_s"], ranks=comm.size)
    return mean | split_probe(mean)


def split_probe(p: dict) -> dict:
    """The probe's phases without JIT: setup, JIT (ffcx, numba), loop, output."""
    jit_setup = p["ffcx_jit_setup_s"] + p["numba_jit_setup_s"]
    jit_loop = p["ffcx_jit_loop_s"] + p["numba_jit_loop_s"]
    jit_output = p["ffcx_jit_output_s"] + p["numba_jit_output_s"]
    return {
        "split": {
            "import (excl. numba)": p["import_s"] - p["numba_jit_in_import_s"],
            "setup: mesh (excl. JIT)": p["mesh_s"] - p["jit_in_mesh_s"],
            "setup: assembly, dt, rest (excl. JIT)": p["setup_s"] - (p["mesh_s"] - p["jit_in_mesh_s"]) - jit_setup,
            "JIT: ffcx forms": p["ffcx_jit_setup_s"] + p["ffcx_jit_loop_s"] + p["ffcx_jit_output_s"],
            "JIT: numba (compile or cache load)": p["numba_jit_in_import_s"] + p["numba_jit_setup_s"]
            + p["numba_jit_loop_s"] + p["numba_jit_output_s"],
            "time loop (excl. JIT)": p["time_loop_s"] - jit_loop,
            "output (excl. JIT)": p["output_s"] - jit_output,
        }
    }


# ## Subprocesses


def mpi_env(extra: dict | None = None) -> dict:
    env = dict(os.environ)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    env.setdefault("OMP_NUM_THREADS", "1")
    env.update(extra or {})
    return env


def timed_command(cmd: list, env: dict) -> tuple:
    """(wall seconds, completed process); raises with the output if the command fails.

    ``LAST_CPU[0]`` is set to the CPU seconds (user + system) of the command and its
    children (all ranks; busy-waiting in MPI counts as CPU time)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    b0 = machine_busy_s()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    b1 = machine_busy_s()
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    LAST_CPU[0] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    # CPU time other processes took from the machine meanwhile, as a share of all its CPUs
    LAST_CPU[1] = None if b0 is None else max(b1 - b0 - LAST_CPU[0], 0.0) / (wall * (os.cpu_count() or 1))
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return wall, proc


def machine_busy_s() -> float | None:
    """CPU seconds the whole machine has spent busy since boot (/proc/stat; None elsewhere)."""
    try:
        with open("/proc/stat") as fh:
            v = [int(x) for x in fh.readline().split()[1:]]
    except OSError:
        return None
    return (sum(v) - v[3] - v[4]) / os.sysconf("SC_CLK_TCK")


def busy_fraction(sample_s: float = 0.5) -> float | None:
    """Share of the machine's CPU time spent busy over ``sample_s`` (from /proc/stat; None elsewhere)."""
    def read():
        with open("/proc/stat") as fh:
            v = [int(x) for x in fh.readline().split()[1:]]
        return sum(v), v[3] + v[4]  # total, idle + iowait

    try:
        t0, i0 = read()
        time.sleep(sample_s)
        t1, i1 = read()
    except OSError:
        return None
    return 1.0 - (i1 - i0) / max(t1 - t0, 1)


def wait_idle(max_wait_s: float, busy_max: float = 0.15) -> float | None:
    """Wait (at most ``max_wait_s``) until other processes leave the CPUs nearly idle; the last busy share.

    The machine may be shared: a run measured while others compute is slower
    by an amount that says nothing about fricfem."""
    deadline = time.monotonic() + max_wait_s
    busy = busy_fraction()
    while busy is not None and busy > busy_max and time.monotonic() < deadline:
        time.sleep(2.0)
        busy = busy_fraction()
    return busy


def cache_env(root: Path) -> dict:
    return {"XDG_CACHE_HOME": str(root / "xdg"), "NUMBA_CACHE_DIR": str(root / "numba")}


def cache_files(root: Path) -> dict:
    """Files in the two cache directories: ffcx modules and numba index/data files."""
    xdg = root / "xdg" / "fenics"
    nb = root / "numba"
    return {"ffcx_modules": len(list(xdg.glob("*.so"))) if xdg.exists() else 0,
            "numba_index_files": len(list(nb.rglob("*.nbi"))) if nb.exists() else 0,
            "numba_data_files": len(list(nb.rglob("*.nbc"))) if nb.exists() else 0}


def package_pycache() -> dict:
    """numba files in fricfem/**/__pycache__: name -> mtime."""
    return {str(p.relative_to(ROOT)): p.stat().st_mtime
            for p in (ROOT / "fricfem").rglob("__pycache__/*.nb[ic]")}


def run_command(np_: int, scene: str, sets: list, out: Path, env: dict, idle_wait: float = 0.0) -> dict:
    busy = wait_idle(idle_wait)
    cmd = ["mpirun", "-n", str(np_), str(VENV / "fricfem"), "run", scene, "--out", str(out), "--overwrite",
           "--quiet"]
    for s in sets:
        cmd += ["--set", s]
    wall, _ = timed_command(cmd, env)
    summary = json.loads((out / "summary.json").read_text())
    w = summary["wall_s"]
    return {"command": " ".join(cmd[:3] + [".venv/bin/fricfem", *cmd[4:]]), "wall_s": wall, "cpu_s": LAST_CPU[0],
            "load_avg_1min": os.getloadavg()[0], "busy_before": busy,
            "others_cpu_share": LAST_CPU[1], "summary_wall_s": w,
            "startup_s": wall - w["total"], "steps": summary["steps"], "dofs": summary["dofs"],
            "complete": summary["complete"]}


def run_probe(np_: int, scene: str, sets: list, out: Path, env: dict, result: Path, idle_wait: float = 0.0) -> dict:
    busy = wait_idle(idle_wait)
    cmd = ["mpirun", "-n", str(np_), str(VENV / "python"), str(Path(__file__).resolve()), "--probe",
           "--scene", scene, "--run-dir", str(out), "--probe-json", str(result)]
    for s in sets:
        cmd += ["--set", s]
    wall, _ = timed_command(cmd, env)
    return json.loads(result.read_text()) | {"wall_s": wall, "cpu_s": LAST_CPU[0], "busy_before": busy,
                                              "others_cpu_share": LAST_CPU[1]}


# ## Numba's cache location
#
# A throw-away module with one ``cache=True`` function, compiled once without
# and once with ``NUMBA_CACHE_DIR``: where do the index files go?


NB_MODULE = "import numba\n\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n"


def numba_cache_location(tmp: Path) -> dict:
    src = tmp / "nbprobe"
    src.mkdir(parents=True)
    (src / "nbmod.py").write_text(NB_MODULE)
    code = f"import sys; sys.path.insert(0, {str(src)!r}); import nbmod; nbmod.f(1)"
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    subprocess.run([str(VENV / "python"), "-c", code], env=env, check=True)
    default = sorted(p.name for p in (src / "__pycache__").glob("*.nbi"))
    shutil.rmtree(src / "__pycache__", ignore_errors=True)
    subprocess.run([str(VENV / "python"), "-c", code], env=env | {"NUMBA_CACHE_DIR": str(tmp / "nbdir")}, check=True)
    moved = sorted(str(p.relative_to(tmp / "nbdir")) for p in (tmp / "nbdir").rglob("*.nbi"))
    left = sorted(p.name for p in (src / "__pycache__").glob("*.nbi")) if (src / "__pycache__").exists() else []
    return {"without_NUMBA_CACHE_DIR": {"__pycache__": default},
            "with_NUMBA_CACHE_DIR": {"cache_dir": moved, "__pycache__": left},
            "default_is_pycache": bool(default), "moved": bool(moved) and not left}


# ## Report


PHASES = ("startup (mpirun, interpreter, imports)", "setup", "time loop", "output", "total (command)")


def command_split(r: dict) -> dict:
    w = r["summary_wall_s"]
    return dict(zip(PHASES, (r["startup_s"], w["setup"], w["time_loop"], w["output"], r["wall_s"])))


def med(values) -> float:
    return float(statistics.median(values))


def summarise(runs: list, split) -> dict:
    """Median and min per phase over repeated runs."""
    phases = list(split(runs[0]))
    return {"median": {ph: med(split(r)[ph] for r in runs) for ph in phases},
            "min": {ph: min(split(r)[ph] for r in runs) for ph in phases}}


def table(doc: dict) -> str:
    c, w = doc["command"]["cold_summary"], doc["command"]["warm_summary"]
    nc, nw = len(doc["command"]["cold"]), len(doc["command"]["warm"])
    cold0 = doc["command"]["cold"][0]
    lines = [f"`{cold0['command']}` — {doc['dofs']} dofs, {doc['steps']} steps, {doc['np']} ranks; "
             f"median (min) of {nc} cold and {nw} warm runs", "",
             "| phase (the command; summary.json) | cold [s] | warm [s] |", "|---|---|---|"]
    for ph in PHASES:
        lines.append(f"| {ph} | {c['median'][ph]:.2f} ({c['min'][ph]:.2f}) | "
                     f"{w['median'][ph]:.2f} ({w['min'][ph]:.2f}) |")
    lines.append(f"| CPU time, all processes (user + system) | {med(r['cpu_s'] for r in doc['command']['cold']):.2f} | "
                 f"{med(r['cpu_s'] for r in doc['command']['warm']):.2f} |")
    lines.append(f"| others' share of the CPUs meanwhile (median) | {_share(doc['command']['cold'])} | "
                 f"{_share(doc['command']['warm'])} |")
    pc, pw = doc["probe"]["cold_summary"], doc["probe"]["warm_summary"]
    lines += ["", "| phase (probe: JIT separated; mean over ranks) | cold [s] | warm [s] |", "|---|---|---|"]
    for ph in pc["median"]:
        lines.append(f"| {ph} | {pc['median'][ph]:.2f} ({pc['min'][ph]:.2f}) | "
                     f"{pw['median'][ph]:.2f} ({pw['min'][ph]:.2f}) |")
    lines.append(f"| probe command, whole | {med(r['wall_s'] for r in doc['probe']['cold']):.2f} | "
                 f"{med(r['wall_s'] for r in doc['probe']['warm']):.2f} |")
    x = doc["extras"]
    lines += ["", "| other (warm caches; median) | [s] |", "|---|---|",
              f"| `mpirun -n {doc['np']} python -c 'from mpi4py import MPI'` | {x['mpirun_python_s']:.2f} |",
              f"| import of fricfem.runner with dolfinx, PETSc, numba (probe, in-process) | "
              f"{med(r['import_s'] for r in doc['probe']['warm']):.2f} |",
              f"| of which fricfem's own modules (numba cache loads included) | "
              f"{med(r['import_fricfem_s'] for r in doc['probe']['warm']):.2f} |",
              f"| `mpirun -n {doc['np']} fricfem mesh --preset {doc['preset']}` (whole command) | "
              f"{x['mesh_command_s']:.2f} |",
              f"| mesh generation alone (probe: `mesh.build`) | {med(r['mesh_s'] for r in doc['probe']['warm']):.2f} |",
              "", doc["verdict"]]
    return "\n".join(lines)


def _share(runs) -> str:
    v = [r["others_cpu_share"] for r in runs if r.get("others_cpu_share") is not None]
    return f"{100 * med(v):.0f} %" if v else "–"


def verdict(doc: dict) -> str:
    w = doc["command"]["warm_summary"]["median"]
    c = doc["command"]["cold_summary"]["median"]
    main = max((p for p in PHASES if not p.startswith("total")), key=lambda p: w[p])
    pw = doc["probe"]["warm_summary"]["median"]
    pc = doc["probe"]["cold_summary"]["median"]
    wmain = max(pw, key=pw.get)
    cmain = max(pc, key=pc.get)
    ok = w["total (command)"] <= TARGET_WARM_S
    wmin = doc["command"]["warm_summary"]["min"]["total (command)"]
    return (f"Warm: {w['total (command)']:.1f} s median, {wmin:.1f} s min — target ≤ {TARGET_WARM_S:g} s "
            f"{'met' if ok else 'NOT met'} (judged on the median). "
            f"Warm, the largest phase of the command is {main} ({w[main]:.1f} s); with JIT separated, "
            f"{wmain} ({pw[wmain]:.1f} s). Cold: {c['total (command)']:.1f} s, dominated by {cmain} "
            f"({pc[cmain]:.1f} s of the probe's {sum(pc.values()):.1f} s).")


def markdown(doc: dict) -> str:
    nc = doc["numba_cache"]
    loc = nc["experiment"]
    lines = ["# End-to-end time of `fricfem run case1`", "",
             f"`.venv/bin/python benchmarks/end_to_end.py` — {doc['finished']}, commit {doc['git']}, "
             f"{doc['machine']['node']} ({doc['machine']['cpus']} CPUs, shared with other jobs: each timed run "
             "waits for idle CPUs first, the table gives the CPU share other processes took meanwhile, and the "
             "minima are the better estimate of an idle machine). Cold: `XDG_CACHE_HOME` and `NUMBA_CACHE_DIR` "
             "set to fresh temporary directories (one pair per cold run); warm: the same directories again. "
             "Python's own bytecode cache is not reset"
             + (" (and with PYTHONDONTWRITEBYTECODE set here, fricfem's modules are byte-compiled at every start, "
                "cold or warm)" if doc["machine"].get("PYTHONDONTWRITEBYTECODE") else "") + ".", "",
             table(doc), "",
             "Reading the two tables: the command's `setup` and `time loop` contain the JIT (ffcx during setup, "
             "numba partly at import, partly in setup and in the first step); the probe moves it into the JIT rows. "
             "`startup` is the command's wall time beyond its own `wall_s.total`: mpirun, the interpreter, MPI, "
             "the imports and the scene's validation.", "",
             "## Numba's cache", "",
             f"A throw-away module with one `@numba.njit(cache=True)` function: without `NUMBA_CACHE_DIR` numba "
             f"writes `{', '.join(loc['without_NUMBA_CACHE_DIR']['__pycache__']) or 'nothing'}` into "
             "`__pycache__` next to the source file; with `NUMBA_CACHE_DIR` set, "
             f"`{', '.join(loc['with_NUMBA_CACHE_DIR']['cache_dir']) or 'nothing'}` goes into that directory "
             "(in a sub-directory named after the source directory and a hash of its path) and "
             f"{'nothing' if not loc['with_NUMBA_CACHE_DIR']['__pycache__'] else 'still something'} "
             "into `__pycache__`. So fricfem's kernels cache into `fricfem/**/__pycache__` by default "
             f"({nc['package_pycache_files']} `.nbi`/`.nbc` files there now) and `NUMBA_CACHE_DIR` moves them: "
             f"the first cold run wrote {nc['cold_run_files']['numba_index_files']} index and "
             f"{nc['cold_run_files']['numba_data_files']} data files into it "
             f"({', '.join(nc['cold_run_index_names'])}) and "
             + ("touched none of the same names in the package's `__pycache__`"
                if not nc["package_pycache_changed_same_names"] else
                "also touched " + ", ".join(nc["package_pycache_changed_same_names"])
                + " in the package's `__pycache__`")
             + (f" (other files there changed meanwhile — other processes compiling other modules: "
                f"{len(nc['package_pycache_changed_other'])})" if nc["package_pycache_changed_other"] else "")
             + f". The ffcx cache received {nc['cold_run_files']['ffcx_modules']} compiled modules.", ""]
    return "\n".join(lines)


# ## Driver


def full(args) -> dict:
    scene, sets, np_ = args.scene, list(args.set or []), args.np
    if args.preset and args.preset != "reference":
        sets = [f"mesh.preset={json.dumps(args.preset)}"] + sets
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    before = package_pycache()
    tmp = Path(tempfile.mkdtemp(prefix="fricfem_e2e_"))
    loads = []
    try:
        location = numba_cache_location(tmp / "location")
        cold, warm, p_cold, p_warm = [], [], [], []
        files = index_names = None
        for i in range(args.cold_repeats):
            env = mpi_env(cache_env(tmp / f"cmd{i}"))
            cold.append(run_command(np_, scene, sets, work / "run", env, args.idle_wait))
            if i == 0:
                files = cache_files(tmp / "cmd0")
                index_names = sorted(p.name for p in (tmp / "cmd0" / "numba").rglob("*.nbi"))
            loads.append(os.getloadavg()[0])
        env_warm = mpi_env(cache_env(tmp / "cmd0"))
        for _ in range(args.warm_repeats):
            warm.append(run_command(np_, scene, sets, work / "run", env_warm, args.idle_wait))
            loads.append(os.getloadavg()[0])
        for i in range(args.cold_repeats):
            env = mpi_env(cache_env(tmp / f"probe{i}"))
            p_cold.append(run_probe(np_, scene, sets, work / "probe", env, tmp / f"probe_cold{i}.json",
                                    args.idle_wait))
        env_probe = mpi_env(cache_env(tmp / "probe0"))
        for i in range(args.warm_repeats):
            p_warm.append(run_probe(np_, scene, sets, work / "probe", env_probe, tmp / f"probe_warm{i}.json",
                                    args.idle_wait))
            loads.append(os.getloadavg()[0])
        launcher = med(timed_command(["mpirun", "-n", str(np_), str(VENV / "python"), "-c", "from mpi4py import MPI"],
                                     env_warm)[0] for _ in range(3))
        mesh_cmd = med(timed_command(["mpirun", "-n", str(np_), str(VENV / "fricfem"), "mesh", "--preset",
                                      args.preset or "reference"], env_warm)[0] for _ in range(3))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    after = package_pycache()
    changed = sorted(k for k in after if before.get(k) != after[k])
    same = [k for k in changed if Path(k).name in set(index_names) or Path(k).name.replace(".nbc", "") in
            {n.replace(".nbi", "") for n in index_names}]
    git = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True)
    doc = {
        "study": "end-to-end time of fricfem run", "scene": scene, "sets": sets, "preset": args.preset or "reference",
        "np": np_, "finished": time.strftime("%Y-%m-%d %H:%M"), "git": git.stdout.strip() or "?",
        "target_warm_s": TARGET_WARM_S, "dofs": cold[0]["dofs"], "steps": cold[0]["steps"],
        "command": {"cold": cold, "warm": warm, "cold_summary": summarise(cold, command_split),
                    "warm_summary": summarise(warm, command_split)},
        "probe": {"cold": p_cold, "warm": p_warm, "cold_summary": summarise(p_cold, lambda r: r["split"]),
                  "warm_summary": summarise(p_warm, lambda r: r["split"])},
        "extras": {"mpirun_python_s": launcher, "mesh_command_s": mesh_cmd},
        "numba_cache": {"experiment": location, "default_location": "__pycache__ next to each source file",
                        "cold_run_files": files, "cold_run_index_names": index_names,
                        "package_pycache_files": len(after), "package_pycache_changed_same_names": same,
                        "package_pycache_changed_other": [k for k in changed if k not in same]},
        "machine": {"node": platform.node(), "cpus": os.cpu_count(), "python": sys.version.split()[0],
                    "PYTHONDONTWRITEBYTECODE": os.environ.get("PYTHONDONTWRITEBYTECODE", ""),
                    "load_avg_range": [min(loads), max(loads)]},
    }
    doc["target_met"] = doc["command"]["warm_summary"]["median"]["total (command)"] <= TARGET_WARM_S
    doc["verdict"] = verdict(doc)
    return doc


def main(argv=None, comm=None) -> dict | None:
    ap = argparse.ArgumentParser(description="End-to-end time of `fricfem run` on 2 ranks, cold and warm caches.")
    ap.add_argument("--scene", default="case1")
    ap.add_argument("--preset", default="reference", help="mesh preset")
    ap.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help="scene override (repeatable)")
    ap.add_argument("--np", type=int, default=2, help="MPI ranks of the timed command")
    ap.add_argument("--cold-repeats", type=int, default=2, help="cold runs, each with fresh cache directories")
    ap.add_argument("--warm-repeats", type=int, default=5)
    ap.add_argument("--idle-wait", type=float, default=90.0,
                    help="seconds to wait, before each timed run, for other processes to leave the CPUs idle")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "end_to_end", help="run directories")
    ap.add_argument("--smoke", action="store_true",
                    help="the probe only, in-process on the caller's communicator (coarse mesh, 5 µs)")
    ap.add_argument("--probe", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--run-dir", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--probe-json", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.probe:  # a child of full(): mpirun -n N python end_to_end.py --probe ...
        sets = list(args.set or [])
        res = probe(args.scene, sets, args.run_dir, comm)
        from mpi4py import MPI

        if (comm or MPI.COMM_WORLD).rank == 0:
            args.probe_json.write_text(json.dumps(res, indent=1))
        return res

    if args.smoke:
        from mpi4py import MPI

        comm = comm or MPI.COMM_WORLD
        sets = ["mesh.preset='coarse'", "time.end=5e-6", "output.fields=[4e-6]"] + list(args.set or [])
        res = probe(args.scene, sets, args.work / "smoke", comm)
        doc = None
        if comm.rank == 0:
            doc = {"study": "end-to-end time of fricfem run (smoke: in-process probe only)", "scene": args.scene,
                   "sets": sets, "np": comm.size, "smoke": True, "finished": time.strftime("%Y-%m-%d %H:%M"),
                   "probe": {"in_process": res}}
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / "end_to_end.json").write_text(json.dumps(doc, indent=1))
            for ph, s in res["split"].items():
                print(f"{ph:45s} {s:7.2f} s")
        return comm.bcast(doc, root=0)

    doc = full(args)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "end_to_end.json").write_text(json.dumps(doc, indent=1))
    (args.out / "end_to_end.md").write_text(markdown(doc))
    print(table(doc))
    return doc


if __name__ == "__main__":
    main()
