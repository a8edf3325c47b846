"""Checkpoint and restart (issue 25): a run killed (SIGKILL, no handler runs) or
stopped (SIGTERM) and continued with ``fricfem run --resume DIR`` gives the same
bits as a run never stopped — interface.h5 (every quantity, the stations, the
energies), gauges.h5, the field snapshots and fields.xdmf, evidence.json and
summary.json (all but its wall times) — on 1 and 2 ranks, both interface kinds
and three laws; resumed on another rank count it agrees as
tests/test_reproducibility.py requires (every interface quantity and station
history bit-identical).  A checkpoint of another scene, of another code
version or a truncated one, a complete run and a directory without a
checkpoint are refused with one line, before anything is built.

The kills are events, not instants (benchmarks/faults.py): a separate
``mpirun`` job is killed once its interface.h5 holds a number of rows drawn
with a fixed seed and a checkpoint exists; the continuation is another job.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import faults
from rankcheck import differing, h5_arrays, on_rank0, one_error
from fricfem import load_scene, open_run, runner
from fricfem.output.checkpoint import CHECKPOINT_FILE, CheckpointError, read_header
from fricfem.output.directory import LOCK_FILE

RANK = MPI.COMM_WORLD.rank
#: summary.json's measured seconds: the only keys a resumed run may differ in
MEASURED = ("wall_s", "us_per_step", "loop_cost")
COARSE = ["--set", "mesh.preset='coarse'"]

#: (name, ranks killed, ranks resumed, fricfem run arguments): three laws, both interface kinds
CASES = [
    ("povirk_needleman-elastic", 2, 2,
     ["case3", *COARSE, "--set", "time.end=100e-6", "--set", "output.fields=[30e-6,60e-6,90e-6]",
      "--set", "output.gauges={g1=[0.03,0.01],g2=[0.09,-0.02]}", "--set", "output.checkpoint_every=10e-6"]),
    ("slip_weakening-rigid", 1, 1,
     ["rupture_sw", *COARSE, "--set", "interface.kind='rigid'", "--set", "time.end=150e-6",
      "--set", "output.fields=[50e-6,120e-6]", "--set", "output.checkpoint_every=10e-6"]),
    ("rate_state_aging-rigid", 2, 2,
     ["rsf_aging_2d", "--set", "mesh.dx=8e-4", "--set", "mesh.dy=8e-4", "--set", "mesh.max_size=0.005",
      "--set", "time.end=40e-6", "--set", "output.gauges={g1=[0.035,0.004]}",
      "--set", "output.checkpoint_every=5e-6"]),
    # killed on 2 ranks, resumed on 1: the later field snapshots in the order of the run's mesh.h5 (2 ranks')
    ("slip_weakening-elastic-2to1", 2, 1,
     ["rupture_sw", *COARSE, "--set", "time.end=150e-6", "--set", "output.fields=[15e-6,120e-6]",
      "--set", "output.checkpoint_every=10e-6"]),
    # spectral elements, the elastic kind's one point a node; killed on 2 ranks, resumed on 1
    ("slip_weakening-elastic-spectral-2to1", 2, 1,
     ["tpv205_2d", "--set", "mesh.degree=3", "--set", "mesh.dx=1.6e-3", "--set", "mesh.dy=1.6e-3",
      "--set", "interface.kind='elastic'", "--set", "time.end=20e-6", "--set", "output.checkpoint_every=4e-6"]),
]


def _kill_after_checkpoint(args, out: Path, rows: int, ranks: int) -> dict:
    """Start ``fricfem run ARGS`` on ``ranks`` ranks, wait for the event — a checkpoint
    on disk and at least ``rows`` valid interface rows — then SIGKILL the job."""
    shutil.rmtree(out, ignore_errors=True)
    p = faults.start(args, out, ranks=ranks)
    seen = None
    while p.poll() is None:
        n = faults.live_rows(out / "interface.h5")
        if n is not None and n >= rows and (out / CHECKPOINT_FILE).is_file():
            seen = n
            break
        time.sleep(0.02)
    ended = p.poll() is not None
    faults.kill_tree(p.pid)
    p.wait()
    return {"rows_seen": seen, "ended_before_kill": ended, "lock_left": (out / LOCK_FILE).is_file(),
            "checkpoint_step": read_header(out / CHECKPOINT_FILE, check_code=False)["step"] if seen else None}


def _resume(out: Path, ranks: int) -> subprocess.CompletedProcess:
    """``mpirun -n RANKS fricfem run --resume OUT --quiet``."""
    return subprocess.run(["mpirun", "-n", str(ranks), str(faults.FRICFEM), "run", "--resume", str(out), "--quiet"],
                          env=faults.clean_env(), capture_output=True, text=True, timeout=900)


def _strings(a: dict) -> dict:
    """Datasets of strings compared by value (h5py gives object arrays)."""
    return {k: (v.astype(str) if getattr(v, "dtype", None) is not None and v.dtype.kind == "O" else v)
            for k, v in a.items()}


def _summary(path: Path) -> dict:
    doc = json.loads((path / "summary.json").read_text())
    return {k: v for k, v in doc.items() if k not in MEASURED}


def compare(got: Path, want: Path, same_ranks: bool = True) -> list:
    """What differs between two run directories (bits; summary.json but its measured seconds).
    ``same_ranks`` False: interface quantities and station histories (the rank-count rule),
    gauges and field snapshots."""
    if same_ranks:
        bad = [f"interface.h5:{k}" for k in differing(h5_arrays(got / "interface.h5"),
                                                       h5_arrays(want / "interface.h5"))]
    else:  # the energies are sums over ranks: they differ in the last bits
        a, b = open_run(got), open_run(want)
        bad = [n for n in b.names if not np.array_equal(a.quantity(n), b.quantity(n))]
        bad += [f"stations/{s}/{q}" for s, d in b.stations.items() for q, v in d.items()
                if not np.array_equal(np.asarray(v), np.asarray(a.stations[s][q]))]
        bad += [] if np.array_equal(a.t, b.t) else ["time"]
    if (want / "gauges.h5").exists():
        bad += [f"gauges.h5:{k}" for k in differing(_strings(h5_arrays(got / "gauges.h5")),
                                                     _strings(h5_arrays(want / "gauges.h5")))]
    if (want / "fields").is_dir():
        names = sorted(p.name for p in (want / "fields").iterdir())
        if names != sorted(p.name for p in (got / "fields").iterdir()):
            bad.append("fields/: other files")
        bad += [f"fields/{n}" for n in names if (got / "fields" / n).exists()
                and differing(h5_arrays(got / "fields" / n), h5_arrays(want / "fields" / n))]
        if (got / "fields.xdmf").read_text() != (want / "fields.xdmf").read_text():
            bad.append("fields.xdmf")
    if not same_ranks:
        return bad
    if (got / "evidence.json").read_bytes() != (want / "evidence.json").read_bytes():
        bad.append("evidence.json")
    sa, sb = _summary(got), _summary(want)
    bad += [f"summary.json:{k}" for k in sorted(set(sa) | set(sb)) if sa.get(k) != sb.get(k)]
    return bad


@pytest.mark.slow
@pytest.mark.parametrize("name,ranks,resume_ranks,args", CASES, ids=[c[0] for c in CASES])
def test_sigkill_then_resume_is_bit_identical(comm, tmp_dir_shared, name, ranks, resume_ranks, args):
    """A complete run; the same run SIGKILLed once it holds a random number of rows
    (drawn with a fixed seed, after its first checkpoint) and continued with
    ``--resume``: the same bits (the killed run's stale lock taken over)."""
    def run_case():
        for _ in range(2):  # again once if fricfem's sources changed meanwhile (an edit in the tree: refused, rightly)
            got = attempt()
            if "another version of fricfem's code" not in got[2]:
                return got
        return got

    def attempt():
        ref, out = tmp_dir_shared / "complete", tmp_dir_shared / "killed"
        assert faults.start(args, ref, ranks=ranks).wait(timeout=900) == 0, f"the complete run of {name} failed"
        t = open_run(ref).t
        every = next(float(a.split("=")[1]) for a in args if a.startswith("output.checkpoint_every="))
        first = int(np.searchsorted(t, every))  # rows when the first checkpoint is written
        rows = random.Random(f"issue25-{name}").randint(first + 2, int(0.7 * len(t)))
        kill = _kill_after_checkpoint(args, out, rows, ranks)
        res = _resume(out, resume_ranks)
        return kill, res.returncode, res.stderr[-3000:], compare(out, ref, same_ranks=ranks == resume_ranks), \
            sorted(p.name for p in out.iterdir())

    kill, status, err, bad, left = on_rank0(comm, run_case)
    assert not kill["ended_before_kill"] and kill["rows_seen"] is not None, kill  # killed mid-run
    assert kill["lock_left"] and kill["checkpoint_step"] > 0, kill  # a stale lock; a checkpoint to go on from
    assert status == 0, err
    assert bad == [], bad
    assert not any(n.endswith((".resume", ".part")) for n in left), left  # nothing of the restart left behind


# -- in process: a stop by SIGTERM, and the refusals ----------------------------------------------------------

SMALL = ["mesh.preset='coarse'", "time.end=12e-6", "output.checkpoint_every=2e-6", "output.fields=[3e-6,9e-6]",
         "output.gauges={g1=[0.05,0.01]}"]


class Stop(Exception):
    """Ends a run in process at a chosen step (as a kill would: nothing finalised)."""


def _cut(scene, out: Path, comm, at: int) -> None:
    """Run ``scene`` into ``out`` and break it off after step ``at`` (every rank)."""
    def on_step(st):
        if st.n == at:
            raise Stop

    with pytest.raises(Stop):
        runner.run_scene(scene, out, comm, quiet=True, on_step=on_step)
    comm.Barrier()


def test_sigterm_stop_then_resume_is_bit_identical(comm, tmp_dir_shared):
    """SIGTERM stops a run cleanly (its files compacted to their rows, a checkpoint
    at the stop, summary.json interrupted); ``--resume`` continues it to the same
    bits as the uninterrupted run (in process, on this job's ranks)."""
    scene = load_scene("case3", SMALL)
    runner.run_scene(scene, tmp_dir_shared / "full", comm, quiet=True)

    def on_step(st):
        if st.n == 21:  # every rank asks at the same step; the run stops at its next reduction
            os.kill(os.getpid(), signal.SIGTERM)

    stopped = runner.run_scene(scene, tmp_dir_shared / "cut", comm, quiet=True, on_step=on_step)
    assert stopped["interrupted"] and not stopped["complete"]
    step = on_rank0(comm, lambda: read_header(tmp_dir_shared / "cut" / CHECKPOINT_FILE)["step"])
    assert step == stopped["steps"] == 22  # the stop's (seen at the next step), not the cadence's (16, 24)
    assert len(open_run(tmp_dir_shared / "cut").t) < len(open_run(tmp_dir_shared / "full").t)  # compacted
    resumed = runner.run_scene(scene, tmp_dir_shared / "cut", comm, quiet=True, resume=True)
    assert resumed["complete"]
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "cut", tmp_dir_shared / "full")) == []


def test_refusals(comm, tmp_dir_shared, capsys, monkeypatch):
    """One line each, before a mesh is built: another scene's checkpoint, a checkpoint
    of another code version, a truncated one, a complete run, a run without checkpoints."""
    scene = load_scene("case3", SMALL)
    out = tmp_dir_shared / "cut"
    _cut(scene, out, comm, 20)
    path = out / CHECKPOINT_FILE
    flags = sum((["--set", s] for s in SMALL), [])

    def refused(argv, *needles):
        built = []
        monkeypatch.setattr(runner, "_run", lambda *a, **k: built.append(1))  # the build and the run
        try:
            return one_error(capsys, argv, *needles)
        finally:
            monkeypatch.undo()
            assert not built

    # another scene (another loading.sigma0): named with both scenes' keys
    refused(["run", "case3", *flags, "--set", "loading.sigma0=11e6", "--resume", str(out)],
            str(path), "another scene")
    with pytest.raises(CheckpointError, match="another scene"):
        runner.run_scene(load_scene("rupture_sw", SMALL), out, comm, quiet=True, resume=True)
    # a forged code version
    original = on_rank0(comm, path.read_bytes)

    def forge(fn):
        def work():
            data = bytearray(original)
            fn(data)
            path.write_bytes(bytes(data))
        on_rank0(comm, work)

    def other_code(data):
        i = data.index(b'"code": "') + len(b'"code": "')
        data[i:i + 12] = b"0123456789ab"

    forge(other_code)
    refused(["run", "--resume", str(out)], str(path), "another version of fricfem's code")
    forge(lambda data: data.__delitem__(slice(len(data) - 100, None)))
    refused(["run", "--resume", str(out)], str(path), "truncated")
    forge(lambda data: data.__setitem__(len(data) - 50, data[len(data) - 50] ^ 0xFF))
    refused(["run", "--resume", str(out)], str(path), "damaged")
    forge(lambda data: None)  # whole again: it resumes
    assert runner.run_scene(scene, out, comm, quiet=True, resume=True)["complete"]
    # a complete run: nothing to resume
    refused(["run", "--resume", str(out)], str(out), "complete")
    # a run that wrote no checkpoint
    plain = load_scene("case3", [s for s in SMALL if not s.startswith("output.checkpoint")])
    _cut(plain, tmp_dir_shared / "plain", comm, 20)
    refused(["run", "--resume", str(tmp_dir_shared / "plain")], "no checkpoint")


def test_a_sweep_point_resumes_from_its_checkpoint(comm, tmp_dir_shared, monkeypatch):
    """A batch job (fricfem sweep's points) whose directory holds an unfinished run of its
    scene with a checkpoint continues from it — the same bits as a run never stopped —
    and one with a checkpoint of other inputs starts again."""
    from fricfem import batch
    from fricfem.output import checkpoint
    from rankcheck import count_calls

    scene = load_scene("case3", SMALL)
    runner.run_scene(scene, tmp_dir_shared / "full", comm, quiet=True)
    _cut(scene, tmp_dir_shared / "point", comm, 20)
    _cut(load_scene("case3", [*SMALL, "loading.sigma0=11e6"]), tmp_dir_shared / "other", comm, 20)
    calls = count_calls(monkeypatch, {"resumed": (checkpoint, "resume_observed")})
    jobs = [batch.Job("point", tmp_dir_shared / "point", scene), batch.Job("other", tmp_dir_shared / "other", scene)]
    results = batch.run_jobs(jobs, comm, ranks_per_job=comm.size)
    if RANK == 0:
        assert [r.error for r in results] == [None, None]
        assert all(r.record["complete"] for r in results)
    assert calls["resumed"] == 1  # the point of this scene only
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "point", tmp_dir_shared / "full")) == []
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "other", tmp_dir_shared / "full")) == []


def test_wall_clock_checkpoints_then_resume(comm, tmp_dir_shared):
    """``output.checkpoint_wall`` alone: rank 0's clock decides (here every step is past
    the interval) and every rank takes the checkpoint in the same step (the loop's one
    reduction); the run broken off goes on from it to the same bits."""
    sets = [s for s in SMALL if not s.startswith(("output.checkpoint", "time.end", "output.fields"))]
    scene = load_scene("case3", sets + ["time.end=6e-6", "output.fields=[3e-6]", "output.checkpoint_wall=1e-9"])
    runner.run_scene(scene, tmp_dir_shared / "full", comm, quiet=True)
    _cut(scene, tmp_dir_shared / "cut", comm, 15)
    step = on_rank0(comm, lambda: read_header(tmp_dir_shared / "cut" / CHECKPOINT_FILE)["step"])
    assert step in (14, 15)  # the last step before the break (no simulated-time cadence is set)
    assert runner.run_scene(scene, tmp_dir_shared / "cut", comm, quiet=True, resume=True)["complete"]
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "cut", tmp_dir_shared / "full")) == []


def test_a_user_law_resumes_with_its_watch(comm, tmp_dir_shared, clean_laws):
    """A user's law (checked as it runs: fricfem.observe.LawWatch, per point) is
    checkpointed with its watch's per-point memory in the grid's order and resumes
    to the same bits."""
    import numba

    from userlaws import coulomb_advance
    from fricfem import friction, register_law
    from fricfem.friction import Law, Param

    @numba.njit
    def mu(p, v):
        return p[0]

    register_law(Law(name="ckpt_coulomb", doc="Coulomb", params=(Param("mu", 0.3, "", 0.0, 1.0, "coefficient"),),
                     state=(), advance=coulomb_advance, steady_mu=mu, initial_state=lambda p, Tn0, Ts0: np.zeros(0)))
    assert "ckpt_coulomb" in friction.LAWS
    scene = load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=20.0", "time.end=20e-6", "output.fields=[]",
                                 "friction.law='ckpt_coulomb'", "output.checkpoint_every=3e-6"])
    full = runner.run_scene(scene, tmp_dir_shared / "full", comm, quiet=True)
    assert full["complete"] and full["initiation"] is not None  # it slides: the watch has something to hold
    _cut(scene, tmp_dir_shared / "cut", comm, 50)
    assert runner.run_scene(scene, tmp_dir_shared / "cut", comm, quiet=True, resume=True)["complete"]
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "cut", tmp_dir_shared / "full")) == []


def test_field_order_of_another_partition():
    """A run resumed on another rank count writes its field snapshots in the order of
    the run's mesh.h5: each node and cell is found by its coordinates (a cell by its
    vertices', in any order), whatever order the new partition gathers them in."""
    from fricfem.output.fields import _matching

    rng = np.random.default_rng(25)
    x = np.column_stack([rng.random(60), rng.random(60)])
    topology = np.array([rng.choice(60, 3, replace=False) for _ in range(90)])
    p_node, p_cell = rng.permutation(60), rng.permutation(90)  # the new partition's gathering order
    new_nodes = x[p_node]
    corner = np.array([rng.permutation(3) for _ in range(90)])  # and each cell's vertices in another order
    new_cells = np.take_along_axis(x[topology][p_cell], corner[:, :, None], axis=1).reshape(-1, 6)
    nodes, cells = _matching((new_nodes, new_cells), x, topology)
    assert np.array_equal(new_nodes[nodes], x)
    assert np.array_equal(p_cell[cells], np.arange(90))  # cell k of the file is new cell cells[k]
    with pytest.raises(ValueError, match="not this mesh's"):
        _matching((new_nodes[1:], new_cells), x, topology)


def test_an_experiment_resumes(comm, tmp_dir_shared, capsys):
    """The experiment's bodies (the projectile against its buffer: the contact's node
    pairs in the state, by pair) checkpoint and resume to the same bits; a
    checkpoint interval that would never write one is refused in one line."""
    sets = ["mesh.preset='coarse'", "time.end=10e-6", "output.checkpoint_every=2e-6", "output.fields=[3e-6,8e-6]"]
    scene = load_scene("experiment_mode_pulse", sets)
    runner.run_scene(scene, tmp_dir_shared / "full", comm, quiet=True)
    _cut(scene, tmp_dir_shared / "cut", comm, 60)
    assert runner.run_scene(scene, tmp_dir_shared / "cut", comm, quiet=True, resume=True)["complete"]
    assert on_rank0(comm, lambda: compare(tmp_dir_shared / "cut", tmp_dir_shared / "full")) == []
    one_error(capsys, ["run", "case3", "--set", "mesh.preset='coarse'", "--set", "time.end=4e-6", "--set",
                        "output.fields=[]", "--set", "output.checkpoint_every=5e-6", "--out",
                        str(tmp_dir_shared / "never"), "--quiet"],
               "output.checkpoint_every = 5e-06 s", "no checkpoint would be written")
