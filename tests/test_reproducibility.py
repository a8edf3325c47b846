"""Results do not depend on the number of ranks: the same scene on 1 and on 2
ranks gives the same bits in every interface quantity and station history
(K, the mass and every row's sum in the grid's order, the interface forces in
fixed slots: fricfem.model.numbering).  Case III (a train of pulses: the most
sensitive to round-off, which the stick/slip switches amplify) to 20 µs."""

import pytest
from rankcheck import world_against_self

from fricfem import load_scene


@pytest.mark.slow
def test_case3_on_one_and_two_ranks_is_bit_identical(comm, tmp_dir_shared):
    scene = load_scene("case3", ["time.end=20e-6", "output.fields=[]"])
    bad = world_against_self(scene, tmp_dir_shared, comm, min_peak=1.0)
    assert not bad, f"1 and 2 ranks differ in {bad}"
