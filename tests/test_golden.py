"""Whole runs against their golden fingerprints (tests/golden.py): a change of
code that is meant to leave results alone must leave them bit-identical."""

import json

import pytest

import golden


@pytest.mark.slow
@pytest.mark.parametrize("name", list(golden.CASES))
def test_run_matches_golden(name, comm, tmp_dir_shared):
    rundir = golden.run_case(name, tmp_dir_shared, comm)
    bad = None
    if comm.rank == 0:
        want = json.loads((golden.GOLDEN_DIR / f"{name}.json").read_text())
        bad = golden.compare(golden.fingerprint(rundir), want)
    bad = comm.bcast(bad, root=0)
    assert not bad, f"{name}: results changed:\n" + "\n".join(bad)
