"""The REPRODUCTION.md demos ``demos/mesh_convergence.py`` and ``demos/paper/rate_tangent.py``
run end to end in a smoke setting (coarse meshes, cut short), on every rank
as under ``mpirun``; rank 0 writes the JSON and the figures."""

from __future__ import annotations

import json
import runpy
import sys
from pathlib import Path

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def run_demo(name: str, argv: list) -> None:
    saved = sys.argv
    sys.argv = [str(DEMOS / name), *argv]
    try:
        runpy.run_path(str(DEMOS / name), run_name="__main__")
    finally:
        sys.argv = saved


def test_mesh_convergence_smoke(tmp_dir_shared, comm):
    out = tmp_dir_shared / "out"
    run_demo("mesh_convergence.py", ["--cases", "case1_v10", "--presets", "coarse", "reference", "--t-end", "20e-6",
                                     "--work", str(tmp_dir_shared / "runs"), "--out", str(out)])
    comm.Barrier()
    doc = json.loads((out / "mesh_convergence.json").read_text())
    rows = doc["problems"]["case1_v10"]["rows"]
    assert rows["reference"]["station_rms_over_peak"] == 0.0  # the finest mesh given is the reference
    assert rows["coarse"]["mode"] == rows["reference"]["mode"] == "crack-like"
    assert 0.0 < rows["coarse"]["tip_max_diff_mm"] < 5.0
    assert (out / "mesh_convergence_case1_v10.png").stat().st_size > 10_000


def test_rate_tangent_smoke(tmp_dir_shared, comm):
    """Case III on the coarse mesh: the converged law slides, the plain update is stopped by the watchdog."""
    out = tmp_dir_shared / "out"
    run_demo("paper/rate_tangent.py", ["--scenes", "case3", "--v-scales", "1", "--preset", "coarse", "--t-end", "12e-6",
                                 "--work", str(tmp_dir_shared / "runs"), "--out", str(out)])
    comm.Barrier()
    runs = {r["law"]: r for r in json.loads((out / "rate_tangent.json").read_text())["runs"]}
    assert runs["povirk_needleman"]["initiation_us"] is not None and runs["povirk_needleman"]["watchdog"] is None
    plain = runs["povirk_needleman_rate_tangent"]
    assert plain["mode"] == "diverged" and "watchdog stopped the run" in plain["watchdog"]
    assert (out / "rate_tangent.png").stat().st_size > 10_000
