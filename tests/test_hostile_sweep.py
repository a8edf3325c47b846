"""Hostile input to ``fricfem sweep``, ``fricfem plot`` and the scene checks (issue 24, §2): each
test makes the fault happen — a damaged job.json, directories where the sweep writes files, a
read-only --out, an endless --label, one rank's failure under 2 ranks, two sweeps into one
directory, a run with more snapshots than figures are drawn, unit slips, an experiment scene
given keys it does not use, a closed stdout.

Run under ``mpirun -n 2`` (1 rank works too): the in-process sweeps run on every rank; the
separate jobs (a second ``mpirun``, a pipe) are started by rank 0 with a bounded wait, so a hang
fails the test instead of hanging the suite.
"""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rankcheck import on_rank0

import faults
from fricfem import cli, load_scene, sweep
from fricfem.output.directory import LOCK_FILE
from fricfem.scene import SceneError, cost

QUICK = ["--preset", "coarse", "--set", "time.end=15e-6", "--quiet"]
#: upper bound on any separate job (a hang fails the test; a normal one ends in seconds)
JOB_TIMEOUT = 300


def _fricfem(*argv) -> list:
    return [sys.executable, "-m", "fricfem.cli", *argv]


def _errors(text: str) -> list:
    return [line for line in text.splitlines() if line.startswith("fricfem sweep: error: ")]


def _lock_written(path: Path) -> bool:
    """The lock file is there with its holder written in it."""
    try:
        return isinstance(json.loads(path.read_text()), dict)
    except (OSError, ValueError):
        return False


def _computed(out: Path) -> list:
    """The points with a finished run under ``out``."""
    pts = out / "points"
    return sorted(d.name for d in pts.iterdir() if (d / "summary.json").is_file()) if pts.is_dir() else []


# --------------------------------------------------------------------------- crashes


def test_a_job_json_that_is_not_a_table_reruns_its_point(tmp_dir_shared, comm):
    """job.json holding [] (or a number) made the planning raise AttributeError: now the point's record
    counts as damaged and the point runs again.  Rank 0 alone reads the files back: a rank still reading
    job.json while rank 0 damages it for the next round read it half written."""
    out = tmp_dir_shared / "map"
    argv = ["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out)]
    assert sweep.main(argv) == 0
    comm.barrier()
    for damaged in ("[]", "3"):
        on_rank0(comm, lambda: (out / "points" / "s6_v2" / "job.json").write_text(damaged))
        assert sweep.main(argv) == 0
        comm.barrier()
        doc, record = on_rank0(comm, lambda: (json.loads((out / "modemap.json").read_text()),
                                              json.loads((out / "points" / "s6_v2" / "job.json").read_text())))
        assert doc["computed"] == ["s6_v2"] and doc["incomplete"] == []
        assert isinstance(record, dict)


@pytest.mark.parametrize("where, variants", [("modemap.json", False), ("modemap.png", False),
                                             ("sweep.log", False), ("modemap.json.tmp", False),
                                             ("stiff_x10/modemap.json", True), ("modemap_variants.png", True)])
def test_a_directory_where_the_sweep_writes_a_file_is_refused_before_any_point(tmp_dir_shared, comm, capsys,
                                                                               where, variants):
    """Before: every point was computed, then writing the map raised IsADirectoryError (a traceback)."""
    out = tmp_dir_shared / "map"
    on_rank0(comm, lambda: (out / where).mkdir(parents=True))
    argv = ["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out)] + (["--variants"] if variants else [])
    assert sweep.main(argv) == 2
    comm.barrier()
    assert _computed(out) == []  # nothing ran
    assert not (out / LOCK_FILE).exists()  # the lock is released
    if comm.rank == 0:
        err = capsys.readouterr().err
        assert _errors(err) == [err.strip()], err
        assert f"{str(out / where)!r}: is a directory" in err


def test_sweep_log_a_directory_under_two_ranks_ends_every_rank(tmp_path_factory, comm):
    """Before: rank 0 raised on sweep.log, rank 1 waited forever in a collective."""
    def run():
        out = tmp_path_factory.mktemp("hang") / "map"
        (out / "sweep.log").mkdir(parents=True)
        res = subprocess.run(["mpirun", "-n", "2", "--oversubscribe",
                              *_fricfem("sweep", "case1", "--sigma0", "6,30", "--v-imp", "2", *QUICK, "--out",
                                        str(out))],
                             capture_output=True, text=True, env=faults.clean_env(), timeout=JOB_TIMEOUT)
        return res.returncode, res.stderr, _computed(out)

    rc, err, computed = on_rank0(comm, run)
    assert rc == 2, err
    assert "Traceback" not in err
    assert len(_errors(err)) == 1 and "sweep.log" in _errors(err)[0] and "is a directory" in err
    assert computed == []


@pytest.fixture
def read_only(tmp_dir_shared, comm):
    """A small tmpfs holding an empty folder ``made``, remounted read-only (root only); unmounted after."""
    mnt = tmp_dir_shared / "ro"

    def mount():
        mnt.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)], capture_output=True).returncode:
            return False
        (mnt / "made").mkdir()
        return subprocess.run(["mount", "-o", "remount,ro", str(mnt)], capture_output=True).returncode == 0

    if not on_rank0(comm, mount):
        pytest.skip("cannot mount a read-only tmpfs here (not root?)")
    yield mnt
    on_rank0(comm, lambda: subprocess.run(["umount", "-l", str(mnt)], capture_output=True) and None)


@pytest.mark.parametrize("sub", ["new/map", "made"])
def test_out_on_a_read_only_file_system_is_one_line(read_only, comm, capsys, sub):
    out = read_only / sub
    assert sweep.main(["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out)]) == 2
    comm.barrier()
    if comm.rank == 0:
        err = capsys.readouterr().err
        assert _errors(err) == [err.strip()], err
        assert f"--out {str(out)!r}" in err and "Read-only file system" in err


@pytest.mark.parametrize("label, message", [("x" * 20_000, "--label: 20000 characters; at most 200"),
                                            (r"Σ0 map $\frac{1}{$", "is not valid mathtext"),
                                            ("map\x07bell", "control characters (U+0007)")])
def test_a_label_the_figure_cannot_draw_is_refused_before_any_point(tmp_dir_shared, comm, capsys, label, message):
    """Before: a 20,000-character label overflowed the glyph raster after every point finished."""
    out = tmp_dir_shared / "map"
    assert sweep.main(["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out), "--label", label]) == 2
    comm.barrier()
    assert not out.exists()
    if comm.rank == 0:
        err = capsys.readouterr().err
        assert _errors(err) == [err.strip()] and message in err, err


def test_a_long_label_within_the_limit_is_drawn(tmp_dir_shared, comm):
    out = tmp_dir_shared / "map"
    label = "Σ0 × V_imp, $\\mu_s = 0.5$ " + "y" * 170
    assert len(label) <= 200
    assert sweep.main(["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out), "--label", label]) == 0
    comm.barrier()
    assert json.loads((out / "modemap.json").read_text())["title"] == label
    assert (out / "modemap.png").stat().st_size > 0


# --------------------------------------------------------------------------- accepted wrongly


def test_a_second_sweep_into_a_running_sweeps_directory_stops_at_once(tmp_dir_shared, comm, capsys):
    """Before: both sweeps ran every point and overwrote each other's finished points.  The first
    sweep (a separate process) is paused while it holds the directory; the second must stop at
    once naming it, and the first then finishes every point alone."""
    out = tmp_dir_shared / "map"
    argv = ["case1", "--sigma0", "6,30", "--v-imp", "2,20", *QUICK, "--out", str(out)]

    proc = None

    def start():
        nonlocal proc
        proc = subprocess.Popen(_fricfem("sweep", *argv), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, env=faults.clean_env())
        deadline = time.monotonic() + JOB_TIMEOUT  # a bound on the wait for the event, not a timing
        while not _lock_written(out / LOCK_FILE):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the first sweep never took its lock"
            time.sleep(0.05)
        proc.send_signal(signal.SIGSTOP)
        return proc.pid

    def finish():
        if proc is None:
            return None, ""
        proc.send_signal(signal.SIGCONT)
        _, err = proc.communicate(timeout=JOB_TIMEOUT)
        return proc.returncode, err

    try:
        pid = on_rank0(comm, start)
        before = on_rank0(comm, lambda: _computed(out))
        assert sweep.main(argv) == 2
        comm.barrier()
        assert on_rank0(comm, lambda: _computed(out)) == before  # the second sweep ran nothing
        if comm.rank == 0:
            err = capsys.readouterr().err
            assert _errors(err) == [err.strip()], err
            assert "another fricfem run is writing there" in err and f"pid {pid}" in err
    finally:
        rc, err = on_rank0(comm, finish)
    assert rc == 0, err
    doc = json.loads((out / "modemap.json").read_text())
    assert sorted(doc["computed"]) == ["s30_v2", "s30_v20", "s6_v2", "s6_v20"]
    assert [c["computed"] for c in doc["calls"]] == [4]  # one sweep wrote the map, with every point
    assert not (out / LOCK_FILE).exists()


@pytest.mark.parametrize("item, key", [("loading . sigma0=5", "loading.sigma0"),
                                       (" loading.v_imp =5", "loading.v_imp"),
                                       ("output.frames=[1e-6]", "output.frames"),
                                       ("output . frames={start=1e-6, interval=1e-6, count=3}", "output.frames")])
def test_set_of_a_swept_or_field_key_is_refused_however_spelt(tmp_dir_shared, comm, capsys, item, key):
    out = tmp_dir_shared / "map"
    assert sweep.main(["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out), "--set", item]) == 2
    comm.barrier()
    assert not out.exists()
    if comm.rank == 0:
        err = capsys.readouterr().err
        assert _errors(err) == [err.strip()] and f"{key} is set by the sweep itself" in err, err


def test_a_base_scene_with_camera_frames_writes_no_fields_in_a_sweep(tmp_dir_shared, comm):
    """A base scene's output.frames are field snapshots: the sweep's points write none, as with output.fields."""
    base = tmp_dir_shared / "framed.toml"
    on_rank0(comm, lambda: base.write_text('base = "case1"\n[output]\nframes = [5e-6, 10e-6]\n'))
    assert load_scene(str(base)).output["frames"] == [5e-6, 10e-6]
    out = tmp_dir_shared / "map"
    assert sweep.main([str(base), "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out)]) == 0
    comm.barrier()
    point = out / "points" / "s6_v2"
    assert json.loads((point / "summary.json").read_text())["complete"]
    assert not (point / "fields.xdmf").exists() and not (point / "fields").exists()
    assert "output.frames=[]" in json.loads((out / "modemap.json").read_text())["points"][0]["overrides"]


@pytest.mark.parametrize("item, hint", [("loading.sigma0=10", "loading.sigma0 = 10 Pa: outside the plausible"),
                                        ("loading.v_imp=0.02", "loading.v_imp = 0.02 m/s: outside the plausible"),
                                        ("material.E=5200", "material.E = 5200 Pa: outside the plausible")])
def test_a_unit_slip_is_warned_once_with_the_likely_value(comm, capsys, item, hint):
    """loading.sigma0 = 10 (meant MPa) and loading.v_imp = 0.02 (meant km/s) were accepted silently."""
    expected = {"loading.sigma0=10": "did you mean 10 MPa = 1e7?", "loading.v_imp=0.02": "did you mean 0.02 km/s = 20?",
                "material.E=5200": "did you mean 5200 MPa = 5.2e9?"}[item]
    assert cli.main(["run", "case1", "--set", "mesh.preset='coarse'", "--set", item, "--check"]) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if line.startswith("fricfem: warning: ")]
    if comm.rank == 0:
        assert len(warnings) == 1 and hint in warnings[0] and warnings[0].endswith(expected), err
    else:
        assert warnings == []
    sc = load_scene("case1", [item])
    assert len([w for w in sc.warnings if hint in w]) == 1


def test_plausible_values_and_zero_get_no_unit_warning():
    for name in ("case1", "case4", "case5", "lineA_v40", "experiment_42", "rupture_sw", "tpv205_2d"):
        assert not [w for w in load_scene(name).warnings if "plausible" in w], name
    assert not load_scene("case1", ["loading.sigma0=0.9e6", "loading.v_imp=0"]).warnings


def test_an_experiment_scene_refuses_the_loading_keys_it_does_not_use(comm):
    """experiment_42 with loading.kind = 'projectile' or loading.impedance = 1e10 ran silently without them."""
    for items, named in ((["loading.kind='projectile'"], "loading.kind"),
                         (["loading.kind='projectile'", "loading.impedance=1e10"], "loading.kind, loading.impedance"),
                         (["loading.t_rise=5e-6"], "loading.t_rise")):
        with pytest.raises(SceneError, match=f"^{named}: not used with an \\[experiment\\]"):
            load_scene("experiment_42", items)
    load_scene("experiment_42", ["loading.sigma0=5e6"])  # a key it uses


#: Built experiment models (benchmarks/results/experiment_dt.json; the coarse mesh with
#: experiment.steel_dx = 1e-5: a run's summary.json, dt 1.6 ns): (preset, steel_dx, dofs, λmax's step).
BUILT = [("coarse", 1e-3, 10316, 1.411870758860711e-07), ("reference", 1e-3, 156318, 3.558542873182105e-08),
         ("half", 1e-3, 306978, 3.5585429556621784e-08), ("fine", 1e-3, 834876, 1.786005713566443e-08),
         ("coarse", 1e-5, 201874, 1.7880311219705962e-09)]


@pytest.mark.parametrize("preset, steel_dx, dofs, dt_crit", BUILT)
def test_the_cost_estimate_sees_the_steel_bodies(preset, steel_dx, dofs, dt_crit):
    """Before: --check gave 3.4e5 dof·steps for experiment.steel_dx = 1e-5 and the run took 1.0e9; the
    estimate counted neither the steel's cells nor its stable step (the reference experiment's
    built step, 35.6 ns, lay outside the bracket)."""
    sc = load_scene("experiment_42", [f"mesh.preset='{preset}'", f"experiment.steel_dx={steel_dx}"])
    est = cost.estimate(sc)
    assert est.dofs == dofs
    assert est.dt_crit[0] <= dt_crit <= est.dt_crit[1]
    run_steps = int(sc.t_end / (sc.dt_safety * dt_crit))
    assert est.dof_steps >= dofs * run_steps  # never below what the run takes
    plain = cost.estimate(load_scene("case1", [f"mesh.preset='{preset}'"]))
    assert est.quads > plain.quads


# --------------------------------------------------------------------------- hangs and raw errors


def test_plot_of_a_run_with_many_snapshots_draws_a_capped_evenly_spaced_set(tmp_dir_shared, comm, capsys, caplog):
    """Before: one PNG per snapshot, with no cap (1000 frames: still going after 150 s)."""
    from fricfem.plot import run as plot_run

    out = tmp_dir_shared / "run"
    assert cli.main(["run", "case1", "--set", "mesh.preset='coarse'", "--set", "time.end=15e-6", "--set",
                     "output.fields=[]", "--set",
                     "output.frames={start=0.5e-6, interval=0.5e-6, count=30}", "--quiet", "--out", str(out)]) == 0
    comm.barrier()

    def plot():  # serial, as `fricfem plot` draws on rank 0 only
        capsys.readouterr()
        caplog.clear()
        rc = plot_run.main([str(out), "--max-figures", "4", "--out", str(out / "few")])
        err = capsys.readouterr().err + caplog.text  # the warnings: fricfem.output's logger (stderr in a shell)
        iso = sorted(p.name for p in (out / "few").glob("isochromatics_*us.png"))
        bad = plot_run.main([str(out), "--max-figures", "-1"])
        return rc, err, iso, (out / "few" / "isochromatics_frames.png").is_file(), bad

    rc, err, iso, series, bad = on_rank0(comm, plot)
    assert rc == 0 and len(iso) == 4 and series, (rc, iso, err)
    assert "30 isochromatic figures (snapshots): drew 4 evenly spaced (0.53 … 14.8 µs)" in err, err
    assert "skipped 26; pass --max-figures 0" in err
    assert "30 camera frames in the frame series: drew 4 evenly spaced" in err
    assert bad == 2
    assert plot_run.MAX_FIGURES == 24 and plot_run.evenly(range(30), 24)[::23] == [0, 29]
    assert plot_run.evenly(range(30), 0) == list(range(30))


def test_scenes_into_a_closed_pipe_is_quiet(comm):
    """``fricfem scenes | head -1`` printed ``fricfem: error: BrokenPipeError`` with status 1."""
    def run():
        res = subprocess.run(f"{sys.executable} -m fricfem.cli scenes --keys | head -c 10 >/dev/null; "
                             "echo ${PIPESTATUS[0]}", shell=True, executable="/bin/bash", capture_output=True,
                             text=True, env=_buffered_env(), timeout=JOB_TIMEOUT)
        return res.stdout.strip(), res.stderr

    rc, err = on_rank0(comm, run)
    assert rc in ("0", "141") and "error" not in err and "Traceback" not in err, (rc, err)


def _buffered_env() -> dict:
    """A separate job's environment with stdout block-buffered, as a user's shell has it
    (PYTHONUNBUFFERED, if the suite's environment sets it, hides the interpreter's final flush)."""
    env = faults.clean_env()
    env.pop("PYTHONUNBUFFERED", None)
    return env


@pytest.fixture(scope="module")
def small_run(tmp_path_factory, comm):
    """A finished coarse case1 run (both ranks), for the commands that read a run directory."""
    out = Path(comm.bcast(str(tmp_path_factory.mktemp("printed")) if comm.rank == 0 else None)) / "run"
    assert cli.main(["run", "case1", "--set", "mesh.preset='coarse'", "--set", "time.end=15e-6", "--set",
                     "output.fields=[]", "--quiet", "--out", str(out)]) == 0
    comm.barrier()
    return out


@pytest.mark.parametrize("argv", [["scenes"], ["scenes", "--keys"], ["show", "case1"], ["--help"],
                                  ["run", "case1", "--check"], ["export", "{run}", "--format", "csv", "--out",
                                                                "{run}/csv"],
                                  ["compare", "{run}", "{run}"], ["compare", "{run}", "{run}", "--json"]],
                         ids=lambda argv: "-".join(a.strip("-{}") for a in argv[:3]))
def test_every_printing_command_into_a_pipe_nobody_reads_is_quiet(small_run, comm, argv):
    """stdout a pipe whose reader has already left: each write fails with EPIPE. Output smaller than
    stdout's buffer was written only by the interpreter's final flush, which reported "Exception ignored
    on flushing sys.stdout: BrokenPipeError" and exited 120 (``fricfem show case1``, on every Python;
    ``fricfem scenes --keys | head -c 10`` on Python 3.13)."""
    def run():
        read, write = os.pipe()
        os.close(read)  # nobody will read: the first write (or the exit's flush) meets a closed pipe
        try:
            res = subprocess.run(_fricfem(*(a.format(run=small_run) for a in argv)), stdout=write,
                                 stderr=subprocess.PIPE, text=True, env=_buffered_env(), timeout=JOB_TIMEOUT)
        finally:
            os.close(write)
        return res.returncode, res.stderr

    rc, err = on_rank0(comm, run)
    assert rc in (0, -signal.SIGPIPE) and "Exception ignored" not in err and "Traceback" not in err, (rc, err)
    assert "error" not in err, err


def test_a_sweep_printing_into_a_closed_pipe_under_two_ranks_ends_every_rank(tmp_path_factory, comm):
    """``mpirun -n 2 fricfem sweep ... | head -1``: rank 0's table meets a closed stdout; it must end
    quietly and still join rank 1 in the final collective (else rank 1 waits forever)."""
    def run():
        out = tmp_path_factory.mktemp("pipe") / "map"
        cmd = ["mpirun", "-n", "2", "--oversubscribe",
               *_fricfem("sweep", "case1", "--sigma0", "6,30", "--v-imp", "2", *QUICK, "--out", str(out))]
        res = subprocess.run(" ".join(map(shlex.quote, cmd)) + " | head -c 1 >/dev/null; echo ${PIPESTATUS[0]}",
                             shell=True, executable="/bin/bash", capture_output=True, text=True, env=faults.clean_env(),
                             timeout=JOB_TIMEOUT)
        return res.stdout.strip(), res.stderr, json.loads((out / "modemap.json").read_text())["computed"]

    rc, err, computed = on_rank0(comm, run)
    assert rc in ("0", "141") and "Traceback" not in err and "error" not in err, (rc, err)
    assert sorted(computed) == ["s30_v2", "s6_v2"]
