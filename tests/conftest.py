"""pytest set-up for running the suite under MPI: ``mpirun -n 2 python -m pytest``.

- Only rank 0 prints pytest's terminal report. Ranks > 0 write one line to
  stderr when one of their tests fails (so a failure that leaves the other
  rank waiting in a collective is still located), and at the end send their
  failure reports to rank 0, which shows them in its report, marked
  ``[rank N]``, and counts them in its closing line.
- All ranks end with the largest exit status of any rank, so a failure on
  any rank fails every rank, and mpirun with it.
- After every test: ``gc.collect()``, PETSc's collective garbage clean-up
  (when petsc4py is loaded) and a barrier, so that PETSc objects are
  destroyed collectively and ranks enter the next test together.

Fixtures: ``comm`` (MPI.COMM_WORLD), ``tmp_dir_shared`` (one directory per
test made on rank 0 and broadcast, so every rank writes to the same place),
``tiny_fs`` (a 3 MB tmpfs, for the full-disk faults), ``clean_laws`` (the law
registry restored after the test).
"""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mpi4py import MPI

# Off-screen rendering through the VTK wheel's EGL window, no X server.
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
# No on-disk set-up cache (fricfem.model.diskcache): the suite neither reads nor fills the user's;
# tests/test_setup_cache.py points it at its own directories.
os.environ["FRICFEM_CACHE"] = "off"

_COMM = MPI.COMM_WORLD
_RANK = _COMM.rank
_FAILED_HERE: list[dict] = []  # serialized failure reports of this rank (> 0)
_CONFIG: list[pytest.Config] = []


@pytest.hookimpl(trylast=True)
def pytest_configure(config: pytest.Config) -> None:
    """Send the terminal report of ranks > 0 to /dev/null."""
    _CONFIG[:] = [config]
    if _RANK == 0:
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter is None:
        return
    from _pytest.config import create_terminal_writer

    devnull = open(os.devnull, "w")  # noqa: SIM115 (lives as long as pytest)
    config.add_cleanup(devnull.close)
    try:
        reporter._tw = create_terminal_writer(config, devnull)
    except Exception:  # pragma: no cover - a pytest without _tw
        config.pluginmanager.unregister(reporter)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Ranks > 0: note a failure on stderr now, keep the report for rank 0."""
    if _RANK == 0 or not report.failed:
        return
    crash = getattr(report.longrepr, "reprcrash", None)
    where = ""
    if crash is not None:
        first = (crash.message.splitlines() or [""])[0]
        where = f"{crash.path}:{crash.lineno}: {first}"
    sys.stderr.write(f"\n[rank {_RANK}] FAILED {report.nodeid} ({report.when}) {where}\n")
    sys.stderr.flush()
    if _CONFIG:
        config = _CONFIG[0]
        _FAILED_HERE.append(
            config.hook.pytest_report_to_serializable(config=config, report=report)
        )


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Agree on the exit status; rank 0 adds the other ranks' failures."""
    own = int(session.exitstatus)
    gathered = _COMM.gather((own, _FAILED_HERE), root=0)
    worst = _COMM.allreduce(own, op=MPI.MAX)
    session.exitstatus = worst
    if _RANK != 0:
        return
    config = session.config
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter is None:
        return
    for rank, (status, failures) in enumerate(gathered):
        if rank == 0:
            continue
        for data in failures:
            rep = config.hook.pytest_report_from_serializable(config=config, data=data)
            if rep is None:
                continue
            rep.nodeid = f"{rep.nodeid} [rank {rank}]"
            fspath, lineno, domain = rep.location
            rep.location = (fspath, lineno, f"{domain} [rank {rank}]")
            category = "failed" if rep.when == "call" else "error"
            try:
                reporter._add_stats(category, [rep])
            except AttributeError:  # pragma: no cover - other pytest versions
                reporter.stats.setdefault(category, []).append(rep)
        if status not in (0, own) and not failures:
            reporter.write_sep("!", f"rank {rank} ended with exit status {status}", red=True)


@pytest.fixture(scope="session")
def comm() -> MPI.Comm:
    """The communicator every test runs on."""
    return _COMM


@pytest.fixture
def tmp_dir_shared(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh directory, the same path on every rank (made by rank 0)."""
    path = str(tmp_path_factory.mktemp("shared")) if _RANK == 0 else None
    return Path(_COMM.bcast(path, root=0))


@pytest.fixture
def tiny_fs(tmp_dir_shared: Path, comm: MPI.Comm):
    """A 3 MB tmpfs (root only), unmounted afterwards."""
    from rankcheck import on_rank0  # imports fricfem: only for the tests that ask for this fixture

    path = tmp_dir_shared / "tiny"

    def mount():
        path.mkdir()
        res = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(path)], capture_output=True)
        return res.returncode == 0

    if not on_rank0(comm, mount):
        pytest.skip("cannot mount a tmpfs here (not root?)")
    yield path
    comm.barrier()
    on_rank0(comm, lambda: subprocess.run(["umount", "-l", str(path)], capture_output=True) and None)


@pytest.fixture
def clean_laws():
    """Leave fricfem's law registry as it was (tests and demos register laws)."""
    from fricfem import friction

    before = dict(friction.LAWS)
    yield
    friction.LAWS.clear()
    friction.LAWS.update(before)


@pytest.fixture(autouse=True)
def _collective_teardown():
    """After each test: collect garbage collectively, then synchronise."""
    yield
    gc.collect()
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None and hasattr(petsc, "garbage_cleanup"):
        petsc.garbage_cleanup(_COMM)
    _COMM.barrier()
