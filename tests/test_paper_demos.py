"""The paper-figure demos of ``demos/paper/`` run end to end in a smoke setting.

Each demo is imported and its ``main(argv)`` called on every rank (the runs
are collective; rank 0 draws and writes ``numbers.json``), on the coarse mesh
and cut short at 20 µs, all sharing one output directory so that later demos
reuse the runs of earlier ones, as ``run_all.py`` does.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest

from fricfem import load_scene

PAPER = Path(__file__).resolve().parents[1] / "demos" / "paper"  # on pytest's pythonpath (pyproject.toml)

SMOKE = ["--preset", "coarse", "--t-end", "20e-6", "--quiet"]


def demo(name):
    return importlib.import_module(name)


def run_demo(name, out: Path, extra=()):
    return demo(name).main(SMOKE + ["--out", str(out / name), "--runs", str(out / "runs"), *extra])


def check_outputs(out: Path, name: str, data: dict, n_png: int) -> None:
    written = json.loads((out / name / "numbers.json").read_text())
    assert written == data  # every rank got rank 0's report back
    assert written["reading"]["preset"] == "coarse"
    assert written["numbers"] and all({"quantity", "paper", "fricfem"} <= set(r) for r in written["numbers"])
    pngs = sorted((out / name).glob("*.png"))
    assert len(pngs) >= n_png, pngs
    assert all(p.stat().st_size > 10_000 for p in pngs)
    assert sorted(written["figures"]) == sorted(str(p) for p in pngs)


def test_scene_options():
    """--preset, --direction, --v-scale, --set and --t-end reach the scene; the paper's snapshots are added."""
    common = demo("_common")
    args = common.options("x", "", ["--preset", "coarse", "--direction", "pull", "--v-scale", "2.5",
                                    "--set", "loading.sigma0=7e6", "--t-end", "33e-6"])
    sc = common.scene("case5", args)
    assert sc.mesh == load_scene("case1", ["mesh.preset='coarse'"]).mesh
    assert sc.pulse.direction == "pull" and sc.pulse.v_imp == pytest.approx(5.0)
    assert sc.sigma0 == 7e6 and sc.t_end == pytest.approx(33e-6)
    assert sc.output["fields"] == [32e-6]  # 38 and 44.6 µs lie past the end
    assert common.reading_tag(args).startswith("pull_v2.5_coarse_")
    assert common.scene("symmetric", args).t_end == pytest.approx(20e-6)  # never longer than the scene


def test_demos_smoke(tmp_dir_shared, comm):
    """fig07 (isochromatics), fig14 (two scenes), fig08_09 (reuses fig14's Case I run), fig21 (four stations)."""
    out = tmp_dir_shared
    data = run_demo("fig07_symmetric", out)
    check_outputs(out, "fig07_symmetric", data, n_png=2)
    rows = {r["quantity"]: r for r in data["numbers"]}
    assert rows["largest slip rate anywhere, any time (no sliding)"]["fricfem"] == 0.0
    assert 25.0 < rows["loading front along the interface at 16 µs"]["fricfem"] < 45.0

    data = run_demo("fig14_case1_vs_case3", out)
    check_outputs(out, "fig14_case1_vs_case3", data, n_png=1)
    assert set(data["runs"]) == {"case1", "case3"}

    summary = Path(data["runs"]["case1"]["dir"]) / "summary.json"
    before = summary.stat().st_mtime_ns
    data = run_demo("fig08_09_case1", out)
    check_outputs(out, "fig08_09_case1", data, n_png=2)  # interface distributions + isochromatics at 16 µs
    assert summary.stat().st_mtime_ns == before  # the finished run was reused

    data = run_demo("fig21_lineB", out)
    check_outputs(out, "fig21_lineB", data, n_png=1)
    assert [r["sigma0_MPa"] for r in data["runs"].values()] == [6.0, 10.0, 16.0, 30.0]
