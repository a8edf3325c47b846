"""Results do not depend on the number of ranks: the same scene on 1 and on 2
ranks gives the same bits in every interface quantity and station history
(K, the mass and every row's sum in the grid's order, the interface forces in
fixed slots: fricfem.model.numbering).  Case III (a train of pulses: the most
sensitive to round-off, which the stick/slip switches amplify) to 20 µs."""

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, open_run, runner


@pytest.mark.slow
def test_case3_on_one_and_two_ranks_is_bit_identical(comm, tmp_dir_shared):
    scene = load_scene("case3", ["time.end=20e-6", "output.fields=[]"])
    runner.run_scene(scene, tmp_dir_shared / "world", comm, quiet=True)
    if comm.rank == 0:
        runner.run_scene(scene, tmp_dir_shared / "self", MPI.COMM_SELF, quiet=True)
    comm.Barrier()
    bad = None
    if comm.rank == 0:
        a, b = open_run(tmp_dir_shared / "world"), open_run(tmp_dir_shared / "self")
        assert a.quantity("slip_rate").max() > 1.0, "the interface should slide"
        bad = [name for name in a.names if not np.array_equal(a.quantity(name), b.quantity(name))]
        bad += [f"stations/{st}/{q}" for st, d in a.stations.items() for q, v in d.items()
                if not np.array_equal(np.asarray(v), np.asarray(b.stations[st][q]))]
        bad += [] if a.summary["dt_s"] == b.summary["dt_s"] else ["dt_s"]
    bad = comm.bcast(bad, root=0)
    assert not bad, f"1 and 2 ranks differ in {bad}"
