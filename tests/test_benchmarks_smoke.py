"""The stability, end-to-end and skipping benchmarks run in their ``--smoke`` mode and write
their JSON.  Run under ``mpirun -n 2``: both ranks call each script's ``main``."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str):
    module = importlib.import_module(name)  # benchmarks/ is on pytest's pythonpath
    return module


def test_stability_smoke(comm, tmp_dir_shared):
    """A handful of points, parallel over ranks: each ends ok, rejected (γ < ½),
    watchdog or error — never a silent NaN — and the three files are written."""
    bench = _load("stability")
    doc = bench.main(["--smoke", "--quiet", "--out", str(tmp_dir_shared / "results"),
                      "--work", str(tmp_dir_shared / "work")], comm)
    assert doc["smoke"] and doc["ranks"] == comm.size
    kinds = {r["key"]: r["kind"] for r in doc["points"]}
    assert set(kinds.values()) <= set(bench.KINDS)
    assert kinds["s6_v2_k1_d0.9_g0.25"] == "rejected"
    rejected = next(r for r in doc["points"] if r["kind"] == "rejected")
    assert rejected["outcome"].startswith("rejected: friction.params.gamma = 0.25")
    assert kinds["s6_v2_k1_d0.9_g0.5"] == "ok"
    assert not doc["silent_nonfinite"]
    for r in doc["points"]:
        assert r["outcome"] == "ok" or r["outcome"].startswith(f"{r['kind']}: ")
        if r["kind"] == "ok":
            assert not r["nonfinite_datasets"] and r["peak_slip_rate_m_s"] >= 0.0
    if comm.rank == 0:
        stored = json.loads((tmp_dir_shared / "results" / "stability.json").read_text())
        assert stored["counts"] == doc["counts"]
        assert (tmp_dir_shared / "results" / "stability.md").read_text().startswith("# Stability stress test")
        assert (tmp_dir_shared / "results" / "stability.png").stat().st_size > 0

    # resumable: a second call reuses every computed point
    again = bench.main(["--smoke", "--quiet", "--out", str(tmp_dir_shared / "results"),
                        "--work", str(tmp_dir_shared / "work")], comm)
    assert again["computed"] == 0 and again["reused"] == len(doc["points"]) - 1  # all but the rejected point
    assert {r["key"]: r["outcome"] for r in again["points"]} == {r["key"]: r["outcome"] for r in doc["points"]}


def test_end_to_end_smoke(comm, tmp_dir_shared):
    """The in-process probe splits a short coarse run into import, setup, JIT, loop and output."""
    bench = _load("end_to_end")
    doc = bench.main(["--smoke", "--out", str(tmp_dir_shared / "results"), "--work", str(tmp_dir_shared / "work")],
                     comm)
    probe = doc["probe"]["in_process"]
    assert probe["steps"] > 0 and probe["ranks"] == comm.size
    split = probe["split"]
    assert set(split) >= {"setup: mesh (excl. JIT)", "JIT: ffcx forms", "JIT: numba (compile or cache load)",
                          "time loop (excl. JIT)", "output (excl. JIT)"}
    assert all(v >= -1e-3 for v in split.values()), split
    assert probe["mesh_s"] > 0.0 and probe["stiffness_s"] > 0.0
    assert sum(split.values()) <= probe["import_s"] + probe["run_total_s"] + 1e-6
    if comm.rank == 0:
        stored = json.loads((tmp_dir_shared / "results" / "end_to_end.json").read_text())
        assert stored["probe"]["in_process"]["split"] == split


def test_skipping_smoke(comm, tmp_dir_shared):
    """Every saving runs with and without it on the coarse mesh; the table and JSON are written."""
    bench = _load("skipping")
    doc = bench.main(["--smoke", "--out", str(tmp_dir_shared / "skip")], comm)
    assert len(doc["rows"]) == len(bench.CASES)
    for r in doc["rows"]:
        assert r["median"]["on"]["total_s"] > 0 and np.isfinite(r["speedup_total"]), r["what"]
    fields = next(r for r in doc["rows"] if r["saving"] == "fields")
    assert fields["without"][0].startswith("output.fields=[1e-06")
    if comm.rank == 0:
        assert json.loads((tmp_dir_shared / "skip" / "skipping.json").read_text())["rows"]
        assert (tmp_dir_shared / "skip" / "skipping.md").read_text().startswith("# Skipping")
