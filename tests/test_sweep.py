"""``fricfem sweep``: a small mode map runs in parallel over points, resumes, and refuses bad input early.

Run under ``mpirun -n 2``: every test calls ``sweep.main`` on every rank
(in-process, on MPI.COMM_WORLD), with one output directory shared by the ranks.
The runs use the coarse mesh and 15 µs, ~0.5 s each.
"""

from __future__ import annotations

import json
import os

import pytest

from fricfem import sweep
from pathlib import Path

from fricfem import analysis, batch
from fricfem.analysis import modemap

QUICK = ["--preset", "coarse", "--set", "time.end=15e-6", "--quiet"]


def _summaries(root):
    """{point key: (mtime_ns, wall_s total)} of every point's summary.json under ``root``."""
    out = {}
    for d in sorted((root / "points").iterdir()):
        path = d / "summary.json"
        out[d.name] = (os.stat(path).st_mtime_ns, json.loads(path.read_text())["wall_s"]["total"])
    return out


def _modemap(root):
    return json.loads((root / "modemap.json").read_text())


def test_small_map_runs_then_resumes(tmp_dir_shared, comm, capsys):
    out = tmp_dir_shared / "map"
    argv = ["case1", "--sigma0", "6,30", "--v-imp", "2,20", *QUICK, "--out", str(out)]
    assert sweep.main(argv) == 0
    comm.barrier()
    doc = _modemap(out)
    assert (out / "modemap.png").stat().st_size > 0
    assert doc["grid"] == {"sigma0_MPa": [6.0, 30.0], "v_imp_m_s": [2.0, 20.0]}
    assert sorted(doc["computed"]) == ["s30_v2", "s30_v20", "s6_v2", "s6_v20"] and doc["reused"] == []
    assert doc["ranks"] == comm.size
    labels = doc["labels"]["values"]
    assert len(labels) == 2 and all(len(row) == 2 for row in labels)
    for p in doc["points"]:
        assert p["complete"] and p["label"] in analysis.LABELS
        assert f"loading.sigma0={p['sigma0_MPa'] * 1e6!r}" in p["overrides"]
        assert "time.end=15e-6" in p["overrides"] and "output.fields=[]" in p["overrides"]
        assert p["wall_s"] > 0 and p["peak_slip_rate_m_s"] >= 0
        assert (p["initiation"] is None) == (p["label"] == "none")
        summary = json.loads((out / p["dir"] / "summary.json").read_text())
        assert summary["ranks"] == 1  # each point ran on COMM_SELF
        assert summary["input"]["loading"]["v_imp"] == p["v_imp_m_s"]
        assert not (out / p["dir"] / "fields.xdmf").exists()
    if comm.rank == 0:
        printed = capsys.readouterr().out
        assert "V_imp \\ Σ0" in printed and "total wall time" in printed
    before = _summaries(out)
    comm.barrier()

    # the same command again: nothing is recomputed
    assert sweep.main(argv) == 0
    comm.barrier()
    doc2 = _modemap(out)
    assert doc2["computed"] == [] and sorted(doc2["reused"]) == sorted(doc["computed"])
    assert _summaries(out) == before
    assert doc2["labels"] == doc["labels"]
    assert [c["computed"] for c in doc2["calls"]] == [4, 0]
    comm.barrier()

    # an incomplete point (a killed run) is rerun, alone
    if comm.rank == 0:
        path = out / "points" / "s6_v2" / "summary.json"
        s = json.loads(path.read_text())
        s["complete"] = False
        path.write_text(json.dumps(s))
    comm.barrier()
    assert sweep.main(argv) == 0
    comm.barrier()
    doc3 = _modemap(out)
    assert doc3["computed"] == ["s6_v2"]
    after = _summaries(out)
    assert after["s6_v2"] != before["s6_v2"]
    assert {k: v for k, v in after.items() if k != "s6_v2"} == {k: v for k, v in before.items() if k != "s6_v2"}


@pytest.mark.parametrize("extra, message", [
    (["--set", "loading.t_rise=-1e-6"], "loading.t_rise = -1e-06 s: must lie in (0, 1]"),
    (["--set", "interface.Cx=1e11"], "interface.Cx: unknown key"),
    (["--set", "loading.v_imp=5"], "loading.v_imp is set by the sweep itself"),
    (["--set", "time.end"], "expected <section.key>=<value>"),
    (["--sigma0", "6,-2"], "--sigma0: -2 MPa must be a positive number"),
    (["--v-imp", "2,fast"], "'fast' is not a number [m/s]"),
    (["--sigma0", "2000"], "loading.sigma0 = 2000000000.0 Pa: must lie in [1, 1e+09]"),
])
def test_bad_input_is_refused_before_any_run(tmp_dir_shared, comm, capsys, extra, message):
    out = tmp_dir_shared / "bad"
    argv = ["case1", "--sigma0", "6", "--v-imp", "2", *QUICK, "--out", str(out)]
    # later occurrences win for --sigma0 / --v-imp; --set items add up
    assert sweep.main(argv + extra) == 2
    comm.barrier()
    assert not out.exists()  # nothing was run, not even a directory made
    if comm.rank == 0:
        err = capsys.readouterr().err
        assert err.startswith("fricfem sweep: error: ") and message in err, err
        assert err.count("\n") == 1  # one line


def test_changed_inputs_are_not_mixed_into_a_map(tmp_dir_shared, comm, capsys):
    out = tmp_dir_shared / "map"
    argv = ["case1", "--sigma0", "6", "--v-imp", "20", "--preset", "coarse", "--quiet", "--out", str(out)]
    assert sweep.main(argv + ["--set", "time.end=10e-6"]) == 0
    comm.barrier()
    before = _summaries(out)
    assert sweep.main(argv + ["--set", "time.end=12e-6"]) == 2
    comm.barrier()
    assert _summaries(out) == before
    if comm.rank == 0:
        assert "complete run with other inputs (time.end: 1e-05 (stored) vs 1.2e-05 (now))" in capsys.readouterr().err
    assert sweep.main(argv + ["--set", "time.end=12e-6", "--overwrite"]) == 0
    comm.barrier()
    assert _modemap(out)["computed"] == ["s6_v20"]


def test_variants_write_sub_maps_and_a_combined_figure(tmp_dir_shared, comm):
    out = tmp_dir_shared / "variants"
    argv = ["case1", "--sigma0", "6", "--v-imp", "20", *QUICK, "--variants", "--label", "quick", "--out", str(out)]
    assert sweep.main(argv) == 0
    comm.barrier()
    main = _modemap(out)
    assert main["title"] == "quick" and main["interface_factor"] == 1.0
    for name, factor in sweep.VARIANTS.items():
        doc = _modemap(out / name)
        assert doc["interface_factor"] == factor
        assert doc["Cn_Pa_m"] == pytest.approx(main["Cn_Pa_m"] * factor)
        assert doc["Cs_Pa_m"] == pytest.approx(main["Cs_Pa_m"] * factor)
        assert f"interface.Cn={doc['Cn_Pa_m']!r}" in doc["points"][0]["overrides"]
        assert (out / name / "modemap.png").exists()
    assert (out / "modemap_variants.png").stat().st_size > 0


def test_boundary_between_crack_and_pulse_columns():
    s, v = [2.0, 10.0, 30.0, 40.0], [1.0, 4.0, 16.0]
    labels = [
        ["crack-like", "crack-like", "pulse-train"],  # change between 4 and 16: at 8
        ["crack-like", "mixed", "pulse-train"],       # on the mixed point
        ["none", "pulse", "pulse"],                   # one class: no point
        ["none", "crack-like", None],                 # one class: no point
    ]
    assert modemap.boundary(s, v, labels) == [(2.0, 8.0), (10.0, 4.0)]


def test_deal_is_round_robin_heaviest_first():
    jobs = [batch.Job(f"v{v}", Path("."), None, cost=float(v)) for v in range(5)]
    groups = batch.deal(jobs, 2)
    assert [j.cost for j in groups[0]] == [4.0, 2.0, 0.0] and [j.cost for j in groups[1]] == [3.0, 1.0]


def test_default_grid_is_the_papers_span():
    assert len(sweep.DEFAULT_SIGMA0_MPA) == len(sweep.DEFAULT_V_IMP) == 8
    assert (min(sweep.DEFAULT_SIGMA0_MPA), max(sweep.DEFAULT_SIGMA0_MPA)) == (0.9, 40.0)
    assert (min(sweep.DEFAULT_V_IMP), max(sweep.DEFAULT_V_IMP)) == (1.0, 40.0)
