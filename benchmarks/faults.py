"""Random SIGKILLs over a 2-rank run: what survives each.

A run of ``fricfem run`` under ``mpirun -n 2`` is started N times and each time
killed with SIGKILL — mpirun and both ranks at once, no handler runs — at a
uniformly random instant between its start and the wall time a complete run
takes (so setup, the time loop and the end are all hit).  After each kill the
run directory is checked against a complete run of the same scene:

* ``summary.json`` (and ``evidence.json``) parse, if present;
* ``interface.h5`` opens with the public reader (``fricfem.open_run``), if
  present; its valid rows are bit-identical to the complete run's first rows
  (every quantity, the station histories, the energy history), and there are at
  least as many as ``summary.json`` says were flushed;
* every snapshot ``fields.xdmf`` lists reads (every function) and equals the
  complete run's;
* ``fricfem plot`` draws the killed directory (exit 0).

    .venv/bin/python benchmarks/faults.py            # N = 24; results/faults.{md,json}
    .venv/bin/python benchmarks/faults.py --n 3 --no-write

The helpers (:func:`start`, :func:`kill_tree`, :func:`check`) are what
``tests/test_faults.py`` uses; it kills on events, not at instants
(:func:`kill_at_rows`: once the run's interface.h5 is laid out, or holds a
given number of valid rows, read from the file), so that where a kill lands
does not depend on the machine's speed or load.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FRICFEM = ROOT / ".venv" / "bin" / "fricfem"
RESULTS = ROOT / "benchmarks" / "results"
#: the run killed: Case III on the reference mesh, 70 µs, an interface row every step
SCENE = ["case3", "--set", "time.end=70e-6", "--set", "output.interface_every=1e-7",
         "--set", "output.fields=[10e-6,20e-6,30e-6,40e-6,50e-6,60e-6]"]


def clean_env() -> dict:
    """This environment without an enclosing MPI job's variables (for a separate mpirun)."""
    keep = ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "OMPI_MCA_rmaps_base_oversubscribe")
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OMPI_", "PMIX_", "OPAL_", "PMI_", "HYDRA_")) or k in keep}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    return env


def start(args, out: Path, ranks: int = 2, log: Path | None = None) -> subprocess.Popen:
    """``mpirun -n ranks fricfem run ARGS --out OUT --overwrite --quiet`` in its own session."""
    cmd = ["mpirun", "-n", str(ranks), str(FRICFEM), "run", *args, "--out", str(out), "--overwrite", "--quiet"]
    sink = open(log, "w") if log else subprocess.DEVNULL  # noqa: SIM115 (closed with the process)
    return subprocess.Popen(cmd, env=clean_env(), start_new_session=True, stdout=sink, stderr=sink)


def _children() -> dict:
    """{ppid: [pid, ...]} of every process."""
    out: dict = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
            except OSError:
                continue
            out.setdefault(int(stat.rpartition(")")[2].split()[1]), []).append(int(d))
    return out


def tree(pid: int) -> list:
    """``pid`` and every descendant (mpirun puts its ranks in process groups of their
    own, so a group signal misses them)."""
    children, todo, found = _children(), [pid], []
    while todo:
        p = todo.pop()
        found.append(p)
        todo += children.get(p, [])
    return found


def signal_tree(pid: int, sig: int) -> int:
    """Send ``sig`` to ``pid`` and every descendant; the number signalled."""
    found = tree(pid)
    for p in found:
        try:
            os.kill(p, sig)
        except ProcessLookupError:
            pass
    return len(found)


def kill_tree(pid: int) -> int:
    """SIGKILL ``pid`` and every descendant; the number killed."""
    return signal_tree(pid, signal.SIGKILL)


def lock_holder(out: Path, jobs: list, poll_s: float = 0.02):
    """Wait for the event: one of ``jobs`` (from :func:`start`) holds ``out``'s lock, its
    pid read from the lock file and found in that job's process tree; that job (None if
    every job ended first).  No clock: ``poll_s`` is only how often the file is looked at."""
    from fricfem.output.directory import LOCK_FILE

    while any(j.poll() is None for j in jobs):
        try:
            pid = json.loads((Path(out) / LOCK_FILE).read_text())["pid"]
        except (OSError, ValueError, KeyError, TypeError):
            pid = None
        for j in jobs:
            if pid is not None and j.poll() is None and pid in tree(j.pid):
                return j
        time.sleep(poll_s)
    return None


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


def check(rundir: Path, ref: Path) -> dict:
    """What a killed run directory holds, against the complete run ``ref`` (see the module
    docstring); ``problems`` lists every promise broken."""
    from fricfem import open_run
    from fricfem.output.quantities import FIELDS
    from fricfem.output.rundir import FieldReader

    rundir, problems = Path(rundir), []
    out = {"rows": 0, "flushed_rows": 0, "station_rows": 0, "energy_rows": 0, "snapshots": 0, "steps": None}
    summary = {}
    for name in ("summary.json", "evidence.json"):
        if (rundir / name).exists():
            try:
                doc = json.loads((rundir / name).read_text())
                summary = doc if name == "summary.json" else summary
            except ValueError as err:
                problems.append(f"{name}: {err}")
    full = open_run(ref)
    if (rundir / "interface.h5").exists():
        try:
            run = open_run(rundir)
        except Exception as err:  # the promise: it always opens
            problems.append(f"interface.h5: {type(err).__name__}: {err}")
            run = None
        if run is not None:
            n = len(run.t)
            out.update(rows=n, energy_rows=len(run.energy.get("time", [])),
                       station_rows=min((len(s["time"]) for s in run.stations.values()), default=0))
            bad = [q for q in full.names if not _same(run.quantity(q), full.quantity(q)[:n])]
            bad += [f"stations/{s}/{k}" for s, d in run.stations.items() for k, v in d.items()
                    if k != "x1" and not _same(v, full.stations[s][k][:len(v)])]
            bad += [f"energy/{k}" for k, v in run.energy.items() if not _same(v, full.energy[k][:len(v)])]
            if bad or not _same(run.t, full.t[:n]):
                problems.append(f"rows differ from the complete run: {bad[:4]}")
            steps = summary.get("steps") or 0
            cadence = ((full.summary.get("input") or {}).get("output") or {}).get("interface_every", 0.2e-6)
            every = max(1, int(round(cadence / full.summary["dt_s"])))
            out["steps"] = steps
            out["flushed_rows"] = (steps - 1) // every + 1 if steps else 0
            if n < out["flushed_rows"]:
                problems.append(f"{n} rows, but summary.json says {out['flushed_rows']} were flushed")
    if (rundir / "fields.xdmf").exists():
        try:
            for name in FIELDS:
                got, want = FieldReader(rundir / "fields.xdmf", name), FieldReader(ref / "fields.xdmf", name)
                out["snapshots"] = len(got.times)
                for i, t in enumerate(got.times):
                    j = int(np.argmin(np.abs(want.times - t)))
                    if want.times[j] != t or not _same(got.values(i), want.values(j)):
                        problems.append(f"fields.xdmf: {name} at {t:.3g} s differs")
        except Exception as err:
            problems.append(f"fields.xdmf: {type(err).__name__}: {err}")
    out["problems"] = problems
    return out


def plot_ok(rundir: Path) -> tuple[bool, str]:
    """``fricfem plot RUNDIR`` exits 0 (its last stderr line otherwise)."""
    res = subprocess.run([str(FRICFEM), "plot", str(rundir), "--out", str(rundir / "plots_check")],
                         capture_output=True, text=True, env=clean_env(), timeout=300)
    return res.returncode == 0, (res.stderr.strip().splitlines() or [""])[-1]


def complete_run(args, out: Path) -> float:
    """Run ``args`` to the end into ``out``; its wall time [s]."""
    t0 = time.perf_counter()
    p = start(args, out, log=out.parent / f"{out.name}.log")
    if p.wait(timeout=1800) != 0:
        raise SystemExit(f"the complete run failed: {(out.parent / f'{out.name}.log').read_text()[-2000:]}")
    return time.perf_counter() - t0


def kill_once(args, out: Path, ref: Path, at: float, plot: bool = True) -> dict:
    """Start the run, SIGKILL it ``at`` seconds later, check what it left.  ``out`` is
    emptied first: a run killed before it replaced the directory would otherwise
    leave the previous run's complete outputs there, to be counted as its own."""
    shutil.rmtree(out, ignore_errors=True)
    p = start(args, out)
    time.sleep(at)
    return _kill_and_check(p, out, ref, plot, kill_at_s=round(at, 3))


def _kill_and_check(p, out: Path, ref: Path, plot: bool, **when) -> dict:
    """Kill the job ``p`` (mpirun and its ranks), then what survived in ``out`` against
    the complete run ``ref`` (:func:`check`), and ``fricfem plot`` on it if ``plot``;
    ``when``: where the kill landed, first in the record."""
    ended = p.poll() is not None
    killed = kill_tree(p.pid)
    p.wait()
    res = {**when, "ended_before_kill": ended, "processes_killed": killed, **check(out, ref)}
    if ended:  # the job ended on its own: why (its status and the end of what it printed)
        log = out.parent / f"{out.name}.log"
        res["job_status"] = p.returncode
        res["job_log_tail"] = log.read_text()[-1500:] if log.is_file() else None
    if plot and (out / "interface.h5").exists():
        ok, why = plot_ok(out)
        res["plot"] = ok
        if not ok:
            res["problems"].append(f"fricfem plot: {why}")
    return res


def live_rows(path: Path) -> int | None:
    """The valid rows of a running job's interface.h5, read from the file as any
    reader would (0: laid out, no row flushed yet); None while it is not there
    (it appears complete, by a rename, once laid out) or cannot be read at this
    instant."""
    from fricfem.output.rundir import _h5open, valid_rows

    if not Path(path).is_file():
        return None
    try:
        with _h5open(path) as f:
            return valid_rows(f["time"])
    except Exception:  # being replaced at the end of the run: look again
        return None


def kill_at_rows(args, out: Path, ref: Path, rows: int, plot: bool = True, poll_s: float = 0.02) -> dict:
    """Start the run, wait for the event — its interface.h5 laid out (``rows`` = 0)
    or holding at least ``rows`` valid rows — then SIGKILL it at once and check
    what it left (:func:`check`).  ``rows_seen``: the valid rows when the event
    was seen (None: the run ended first).  No clock: ``poll_s`` is only how often
    the file is looked at.  ``out`` is emptied first (see :func:`kill_once`)."""
    shutil.rmtree(out, ignore_errors=True)
    p = start(args, out, log=out.parent / f"{out.name}.log")
    seen = None
    while p.poll() is None:
        n = live_rows(out / "interface.h5")
        if n is not None and n >= rows:
            seen = n
            break
        time.sleep(poll_s)
    return _kill_and_check(p, out, ref, plot, kill_at_rows=rows, rows_seen=seen)


def _plot_cell(r: dict) -> str:
    if "plot" not in r:
        return "(no interface.h5)"
    return "ok" if r["plot"] else "FAILED"


def report(doc: dict) -> str:
    runs = doc["kills"]
    rows = [r["rows"] for r in runs]
    bad = [r for r in runs if r["problems"]]
    lines = [
        "# Random SIGKILLs over a 2-rank run (`benchmarks/faults.py`)", "",
        f"`mpirun -n 2 fricfem run {' '.join(doc['scene'])}`: {doc['full_rows']} interface rows, "
        f"{doc['full_snapshots']} field snapshots; a complete run took {doc['full_wall_s']:.1f} s of wall time "
        f"here. Each of {len(runs)} runs was killed (SIGKILL to mpirun and both ranks) at a uniformly random "
        f"instant in [0, {doc['full_wall_s']:.1f}] s.", "",
        f"**{len(runs) - len(bad)} of {len(runs)} killed runs left readable outputs that keep every promise** "
        f"(interface rows bit-identical to the complete run's, at least the rows summary.json says were flushed; "
        f"summary.json valid; every listed field snapshot readable and identical; `fricfem plot` exit 0).", "",
        f"{sum(r['ended_before_kill'] for r in runs)} of the runs had already ended when the kill came; "
        f"{sum(r['rows'] == 0 and not (r['snapshots']) for r in runs)} were killed before their first interface row "
        "was flushed (in the setup, or before the first flush: no interface.h5 yet, or one with no valid row).", "",
        f"Rows that survived: median {statistics.median(rows):.0f}, min {min(rows)}, max {max(rows)} of "
        f"{doc['full_rows']}; rows beyond the last flush recorded in summary.json: median "
        f"{statistics.median([r['rows'] - r['flushed_rows'] for r in runs]):.0f} (a flush every "
        f"{doc['flush_rows']} rows and every output.flush_every seconds).", "",
        "| kill at [s] | interface rows | flushed per summary.json | station rows | energy rows | field snapshots "
        "| plot | problems |", "|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(runs, key=lambda r: r["kill_at_s"]):
        lines.append(f"| {r['kill_at_s']:.2f} | {r['rows']} | {r['flushed_rows']} | {r['station_rows']} | "
                     f"{r['energy_rows']} | {r['snapshots']} | {_plot_cell(r)} | "
                     f"{'; '.join(r['problems']) or '—'} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=24, help="number of killed runs (default 24)")
    ap.add_argument("--seed", type=int, default=10)
    ap.add_argument("--work", default=str(ROOT / "runs" / "faults"))
    ap.add_argument("--no-write", action="store_true", help="print, do not write results/")
    ap.add_argument("--report-only", action="store_true", help="rewrite results/faults.md from faults.json")
    args = ap.parse_args(argv)
    if args.report_only:
        (RESULTS / "faults.md").write_text(report(json.loads((RESULTS / "faults.json").read_text())))
        return 0
    from fricfem.observe import FLUSH_ROWS
    from fricfem import open_run

    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    ref = work / "complete"
    wall = complete_run(SCENE, ref)
    full = open_run(ref)
    rng = random.Random(args.seed)
    kills = []
    for i in range(args.n):
        r = kill_once(SCENE, work / "killed", ref, rng.uniform(0.0, wall))
        kills.append(r)
        print(f"{i + 1:3d}/{args.n} kill at {r['kill_at_s']:6.2f} s: {r['rows']:5d} rows "
              f"({r['flushed_rows']} flushed per summary), {r['snapshots']} snapshots  "
              f"{'; '.join(r['problems']) or 'ok'}", flush=True)
    from fricfem.output.rundir import FieldReader

    doc = {"scene": SCENE, "ranks": 2, "full_wall_s": wall, "full_rows": len(full.t), "flush_rows": FLUSH_ROWS,
           "full_snapshots": len(FieldReader(ref / "fields.xdmf").times), "seed": args.seed, "kills": kills}
    text = report(doc)
    print(text)
    if not args.no_write:
        RESULTS.mkdir(parents=True, exist_ok=True)
        (RESULTS / "faults.md").write_text(text)
        (RESULTS / "faults.json").write_text(json.dumps(doc, indent=1) + "\n")
    return 0 if all(not r["problems"] for r in kills) else 1


if __name__ == "__main__":
    sys.exit(main())
