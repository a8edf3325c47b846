"""Runs that survive faults (issue 10): SIGKILL at random points, a full file system,
an error on one rank, two runs into one directory, outputs confined to the run
directory, and one clear line for every file-system and command-line error.

Under ``mpirun -n 2``.  The runs that are killed, fill a disk or fail on one
rank are separate ``mpirun -n 2`` jobs started by rank 0 (the helpers of
``benchmarks/faults.py``); the directory checks call ``fricfem.cli.main`` or
the runner on every rank, in process.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

import faults
from rankcheck import command, on_rank0, one_error
from fricfem import load_scene, open_run, runner
from fricfem.output import directory
from fricfem.output.directory import LOCK_FILE, MANIFEST_FILE, RunDirError

RANK = MPI.COMM_WORLD.rank
COARSE = ["--set", "mesh.preset='coarse'", "--set", "output.fields=[]", "--set", "time.end=4e-6"]


# -- SIGKILL --------------------------------------------------------------------------------------

KILLED = ["case3", "--set", "time.end=16e-6", "--set", "output.interface_every=1e-7",
          "--set", "output.fields=[6e-6,10e-6,14e-6]"]


@pytest.mark.slow
def test_sigkill_at_random_points_leaves_readable_outputs(comm, tmp_dir_shared):
    """A 2-rank run killed (SIGKILL to mpirun and both ranks) at 3 events: its
    interface.h5 just laid out (before the loop's first flush), and two random
    row counts in the loop (read from the file; no wall-time fraction, so a
    loaded machine moves nothing).  Each time summary.json parses,
    interface.h5 opens and its rows are bit-identical to a complete run's first
    rows — at least as many as were seen and as summary.json says were
    flushed — every snapshot fields.xdmf lists reads and is identical, and
    ``fricfem plot`` draws the killed run."""
    def work():
        ref = tmp_dir_shared / "complete"
        faults.complete_run(KILLED, ref)
        full = len(open_run(ref).t)
        rng = random.Random(15)
        targets = [0] + sorted(rng.randint(1, int(0.8 * full)) for _ in range(2))
        return [faults.kill_at_rows(KILLED, tmp_dir_shared / f"killed{i}", ref, n, plot=(i == 1))
                for i, n in enumerate(targets)]

    kills = on_rank0(comm, work)
    for k in kills:
        assert k["problems"] == [], repr(k)
        assert not k["ended_before_kill"] and k["rows_seen"] is not None, repr(k)  # killed at its event, mid-run
        assert k["rows"] >= k["rows_seen"] >= k["kill_at_rows"], repr(k)
    assert all(k["rows"] > 0 for k in kills[1:])  # those kills landed in the loop


def test_a_row_with_a_finite_time_is_complete(comm, tmp_dir_shared):
    """The reader's rule on a file as a kill leaves it: rows laid out with NaN, the
    values of rows 0–4 written but only the times of rows 0–2 — 3 valid rows."""
    def work():
        from fricfem.output.rundir import InterfaceFile, valid_rows

        path = tmp_dir_shared / "interface.h5"
        with h5py.File(path, "w") as f:
            f["x1"] = np.linspace(0, 0.1, 4)
            f.create_dataset("time", data=np.full(8, np.nan))
            f.create_dataset("slip_rate", data=np.full((8, 4), np.nan))
            f["slip_rate"][:5] = 1.0
            f["time"][:3] = [0.0, 1e-7, 2e-7]
        with h5py.File(path, "r") as f:
            itf = InterfaceFile(f)
            return itf.n_time, itf.all("slip_rate").tolist(), valid_rows(np.array([0.0, 1.0, 0.5, 2.0]))

    n, rows, backwards = on_rank0(comm, work)
    assert n == 3 and np.all(np.array(rows) == 1.0) and backwards == 2


# -- a full file system ---------------------------------------------------------------------------

def _mpirun(argv, timeout=900):
    """(status, stderr) of ``mpirun -n 2 fricfem ARGV`` (the timeout only bounds a hang)."""
    res = subprocess.run(["mpirun", "-n", "2", str(faults.FRICFEM), *argv], capture_output=True, text=True,
                         env=faults.clean_env(), timeout=timeout)
    return res.returncode, res.stderr


@pytest.mark.slow
def test_a_full_file_system(comm, tiny_fs):
    """3 MB: the reference mesh's interface file (17 MB) is refused before the loop with
    one line naming it; on the coarse mesh the field snapshots fill the disk mid-run,
    the job ends non-zero naming the file, and what was flushed stays readable."""
    def work():
        big = _mpirun(["run", "case3", "--out", str(tiny_fs / "big"), "--quiet"])
        small = _mpirun(["run", "case3", "--out", str(tiny_fs / "small"), "--quiet", "--set", "mesh.preset='coarse'",
                         "--set", "output.fields=[5e-6,10e-6,15e-6,20e-6,25e-6,30e-6,35e-6,40e-6]"])
        from fricfem.output.rundir import FieldReader

        run = open_run(tiny_fs / "small")
        return big, small, len(run.t), len(FieldReader(tiny_fs / "small" / "fields.xdmf").times), \
            json.loads((tiny_fs / "small" / "summary.json").read_text())["steps"]

    big, small, rows, snaps, steps = on_rank0(comm, work)
    status, err = big
    errors = [ln for ln in err.splitlines() if ln.startswith("fricfem")]
    assert status == 2 and "Traceback" not in err
    assert errors == [errors[0]] and "interface.h5" in errors[0] and "No space left on device" in errors[0]
    status, err = small
    assert status != 0 and "Traceback" not in err
    line = next(ln for ln in err.splitlines() if ln.startswith("fricfem: error:"))
    assert "/fields/" in line and ".h5" in line and "the file system is full" in line
    assert rows >= (steps - 1) + 1 > 0 and 0 < snaps < 8  # coarse mesh: a row every step


# -- an error on one rank ---------------------------------------------------------------------------

ONE_RANK = """
import sys, time
from mpi4py import MPI
from fricfem import load_scene, runner
scene = load_scene("case1", ["mesh.preset='coarse'", "output.fields=[]", "time.end=30e-6"])
def on_step(state):
    if state.n == 20 and MPI.COMM_WORLD.rank == 1:
        open(sys.argv[2], "w").write(repr(time.time()))
        raise RuntimeError("a user monitor failed on rank 1")
runner.run_scene(scene, sys.argv[1], quiet=True, on_step=on_step)
"""


def test_an_error_on_one_rank_ends_the_job(comm, tmp_dir_shared):
    """An exception on rank 1 alone (a user's on_step at step 20) ends the 2-rank job
    non-zero, with its message: the job returns (rank 0 is not left waiting in a
    collective; the timeout only bounds a hang) and its interface.h5 opens with
    fewer rows than the run planned (the job ended at the error, not at the
    run's end).  No wall time is asserted."""
    def work():
        script = tmp_dir_shared / "one_rank.py"
        script.write_text(ONE_RANK)
        stamp = tmp_dir_shared / "raised_at"
        res = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script), str(tmp_dir_shared / "run"),
                              str(stamp)], capture_output=True, text=True, env=faults.clean_env(), timeout=900)
        with h5py.File(tmp_dir_shared / "run" / "interface.h5", "r") as f:
            planned = int(f.attrs["rows_planned"])
        return res.returncode, res.stderr, stamp.exists(), len(open_run(tmp_dir_shared / "run").t), planned

    status, err, raised, rows, planned = on_rank0(comm, work)
    assert status != 0 and raised
    assert "fricfem: error: rank 1 of 2: RuntimeError: a user monitor failed on rank 1" in err
    assert 0 <= rows < planned  # interface.h5 opens; the run stopped at the error


# -- two runs into one directory -------------------------------------------------------------------

def test_a_second_run_into_a_running_directory_fails_at_once(comm, tmp_dir_shared, capsys, monkeypatch):
    """While a run holds the directory's lock, another run (even with --overwrite) is
    refused at once naming it — before any heavy work: no mesh is built, no λmax
    computed (counted, not timed) — the first run's outputs are untouched.  A
    lock left by a killed run (its pid gone) is taken over."""
    from rankcheck import count_calls

    from fricfem.model import build as build_mod

    out = tmp_dir_shared / "busy"
    lock = on_rank0(comm, lambda: directory.prepare(out, overwrite=False))  # this process is "the running one"
    calls = count_calls(monkeypatch, {"mesh": (build_mod.mesh_mod, "build"), "eig": (build_mod, "max_eigenvalue")})
    line = one_error(capsys, ["run", "case1", *COARSE, "--out", str(out), "--overwrite"],
                     "another fricfem run is writing there", f"pid {os.getpid() if RANK == 0 else ''}")
    assert calls == {"mesh": 0, "eig": 0}
    if RANK == 0:
        assert LOCK_FILE in line
        lock.release()
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        info = json.loads((out / LOCK_FILE).read_text()) if (out / LOCK_FILE).exists() else dict(lock.info)
        (out / LOCK_FILE).write_text(json.dumps({**info, "pid": dead.pid, "start_ticks": None}))
    comm.barrier()
    summary = runner.run_scene(load_scene("case1", [a for a in COARSE if a != "--set"]), out, comm, quiet=True,
                               overwrite=True)
    assert summary["complete"]
    if RANK == 0:
        assert not (out / LOCK_FILE).exists()  # released at the end


@pytest.mark.slow
def test_two_concurrent_runs_into_one_directory(comm, tmp_dir_shared):
    """Two 2-rank jobs started together into one directory: one runs to completion,
    the other fails naming it; the directory holds one complete run.  The job that
    took the lock is paused (SIGSTOP to its tree) from the moment its lock is seen
    until the other has ended: on a loaded machine the other might otherwise reach
    the directory only after the first had finished, and rerun it (--overwrite)."""
    def work():
        out = tmp_dir_shared / "both"
        args = ["case1", "--set", "mesh.preset='coarse'", "--set", "output.fields=[]"]
        a = faults.start(args, out, log=tmp_dir_shared / "a.log")
        b = faults.start(args, out, log=tmp_dir_shared / "b.log")
        holder = faults.lock_holder(out, [a, b])
        try:
            if holder is not None:
                faults.signal_tree(holder.pid, signal.SIGSTOP)
                (b if holder is a else a).wait(timeout=900)  # bounds a hang only
        finally:
            if holder is not None:
                faults.signal_tree(holder.pid, signal.SIGCONT)
        ra, rb = a.wait(timeout=900), b.wait(timeout=900)  # bounds a hang only
        logs = [(tmp_dir_shared / f"{k}.log").read_text() for k in "ab"]
        return holder is not None, ra, rb, logs, json.loads((out / "summary.json").read_text())["complete"], \
            len(open_run(out).t)

    seen, ra, rb, logs, complete, rows = on_rank0(comm, work)
    assert seen, ("neither job was seen holding the lock", ra, rb, logs)
    assert sorted([ra, rb]) == [0, 2], logs
    loser = logs[[ra, rb].index(2)]
    assert "another fricfem run is writing there" in loser and "Traceback" not in loser
    assert complete and rows > 0


# -- confinement ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["../../x", "/tmp/abs", "a/b", ".."])
def test_a_scene_name_cannot_leave_runs(capsys, comm, tmp_dir_shared, name, monkeypatch):
    """A name that is a path is refused before anything is written; nothing appears outside."""
    monkeypatch.chdir(tmp_dir_shared)
    one_error(capsys, ["run", "case1", *COARSE, "--set", f"name={name!r}"], "name")
    comm.barrier()
    assert not (tmp_dir_shared / "runs").exists() and not Path("/tmp/abs").exists()


def test_default_run_directory_is_runs_name_under_cwd(comm, tmp_dir_shared, monkeypatch):
    monkeypatch.chdir(tmp_dir_shared)
    summary = runner.resolve_and_run("case1", [a for a in COARSE if a != "--set"] + ["name='mine'"], quiet=True,
                                     comm=comm)
    assert summary["complete"] and (tmp_dir_shared / "runs" / "mine" / "interface.h5").is_file()


def test_out_through_a_symlink_is_refused(capsys, comm, tmp_dir_shared):
    """--out that is a symbolic link (to a directory, or dangling) is refused; nothing is
    written where it points."""
    target, link, dangling = tmp_dir_shared / "target", tmp_dir_shared / "link", tmp_dir_shared / "dangling"
    on_rank0(comm, lambda: (target.mkdir(), link.symlink_to(target), dangling.symlink_to(tmp_dir_shared / "no"))
             and None)
    one_error(capsys, ["run", "case1", *COARSE, "--out", str(link)], "is a symbolic link", str(link))
    one_error(capsys, ["run", "case1", *COARSE, "--out", str(dangling)], "is a symbolic link")
    comm.barrier()
    assert list(target.iterdir()) == [] and not (tmp_dir_shared / "no").exists()


def test_overwrite_removes_only_what_fricfem_wrote(comm, tmp_dir_shared):
    """--overwrite keeps a user's file and a user's folder in the run directory, and
    removes a symbolic link fricfem's name was replaced by without touching its target."""
    out, outside = tmp_dir_shared / "mine", tmp_dir_shared / "precious.txt"
    scene = load_scene("case1", [a for a in COARSE if a != "--set"])
    runner.run_scene(scene, out, comm, quiet=True)

    def tamper():
        (out / "notes.txt").write_text("mine")
        (out / "analysis").mkdir()
        (out / "analysis" / "a.png").write_text("x")
        outside.write_text("keep me")
        (out / "summary.json").unlink()
        (out / "summary.json").symlink_to(outside)

    on_rank0(comm, tamper)
    runner.run_scene(scene, out, comm, quiet=True, overwrite=True)
    if RANK == 0:
        assert (out / "notes.txt").read_text() == "mine" and (out / "analysis" / "a.png").exists()
        assert outside.read_text() == "keep me" and not (out / "summary.json").is_symlink()
        assert json.loads((out / "summary.json").read_text())["complete"]
        assert "interface.h5" in json.loads((out / MANIFEST_FILE).read_text())["files"]


# -- file-system and command-line errors: one line each (issue 10, item 8) -----------------------------

def test_out_under_a_regular_file(capsys, comm, tmp_dir_shared):
    on_rank0(comm, lambda: (tmp_dir_shared / "file").write_text("x") and None)
    one_error(capsys, ["run", "case1", *COARSE, "--out", str(tmp_dir_shared / "file" / "run")],
              "a parent is not a directory", "file/run")


def test_out_name_too_long(capsys, tmp_dir_shared):
    one_error(capsys, ["run", "case1", *COARSE, "--out", str(tmp_dir_shared / ("x" * 300))], "File name too long")


def test_out_on_a_read_only_file_system(capsys, comm, tmp_dir_shared):
    ro = tmp_dir_shared / "ro"

    def mount():
        ro.mkdir()
        return subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)],
                              capture_output=True).returncode == 0

    if not on_rank0(comm, mount):
        pytest.skip("cannot mount a read-only tmpfs here (not root?)")
    try:
        one_error(capsys, ["run", "case1", *COARSE, "--out", str(ro / "run")], "Read-only file system", "ro/run")
    finally:
        on_rank0(comm, lambda: subprocess.run(["umount", "-l", str(ro)]) and None)


def test_interface_h5_that_is_a_directory(capsys, comm, tmp_dir_shared):
    """A directory where fricfem writes interface.h5 is refused (even with --overwrite)."""
    out = tmp_dir_shared / "occupied"
    on_rank0(comm, lambda: (out / "interface.h5").mkdir(parents=True))
    one_error(capsys, ["run", "case1", *COARSE, "--out", str(out), "--overwrite"], "interface.h5",
              "not written by fricfem")


def test_plot_of_a_corrupt_interface_file(capsys, comm, tmp_dir_shared):
    out = tmp_dir_shared / "corrupt"

    def corrupt():
        out.mkdir()
        (out / "interface.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + os.urandom(2000))

    on_rank0(comm, corrupt)
    status, err = command(capsys, ["plot", str(out)])
    assert status == (2 if RANK == 0 else 0)
    if RANK == 0:
        assert len(err) == 1 and "interface.h5: not readable" in err[0], err


def test_stale_lock_detection(tmp_path):
    """A lock is stale when its pid is gone or belongs to another process; a live one
    (this process) is not; another host's cannot be judged and is kept."""
    out = tmp_path / "d"
    lock = directory.prepare(out, overwrite=False)
    assert directory._alive(lock.info)
    assert not directory._alive({**lock.info, "start_ticks": -1})  # the pid reused by another process
    with pytest.raises(RunDirError, match="another fricfem run is writing there"):
        directory.prepare(out, overwrite=True)
    assert directory._alive({**lock.info, "host": "elsewhere", "pid": 1})
    lock.release()
    assert not (out / LOCK_FILE).exists()
