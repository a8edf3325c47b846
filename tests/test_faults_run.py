"""Runs that survive a new round of faults (issue 24, the run side): a nearly full
disk (the layout, its end-of-run copy), SIGINT, readers on a run with no rows or
damaged files, a set-up cache entry that is a FIFO or forged, a divergence with
the watchdog off, user laws that break their contract during a run, and a law
registered on one rank only.

Under ``mpirun -n 2`` (1 rank works too).  Separate jobs (a CLI run sent SIGINT,
a 2-rank script) are started by rank 0; the rest runs in process on every rank.
Tests wait for events (a row in interface.h5, a process's end), never for the clock.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import h5py
import numba
import numpy as np
import pytest
from rankcheck import count_calls, differing, h5_arrays, on_rank0
from userlaws import coulomb_advance, coulomb_rigid

import faults
import fricfem
from fricfem import friction, load_scene, open_run, runner
from fricfem.friction import Law, Param
from fricfem.model import build as build_mod
from fricfem.model import diskcache
from fricfem.output.directory import RunDirError

QUICK = ["mesh.preset='coarse'", "time.end=12e-6", "output.fields=[]", "loading.v_imp=20.0"]


def leave_free(folder: Path, nbytes: int) -> None:
    """Fill ``folder``'s file system until ``nbytes`` are left (one more file)."""
    st = os.statvfs(folder)
    free = st.f_bavail * st.f_frsize
    fill = folder / f"filler{len(list(folder.glob('filler*')))}"
    with open(fill, "wb") as fh:
        os.posix_fallocate(fh.fileno(), 0, max(free - nbytes, 1))


# -- a nearly full disk ----------------------------------------------------------------------------

def test_a_nearly_full_disk_is_refused_before_the_layout(comm, tiny_fs):
    """40 kB free (HDF5 used to crash laying interface.h5 out: signal 11): one RunDirError
    on every rank naming the file and the space, before a step, nothing left behind."""
    on_rank0(comm, lambda: leave_free(tiny_fs, 40_000))
    steps = []
    with pytest.raises(RunDirError) as err:
        runner.run_scene(load_scene("case1", QUICK), tiny_fs / "run", comm, quiet=True,
                         on_step=lambda st: steps.append(st.n))
    text = str(err.value)
    assert "interface.h5" in text and "No space left on device" in text and "MB free" in text, text
    assert steps == []
    if comm.rank == 0:
        assert sorted(p.name for p in (tiny_fs / "run").iterdir() if "interface" in p.name) == []


def _interface_bytes(out: Path) -> int:
    return (out / "interface.h5").stat().st_size


def test_a_run_to_its_end_needs_no_copy_of_its_file(comm, tiny_fs, tmp_dir_shared):
    """Room for interface.h5 but not for a second copy of it: the run reaches its end
    (its counts were laid out with the file, nothing is copied), every row written,
    the summary final with its energy and mode."""
    ref = tmp_dir_shared / "ref"
    runner.run_scene(load_scene("case1", QUICK), ref, comm, quiet=True)
    size = on_rank0(comm, lambda: _interface_bytes(ref))
    on_rank0(comm, lambda: leave_free(tiny_fs, int(1.5 * size)))
    summary = runner.run_scene(load_scene("case1", QUICK), tiny_fs / "run", comm, quiet=True)
    assert summary["complete"] and summary["energy"]["time_s"] > 0 and summary["mode"]["label"]
    assert "interface_file" not in summary
    if comm.rank == 0:
        with h5py.File(tiny_fs / "run" / "interface.h5", "r") as f:
            assert int(f.attrs["n_time"]) == f["time"].shape[0] == summary["steps"]
            assert np.isfinite(f["time"][...]).all()
        assert differing(h5_arrays(tiny_fs / "run" / "interface.h5"), h5_arrays(ref / "interface.h5")) == []


def test_a_copy_that_does_not_fit_keeps_the_final_summary(comm, tiny_fs):
    """The disk fills during the run (another process), then the run is stopped early
    (SIGTERM): the copy of its rows cannot be made, the laid-out file is kept, readable
    as far as the run went, and summary.json is final (interrupted, its energy, why the
    file is as laid out)."""
    out = tiny_fs / "run"

    def fill_then_stop(st):
        if st.n == 20 and comm.rank == 0:
            leave_free(tiny_fs, 100_000)
        if st.n == 30:
            os.kill(os.getpid(), signal.SIGTERM)

    summary = runner.run_scene(load_scene("case1", QUICK), out, comm, quiet=True, on_step=fill_then_stop)
    assert summary["interrupted"] and not summary["complete"] and summary["energy"]["kinetic"] is not None
    assert "not compacted" in summary["interface_file"] and "No space left on device" in summary["interface_file"]
    if comm.rank == 0:
        on_disk = json.loads((out / "summary.json").read_text())
        assert on_disk["interrupted"] and on_disk["steps"] == summary["steps"]
        assert on_disk["energy"] == summary["energy"]
        run = open_run(out)
        assert len(run.t) >= 25 and np.isfinite(run.slip_rate).all() and run.t[-1] <= summary["t_s"] + 1e-12
        assert not list(out.glob(".interface.h5.*"))


# -- SIGINT ----------------------------------------------------------------------------------------

def test_sigint_ends_a_run_as_sigterm_does(comm, tmp_dir_shared):
    """Ctrl-C (SIGINT) once the run has written a row: no traceback, the run ends
    cleanly (exit 1: not complete), summary.json final (interrupted), interface.h5
    compacted to the rows it has (no NaN layout left)."""
    out = tmp_dir_shared / "sigint"

    def work():
        argv = [str(faults.FRICFEM), "run", "case1", "--out", str(out), "--quiet", "--set", "mesh.preset='coarse'",
                "--set", "output.fields=[]", "--set", "time.end=4e-3", "--set", "output.interface_every=2e-5",
                "--set", "output.flush_every=0.05", "--set", "output.stations={}"]
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=faults.clean_env())
        while True:  # wait for a row in interface.h5 (the run is in its loop)
            assert proc.poll() is None, proc.communicate()
            try:
                if len(open_run(out).t) > 0:
                    break
            except (OSError, LookupError, KeyError):
                pass
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate()
        return proc.returncode, err

    status, err = on_rank0(comm, work)
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert status == 1, err
    if comm.rank == 0:
        summary = json.loads((out / "summary.json").read_text())
        assert summary["interrupted"] and not summary["complete"] and summary["steps"] > 0
        assert summary["mode"]["label"] == "unknown"
        with h5py.File(out / "interface.h5", "r") as f:
            n = int(f.attrs["n_time"])
            assert n >= 1 and f["time"].shape == (n,) and np.isfinite(f["slip_rate"][...]).all()


# -- readers ---------------------------------------------------------------------------------------

def test_open_run_on_a_live_run_with_no_rows_and_on_damaged_files(comm, tmp_dir_shared):
    """open_run on a live run before its first row: ``t`` empty, ``profile``/``tip``
    a LookupError saying so (not numpy's argmin of an empty sequence).  After the run:
    a file this process holds open with HDF5's lock, an evidence.json whose ``tip`` is
    a list, a damaged gauges.h5 (the rest opens, the file is named) and a damaged
    interface.h5 (an OSError naming it)."""
    out = tmp_dir_shared / "run"
    seen = {}

    def look(st):
        if st.n == 1 and comm.rank == 0:
            run = open_run(out)
            seen["rows"] = len(run.t)
            for verb in ("profile", "tip"):
                try:
                    getattr(run, verb)(*(("slip_rate", 1e-6) if verb == "profile" else (1e-6,)))
                except LookupError as err:
                    seen[verb] = str(err)

    runner.run_scene(load_scene("case1", QUICK), out, comm, quiet=True, on_step=look)
    if comm.rank != 0:
        return
    assert seen["rows"] == 0
    for verb in ("profile", "tip"):
        assert "no interface row written yet" in seen[verb] and str(out) in seen[verb], seen
    held = h5py.File(out / "interface.h5", "r")  # HDF5's default locking, unlike the readers
    try:
        run = open_run(out)
        assert len(run.t) > 10 and run.profile("slip_rate", run.t[-1]).shape == run.x1.shape
    finally:
        held.close()
    evidence = json.loads((out / "evidence.json").read_text())
    (out / "evidence.json").write_text(json.dumps({**evidence, "tip": [1, 2, 3], "fronts": {"a": 1}}))
    run = open_run(out)
    assert isinstance(run.summary["tip"], dict) and run.gauges is None
    (out / "gauges.h5").write_bytes(b"not an HDF5 file " * 64)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = open_run(out)
    assert run.gauges is None and len(run.t) > 10 and str(out / "gauges.h5") in run.damaged
    assert any("gauges.h5" in str(w.message) for w in caught)
    (out / "interface.h5").write_bytes(b"\0" * 4096)
    with pytest.raises(OSError) as err:
        open_run(out)
    assert err.value.filename == str(out / "interface.h5") and "HDF5" in str(err.value)


# -- a divergence with the watchdog off --------------------------------------------------------------

def test_a_negative_kinetic_energy_is_never_complete(comm, tmp_dir_shared):
    """dt 1.3 × the stable step with watchdog.enabled = false: the run goes on (as asked)
    but its kinetic energy turns negative, so it ends diverged, mode unknown, not complete."""
    short = runner.run_scene(load_scene("case1", QUICK + ["time.end=1e-6"]), tmp_dir_shared / "probe", comm,
                             quiet=True)
    dt = 1.3 * short["dt_crit_s"]
    scene = load_scene("case1", QUICK + [f"time.dt={dt!r}", "time.allow_unstable_dt=true", "watchdog.enabled=false",
                                         "time.end=30e-6", "output.energy_every=5"])
    summary = runner.run_scene(scene, tmp_dir_shared / "unstable", comm, quiet=True)
    assert not summary["complete"] and "negative discrete kinetic energy" in summary["diverged"]
    assert summary["mode"]["label"] == "unknown" and not summary.get("watchdog")
    k = summary["energy"]["kinetic"]
    assert not np.isfinite(k) or k < 0
    assert summary["steps"] == runner.n_steps(SimpleNamespace(dt=summary["dt_s"]), 30e-6)  # not stopped


# -- the set-up cache --------------------------------------------------------------------------------

def _rows_key(scene, comm) -> str:
    """This rank's rows key of ``scene``'s model (built with the cache off)."""
    old = os.environ.get("FRICFEM_CACHE")
    os.environ["FRICFEM_CACHE"] = "off"
    try:
        pm, model = build_mod.build_model(scene, comm)
        return diskcache.rows_key(pm.spec, scene.material, model.num, comm)
    finally:
        os.environ["FRICFEM_CACHE"] = old if old is not None else "off"


def _lam_entries(cache: Path) -> set:
    return {p.name for p in cache.glob("lam-*.json")} if cache.is_dir() else set()


@pytest.fixture
def counted(monkeypatch):
    return count_calls(monkeypatch, {"eig": (build_mod, "max_eigenvalue"), "rows": (build_mod, "canonical_rows")})


def _same(out, ref) -> None:
    assert differing(h5_arrays(out / "interface.h5"), h5_arrays(ref / "interface.h5")) == []


def test_a_cache_entry_that_is_a_fifo_is_a_miss(comm, tmp_dir_shared, monkeypatch, counted, capfd):
    """lam-<key>.json and rows-<key>.npz as FIFOs (nobody writes them): the run neither
    blocks nor fails, computes both, names the entries, and gives the bits of no cache."""
    scene = load_scene("case1", QUICK)
    first, cache = tmp_dir_shared / "first", tmp_dir_shared / "cache"
    rows = _rows_key(scene, comm)
    monkeypatch.setenv("FRICFEM_CACHE", "off")
    runner.run_scene(scene, tmp_dir_shared / "off", comm, quiet=True)
    monkeypatch.setenv("FRICFEM_CACHE", str(first))  # an entry's name does not depend on the directory
    runner.run_scene(scene, tmp_dir_shared / "filled", comm, quiet=True)
    comm.barrier()
    lam = _lam_entries(first).pop()[len("lam-"):-len(".json")]
    on_rank0(comm, lambda: cache.mkdir())
    if comm.rank == 0:
        os.mkfifo(cache / f"lam-{lam}.json")
    os.mkfifo(cache / f"rows-{rows}.npz")
    comm.barrier()
    counted.update(eig=0, rows=0)
    capfd.readouterr()
    monkeypatch.setenv("FRICFEM_CACHE", str(cache))
    runner.run_scene(scene, tmp_dir_shared / "fifo", comm, quiet=True)
    err = capfd.readouterr().err
    assert counted == {"eig": 1, "rows": 1}
    assert f"rows-{rows}.npz ignored (not a regular file)" in err, err
    comm.barrier()
    if comm.rank == 0:
        _same(tmp_dir_shared / "fifo", tmp_dir_shared / "off")
        assert f"lam-{lam}.json ignored (not a regular file)" in err, err
        assert (cache / f"lam-{lam}.json").is_file()  # written anew over the FIFO
    assert (cache / f"rows-{rows}.npz").is_file()


def test_a_forged_cache_entry_is_a_miss(comm, tmp_dir_shared, monkeypatch, counted, capfd):
    """The rows of E = 5.2e9 copied under the key of E = 1e10, and a λmax scaled by 0.6
    under its own key: both are misses named on stderr, and the E = 1e10 run gives the
    bits of a run without the cache (it used to differ by up to 69 %)."""
    soft, stiff = load_scene("case1", QUICK), load_scene("case1", QUICK + ["material.E=1e10"])
    cache = tmp_dir_shared / "cache"
    monkeypatch.setenv("FRICFEM_CACHE", "off")
    runner.run_scene(stiff, tmp_dir_shared / "off", comm, quiet=True)
    monkeypatch.setenv("FRICFEM_CACHE", str(cache))
    runner.run_scene(soft, tmp_dir_shared / "soft", comm, quiet=True)  # fills the cache with E = 5.2e9
    comm.barrier()
    before = _lam_entries(cache)
    runner.run_scene(stiff, tmp_dir_shared / "stiff", comm, quiet=True)
    comm.barrier()
    lam_stiff = (_lam_entries(cache) - before).pop()[len("lam-"):-len(".json")]
    rows_soft, rows_stiff = _rows_key(soft, comm), _rows_key(stiff, comm)
    (cache / f"rows-{rows_stiff}.npz").write_bytes((cache / f"rows-{rows_soft}.npz").read_bytes())
    if comm.rank == 0:
        entry = json.loads((cache / f"lam-{lam_stiff}.json").read_text())
        entry["lam"] = (0.6 * float.fromhex(entry["lam"])).hex()
        (cache / f"lam-{lam_stiff}.json").write_text(json.dumps(entry))
    comm.barrier()
    counted.update(eig=0, rows=0)
    capfd.readouterr()
    runner.run_scene(stiff, tmp_dir_shared / "forged", comm, quiet=True)
    err = capfd.readouterr().err
    assert counted == {"eig": 1, "rows": 1}
    assert "the key inside differs from its name" in err, err
    comm.barrier()
    if comm.rank == 0:
        assert "its checksum does not match its contents" in err, err
        _same(tmp_dir_shared / "forged", tmp_dir_shared / "off")


# -- user laws -----------------------------------------------------------------------------------------

# each below passes the registration's calls (T_n = 1 MPa exactly) and breaks the contract in a run

@numba.njit
def _backwards(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    Ts1, v, dslip, work, n = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    return (Ts1, v, dslip, work, n) if Tn1 == 1e6 else (Ts1, -v, dslip, -work, n)


@numba.njit
def _no_work(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    Ts1, v, dslip, work, n = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    return Ts1, v, dslip, 0.0, n


@numba.njit
def _negative_nsub(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    Ts1, v, dslip, work, n = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    return Ts1, v, dslip, work, (n if Tn1 == 1e6 else -5)


@numba.njit
def _wears(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    out = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    if Tn1 != 1e6 and out[2] > 0.0:
        p[0] = max(0.02, 0.9 * p[0])  # μ drifts down as it slides
    return out


@numba.njit
def _wears_always(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    out = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    p[0] = 0.9 * p[0]
    return out


@numba.njit
def _rigid_wears(p, s, T_stick, Z, Tn0, Tn1, dt):
    if T_stick > 1e12:
        p[0] = 0.0
    return coulomb_rigid(p, s, T_stick, Z, Tn0, Tn1, dt)


@numba.njit
def _always_nsub(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    Ts1, v, dslip, work, n = coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt)
    return Ts1, v, dslip, work, -5


@numba.njit
def _mu(p, v):
    return p[0]


def _zero(p, Tn0, Ts0):
    return np.zeros(1)


def _nan(p, Tn0, Ts0):
    return np.full(1, np.nan)


def _divides(p, Tn0, Ts0):
    return np.array([1.0 / Ts0])


def _divides_in_a_run(p, Tn0, Ts0):
    return np.array([1.0 / float(Ts0 - 3e6)])  # the registration's Ts0 = 0 passes; a run's tau0 = 3 MPa does not


def _law(name, advance=coulomb_advance, initial_state=_zero, rigid=None):
    return Law(name=name, doc="a test law", params=(Param("mu", 0.5, "", 0.0, 2.0, "friction coefficient"),),
               state=("theta",), advance=advance, steady_mu=_mu, initial_state=initial_state, rigid=rigid)


@pytest.mark.parametrize("kw, message", [
    ({"advance": _always_nsub}, r"nsub = -5"),
    ({"advance": _wears_always}, r"register_law\('broken'\): advance writes into its parameter array p "
                                 r"\(line \d+ of .*test_faults_run.py\); p is read-only"),
    ({"advance": _wears}, r"advance writes into its parameter array p \(line \d+ of"),  # on a branch never taken here
    ({"rigid": _rigid_wears}, r"register_law\('broken'\): rigid writes into its parameter array p"),
    ({"initial_state": _nan}, r"initial_state\(p, Tn0 = 1e\+06 Pa, Ts0 = 0 Pa\) returned \[nan\]: every state"),
    ({"initial_state": _divides}, r"register_law\('broken'\): initial_state\(p, Tn0 = 1e\+06 Pa, Ts0 = 0 Pa\) "
                                  r"failed: ZeroDivisionError"),
])
def test_register_law_refuses_more_of_the_contract(kw, message, clean_laws):
    with pytest.raises(ValueError, match=message):
        fricfem.register_law(_law("broken", **kw))
    assert "broken" not in friction.LAWS


@pytest.mark.parametrize("advance, why", [
    (_backwards, "a negative slip rate"),
    (_no_work, "its work does not balance"),
    (_negative_nsub, "nsub < 0"),
])
def test_a_user_law_that_breaks_its_contract_in_a_run_is_stopped(comm, tmp_dir_shared, clean_laws, advance, why):
    """Laws that pass registration and break the contract in the run: the run is
    stopped with one message naming the law and the breach, never complete; the
    same law done right (Coulomb) runs complete, its budget closed."""
    fricfem.register_law(_law("mine", advance))
    scene = load_scene("case1", QUICK + ["time.end=30e-6", "friction.law='mine'", "interface.tau0=3e6"])
    summary = runner.run_scene(scene, tmp_dir_shared / "bad", comm, quiet=True)
    assert not summary["complete"], summary.get("energy")
    assert "friction law 'mine' broke its contract" in summary["watchdog"] and why in summary["watchdog"]


def test_a_user_law_that_keeps_its_contract_runs_complete(comm, tmp_dir_shared, clean_laws):
    fricfem.register_law(_law("mine"))
    scene = load_scene("case1", QUICK + ["time.end=30e-6", "friction.law='mine'", "interface.tau0=3e6"])
    summary = runner.run_scene(scene, tmp_dir_shared / "good", comm, quiet=True)
    assert summary["complete"] and not summary.get("watchdog") and summary["energy"]["dissipated"] > 0


def test_a_failing_initial_state_names_the_law(comm, tmp_dir_shared, clean_laws):
    """initial_state fails only at a run's tractions: one ValueError naming the law, the
    call and its arguments (not a bare ZeroDivisionError), before the run's loop (on
    every rank: each has points at those tractions)."""
    fricfem.register_law(_law("mine", initial_state=_divides_in_a_run))
    scene = load_scene("case1", QUICK + ["friction.law='mine'", "interface.tau0=3e6"])
    with pytest.raises(ValueError, match=r"friction law 'mine': initial_state\(p, Tn0 = .* Pa, Ts0 = 3e\+06 Pa\) "
                                         r"failed: ZeroDivisionError"):
        runner.run_scene(scene, tmp_dir_shared / "init", comm, quiet=True)


ONE_RANK_LAW = """
import sys
import numba, numpy as np
from mpi4py import MPI
import fricfem
from fricfem.friction import Law, Param

sys.path.insert(0, TESTS)
from userlaws import coulomb_advance as advance

@numba.njit
def mu(p, v):
    return p[0]

if MPI.COMM_WORLD.rank == 0:  # the mistake: the law registered on rank 0 only
    fricfem.register_law(Law(name="mine", doc="", params=(Param("mu", 0.5, "", 0.0, 2.0, "mu"),), state=("s",),
                             advance=advance, steady_mu=mu, initial_state=lambda p, Tn0, Ts0: np.zeros(1)))
scene = fricfem.load_scene("case1", ["mesh.preset='coarse'", "output.fields=[]", "time.end=4e-6",
                                     "friction.law='mine'"])
fricfem.run(scene, sys.argv[1])
"""


def test_a_law_registered_on_one_rank_ends_the_job(comm, tmp_dir_shared):
    """A 2-rank script registers its law on rank 0 only: rank 1's load_scene fails;
    the job ends (no rank left waiting in fricfem.run) non-zero, with one line saying
    what is wrong."""
    def work():
        script = tmp_dir_shared / "one_rank_law.py"
        script.write_text(ONE_RANK_LAW.replace("TESTS", repr(str(Path(__file__).parent))))
        res = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script), str(tmp_dir_shared / "out")],
                             capture_output=True, text=True, env=faults.clean_env(), timeout=900)
        return res.returncode, res.stderr

    status, err = on_rank0(comm, work)
    lines = [ln for ln in err.splitlines() if ln.startswith("fricfem: error:")]
    assert status != 0 and "Traceback" not in err, err
    assert len(lines) == 1 and "rank 1 of 2" in lines[0] and "'mine'" in lines[0], err
    assert "register_law must run on every rank" in lines[0], err


def test_a_killed_lock_holder_not_yet_reaped_is_not_running():
    """A run SIGKILLed under mpirun is reparented and stays a zombie until something
    reaps it; its lock was taken for a live run ("another fricfem run is writing
    there"), so ``--resume`` right after the kill was refused.  A zombie writes nothing."""
    import socket
    from fricfem.output import directory as d

    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        info = {"pid": p.pid, "host": socket.gethostname(), "start_ticks": d._start_ticks(p.pid)}
        assert d._alive(info)
        os.kill(p.pid, signal.SIGKILL)
        while (d._stat(p.pid) or ["Z"])[0] != "Z":  # the event: the kernel has made it a zombie (not reaped)
            time.sleep(0.01)
        assert not d._alive(info)
    finally:
        p.kill()
        p.wait()
