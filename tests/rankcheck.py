"""Helpers for tests under MPI: work done on rank 0 and shared (``on_rank0``); one scene on
every rank of ``comm`` and alone on rank 0: which recorded arrays differ."""

import numpy as np
from mpi4py import MPI

from fricfem import cli, runner
from fricfem.output.rundir import open_run


def on_rank0(comm, fn):
    """``fn()`` on rank 0, its result (or its failure) on every rank."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn()
        except BaseException as err:  # re-raised on every rank
            error = err
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


def world_against_self(scene, tmp_dir, comm, min_peak: float) -> list:
    """Run ``scene`` on ``comm`` and on rank 0 alone; the names of the interface
    quantities, station histories and ``dt_s`` that are not bit-identical (on every
    rank).  ``min_peak``: the slip rate [m/s] the run must exceed (it must slide)."""
    runner.run_scene(scene, tmp_dir / "world", comm, quiet=True)
    if comm.rank == 0:
        runner.run_scene(scene, tmp_dir / "self", MPI.COMM_SELF, quiet=True)
    comm.Barrier()
    bad = None
    if comm.rank == 0:
        a, b = open_run(tmp_dir / "world"), open_run(tmp_dir / "self")
        assert a.quantity("slip_rate").max() > min_peak, "the interface should slide"
        bad = [name for name in a.names if not np.array_equal(a.quantity(name), b.quantity(name))]
        bad += [f"stations/{st}/{q}" for st, d in a.stations.items() for q, v in d.items()
                if not np.array_equal(np.asarray(v), np.asarray(b.stations[st][q]))]
        bad += [] if a.summary["dt_s"] == b.summary["dt_s"] else ["dt_s"]
    return comm.bcast(bad, root=0)


def h5_arrays(path) -> dict:
    """Every dataset of an HDF5 file: {name: array}."""
    import h5py

    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def differing(a: dict, b: dict) -> list:
    """Names of datasets whose bytes differ (or that one file lacks)."""
    bad = sorted(set(a) ^ set(b))
    for k in sorted(set(a) & set(b)):
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.shape != y.shape or x.dtype != y.dtype or x.tobytes() != y.tobytes():
            bad.append(k)
    return bad


def comms(comm):
    """The 2-rank communicator and each rank alone (both under mpirun -n 2)."""
    return [("world", comm)] + ([("self", MPI.COMM_SELF)] if comm.size > 1 else [])


def serial_env() -> dict:
    """This process's environment without the MPI launcher's variables: a
    subprocess started with it is a serial program of its own (one started from
    a rank of mpirun would otherwise try to join that job and fail in MPI_Init)."""
    import os

    return {k: v for k, v in os.environ.items() if not k.startswith(("OMPI", "PMIX", "PMI_"))}


def count_calls(monkeypatch, targets: dict) -> dict:
    """Replace each ``(module, function name)`` of ``targets`` by a wrapper that
    counts its calls; returns ``{label: calls so far}``, updated as they happen."""
    calls = dict.fromkeys(targets, 0)

    def counted(label, fn):
        def wrapper(*a, **k):
            calls[label] += 1
            return fn(*a, **k)
        return wrapper

    for label, (module, name) in targets.items():
        monkeypatch.setattr(module, name, counted(label, getattr(module, name)))
    return calls


def command(capsys, argv):
    """(status, this rank's stderr lines) of ``fricfem ARGV`` in process."""
    capsys.readouterr()
    status = cli.main(argv)
    return status, [line for line in capsys.readouterr().err.splitlines() if line.strip()]


def one_error(capsys, argv, *needles) -> str:
    """``fricfem ARGV`` fails with status 2 and one line on rank 0 containing every needle
    (nothing on the other ranks); that line on rank 0, "" elsewhere."""
    status, err = command(capsys, argv)
    assert status == 2, err
    if MPI.COMM_WORLD.rank == 0:
        assert len(err) == 1 and err[0].startswith("fricfem: error: "), err
        for n in needles:
            assert n in err[0], err[0]
        return err[0]
    assert err == []
    return ""
