"""Run a batch of scenes: resumable, heaviest first, taken by groups of ranks as they free up.

Used by ``fricfem sweep``, the stability study and the paper demos.

    jobs = [Job(key, rundir, scene, cost=expected_cost(scene)) for ...]
    todo = [j for j in jobs if status(j) != "done"]
    results = run_jobs(todo, comm, ranks_per_job=1)       # collective

Each job is one scene run into its own run directory.  When a job finishes
(complete, or stopped by the watchdog: rerunning gives the same), the batch
writes ``job.json`` beside the run's files: the job's *identity* (by default
the scene's input tables) and its *record* (what the job's work returned).
A later batch reuses a job whose ``job.json`` holds the same identity
(:func:`status`), so a killed batch picks up where it stopped.

Under MPI the communicator is split into groups of ``ranks_per_job`` ranks;
the jobs are sorted by expected cost, heaviest first, and each group takes the
next job of that order whenever it is free (:class:`SharedCounter`: an atomic
fetch-and-add on rank 0, so a group that drew cheap points takes more of
them), running its jobs one after another on its own communicator.  Which
group runs a job does not change its results.  ``ranks_per_job = 1``: one
serial run per rank (a sweep scales by points); ``= comm.size``: every job
on all ranks (the paper demos).  A
group keeps the models it built (:class:`fricfem.model.reuse.ModelCache`): a
job on the same mesh and interface as an earlier one of its group reuses the
mesh, K, the mass, the interface geometry, λmax and the step's rows, with the
same results bit for bit.  :class:`Pool` keeps the groups and their models
for several batches (the rounds of an adaptive map):

    with Pool(comm, ranks_per_job=1) as pool:
        first = pool.run(jobs)
        second = pool.run(more_jobs)                      # same groups, same models
"""

from __future__ import annotations

import gc
import json
import math
import sys
import time
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
from mpi4py import MPI

JOB_FILE = "job.json"


class Job(NamedTuple):
    """One run of a batch.

    key       unique name in the batch (log lines, results)
    dir       its run directory
    scene     the validated :class:`fricfem.scene.Scene`
    cost      expected relative cost (:func:`expected_cost`); only the order matters
    identity  what a stored run must match to be reused (JSON-able; default the scene's input)
    """

    key: str
    dir: Path
    scene: object
    cost: float = 1.0
    identity: object = None

    def ident(self):
        """The identity, normalised through JSON (what ``job.json`` holds)."""
        return json.loads(json.dumps(self.scene.raw if self.identity is None else self.identity))


#: Top-level scene keys that document a run without changing it: a stored run whose
#: inputs differ only there is the same run (a scene's description may be reworded).
NOT_INPUT = ("description",)


def same_identity(stored_identity, now) -> bool:
    """Whether a stored identity names the same run as ``now`` (both JSON-normalised):
    equal, or (scene tables) equal but for the documentation keys :data:`NOT_INPUT`."""
    if stored_identity == now:
        return True
    if not (isinstance(stored_identity, dict) and isinstance(now, dict)):
        return False
    return {k: v for k, v in stored_identity.items() if k not in NOT_INPUT} == \
        {k: v for k, v in now.items() if k not in NOT_INPUT}


def expected_cost(scene) -> float:
    """Relative cost of a run (heavier first).

    Steps ∝ t_end / dt with dt ∝ the smallest cell size (interface springs
    stiffer than the bulk shorten it further, ∝ 1/√C_n); work per step ∝ the
    cell count ∝ 1/(dx·dy); and the friction kernel sub-steps more when
    sliding is fast, which grows with V_imp.
    """
    m = scene.mesh
    h = min(m.dx, m.dy)
    stiff = max(1.0, math.sqrt(scene.Cn / 3e11))
    return scene.t_end / h * stiff / (m.dx * m.dy) * (1.0 + scene.pulse.v_imp / 10.0)


def stored(job: Job) -> dict | None:
    """``job.json`` of the job's directory ({"identity", "record"}), or None (none there, or
    not a JSON table: a damaged record does not count as a finished job)."""
    try:
        doc = json.loads((Path(job.dir) / JOB_FILE).read_text())
    except (OSError, ValueError):  # missing, a directory, unreadable, not JSON or not UTF-8
        return None
    return doc if isinstance(doc, dict) else None  # damaged (a list, a number): the job runs again


def status(job: Job) -> str:
    """'done' (finished with the same identity), 'stale' (finished with another), 'todo'.

    Finished: ``job.json`` is there and the run's ``summary.json`` says it is
    complete or was stopped by the watchdog (a directory whose run was killed
    or damaged since is run again).  Same identity: :func:`same_identity` (a
    reworded scene description does not make a run stale)."""
    # lazy: start-up time (it loads h5py)
    from .output.rundir import read_summary

    s = stored(job)
    if s is None or not _finished(read_summary(job.dir)):
        return "todo"
    return "done" if same_identity(s.get("identity"), job.ident()) else "stale"


def order(jobs) -> list:
    """The jobs by expected cost, heaviest first (ties by key): the order groups take them in."""
    return sorted(jobs, key=lambda j: (-j.cost, j.key))


class SharedCounter:
    """The place of the next job to take, shared by the groups of ranks of ``comm``.

    One integer in an MPI window on rank 0 of ``comm``; the first rank of a
    group takes a place with an atomic fetch-and-add (``MPI_Fetch_and_op``,
    passive target: rank 0 need not be waiting for it) and tells the rest of
    its group (``sub``).  Collective on ``comm`` to make and to :meth:`free`.
    """

    def __init__(self, comm, sub):
        self.comm, self.sub = comm, sub
        self.win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
        if comm.rank == 0:
            self.win.Lock(0, MPI.LOCK_EXCLUSIVE)
            self.win.Put(np.zeros(1, dtype=np.int64), 0)
            self.win.Unlock(0)
        comm.Barrier()

    def take(self) -> int:
        """The next place (0, 1, 2, …: each place once over all groups; collective on ``sub``)."""
        got = None
        if self.sub.rank == 0:
            one, old = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
            self.win.Lock(0, MPI.LOCK_SHARED)
            self.win.Fetch_and_op(one, old, 0, 0, MPI.SUM)
            self.win.Unlock(0)
            got = int(old[0])
        return self.sub.bcast(got, root=0) if self.sub.size > 1 else got

    def free(self) -> None:
        self.win.Free()


def run_scene_job(job: Job, comm, models=None) -> dict:
    """The default work of a job: run its scene (overwriting the directory), or continue it
    from its checkpoint when its directory holds one of this scene (:func:`resumable`); the
    summary.  ``models``: a :class:`fricfem.model.reuse.ModelCache` to take the model from."""
    # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py, numba, h5py)
    from .runner import run_scene

    build = {} if models is None else {"build": models.build}
    if resumable(job, comm):
        return run_scene(job.scene, job.dir, comm, quiet=True, resume=True, **build)
    return run_scene(job.scene, job.dir, comm, overwrite=True, quiet=True, **build)


def resumable(job: Job, comm) -> bool:
    """Whether the job's directory holds an unfinished run of this very scene with a
    checkpoint it can continue from (:func:`fricfem.output.checkpoint.check_resume`: the
    same scene key and code, a whole file, not complete); collective on ``comm``.  Any
    other directory's run starts again."""
    # lazy: start-up time (it loads numba)
    from .output import checkpoint

    try:
        checkpoint.check_resume(Path(job.dir), comm, job.scene)
    except checkpoint.CheckpointError:
        return False
    return True


def _finished(record: dict) -> bool:
    return bool(record.get("complete") or record.get("watchdog"))


class Result(NamedTuple):
    """What a job left: its key, the record (None on error), the error text, wall seconds."""

    key: str
    record: dict | None
    error: str | None
    wall_s: float


def _free(comm, keep: bool = True) -> None:
    """Runs on a sub-communicator leave PETSc objects to the garbage collector: free them now.

    ``keep``: what survives is then frozen (``gc.freeze``), so that the next
    job's collection looks only at the objects made since: a full collection
    walks every object of the process, ~55 ms a job once dolfinx, numba and a
    model are loaded.  :meth:`Pool.close` unfreezes them (``keep=False``).
    """
    gc.collect()
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None and hasattr(petsc, "garbage_cleanup"):
        petsc.garbage_cleanup(comm)
    if keep:
        gc.freeze()


def _run_group(jobs, comm, work, log, finished, total: int) -> list:
    """Run ``jobs`` ((place, job) pairs, taken as the iteration goes) one after
    another on ``comm`` (collective on it); ``total``: the batch's size, for the log."""
    done = []
    for k, job in jobs:
        t0 = time.perf_counter()
        record = err = None
        if comm.rank == 0:  # a job running is not finished, whatever it was before
            (Path(job.dir) / JOB_FILE).unlink(missing_ok=True)
        try:
            record = work(job, comm)
        except Exception as e:  # one failed job does not stop the batch (nor leave ranks waiting)
            err = f"{type(e).__name__}: {e}"
        wall = time.perf_counter() - t0
        if record is not None and finished(record) and comm.rank == 0:
            (Path(job.dir) / JOB_FILE).write_text(json.dumps({"identity": job.ident(), "record": record},
                                                              default=str))  # unindented: json's C encoder
        if log is not None and comm.rank == 0:
            rec = record or {}
            what = err or rec.get("outcome") or (rec.get("mode") or {}).get("label") or rec.get("watchdog") or "done"
            log(f"{k + 1}/{total} {job.key}: {what} ({wall:.1f} s)")
        done.append(Result(job.key, record, err, wall))
        _free(comm)
        if record is not None and record.get("interrupted"):  # SIGTERM: leave the rest for a rerun
            if log is not None and comm.rank == 0:
                log("interrupted (SIGTERM): stopping; rerun the same command to resume")
            break
    return done


def _taken(counter: SharedCounter, todo: list):
    """(place, job) for the places ``counter`` gives this group, until the batch is done."""
    while True:
        k = counter.take()
        if k >= len(todo):
            return
        yield k, todo[k]


class Pool:
    """Groups of ``ranks_per_job`` ranks of ``comm``, kept for several batches
    (the rounds of an adaptive map): the split communicator and, per group, a
    :class:`fricfem.model.reuse.ModelCache`, so that scenes sharing a mesh and
    interface reuse one model across jobs and batches.  Collective to make and
    to :meth:`close` (or use it as a context manager).
    """

    def __init__(self, comm=MPI.COMM_WORLD, ranks_per_job: int = 1, reuse: bool = True):
        k = int(ranks_per_job)
        if k < 1 or comm.size % k:
            raise ValueError(f"--ranks-per-scene {ranks_per_job}: must divide the number of ranks ({comm.size})")
        # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py, numba)
        from .model.reuse import ModelCache

        self.comm, self.k = comm, k
        self.groups = comm.size // k
        self.color = comm.rank // k
        self.sub = comm.Split(self.color, comm.rank) if self.groups > 1 else comm
        self.models = ModelCache() if reuse else None

    def run(self, jobs, *, work: Callable | None = None, log: Callable | None = None,
            finished: Callable = _finished) -> list | None:
        """Run ``jobs`` (collective on the pool's ``comm``): see :func:`run_jobs`.
        ``work`` None: run each job's scene, with the group's model cache."""
        if work is None:
            models = self.models
            work = (lambda job, c: run_scene_job(job, c, models)) if models is not None else run_scene_job
        todo = order(jobs)
        if self.groups == 1:
            done = _run_group(enumerate(todo), self.sub, work, log, finished, len(todo))
        else:
            counter = SharedCounter(self.comm, self.sub)
            try:
                done = _run_group(_taken(counter, todo), self.sub, work, log, finished, len(todo))
            finally:
                self.comm.Barrier()  # every group done with the counter
                counter.free()
        leaders = self.comm.gather(done if (self.comm.rank % self.k == 0) else [], root=0)
        if self.comm.rank != 0:
            return None
        by_key = {r.key: r for part in leaders for r in part}
        return [by_key[j.key] for j in jobs if j.key in by_key]

    def close(self) -> None:
        """Drop the cached models and free the sub-communicator (collective)."""
        if self.models is not None:
            self.models.clear()
        gc.unfreeze()  # what the jobs' collections froze is the collector's again
        _free(self.sub, keep=False)
        if self.sub is not self.comm:
            self.sub.Free()
            self.sub = self.comm

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def run_jobs(jobs, comm=MPI.COMM_WORLD, *, ranks_per_job: int = 1, work: Callable | None = None,
             log: Callable | None = None, finished: Callable = _finished) -> list | None:
    """Run ``jobs`` on groups of ``ranks_per_job`` ranks of ``comm`` (collective).

    ``work(job, group_comm) -> record`` (a JSON-able dict) does one job
    (default: run its scene, reusing the model of an earlier job of the group
    on the same mesh and interface (:mod:`fricfem.model.reuse`); the record
    is the summary); ``finished(record)`` says whether the job is settled, so
    that ``job.json`` is written and the job reused next time.  Returns the
    :class:`Result` of every job on rank 0 of ``comm`` (None elsewhere), in
    the order of ``jobs``.
    """
    with Pool(comm, ranks_per_job) as pool:
        return pool.run(jobs, work=work, log=log, finished=finished)
