"""What a researcher uses around a run: ``fricfem show`` (a scene as TOML that
loads back to the same Scene), ``fricfem export`` (station time series in the
SCEC code-verification ASCII format and CSV), ``fricfem compare`` (two runs,
one line per station) and ``fricfem plot`` on a sweep directory.

Every rank works in its own directory (no collectives)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import cli
from fricfem import scene as scene_mod


def _own(tmp_path: Path) -> Path:
    d = tmp_path / f"rank{MPI.COMM_WORLD.rank}"
    d.mkdir(parents=True, exist_ok=True)
    return d


@pytest.mark.parametrize("name", sorted(scene_mod.shipped()))
def test_show_loads_back_to_the_same_scene(name, tmp_path, capsys):
    """show → file → load gives the Scene that loading the shipped name gives, for every shipped scene
    (base chains, inline tables, lists of tables, quoted station names, floats to the last bit)."""
    overrides = ["time.dt_safety=0.51234567890123456", "output.stations={\"x16.1mm\"=0.0161, b=3e-2}"]
    assert cli.main(["show", name, "--set", overrides[0], "--set", overrides[1]]) == 0
    text = capsys.readouterr().out
    path = _own(tmp_path) / "shown.toml"
    path.write_text(text)
    shown = scene_mod.load(str(path))
    assert shown == scene_mod.load(name, overrides)
    assert shown.dt_safety == 0.51234567890123456
    assert text.startswith(f"# fricfem show {name}")


def test_show_follows_the_base_chain_and_refuses_bad_input(tmp_path, capsys):
    """A user's scene with base = "case3": every key of case3 and case1 is printed, the user's
    override wins, and the header names the chain; a bad value is one error line, exit 2."""
    d = _own(tmp_path)
    (d / "mine.toml").write_text('base = "case3"\nname = "mine"\n[loading]\nv_imp = 7.5\n')
    assert cli.main(["show", str(d / "mine.toml")]) == 0
    text = capsys.readouterr().out
    assert "case3.toml <- " in text and "case1.toml" in text
    assert "v_imp = 7.5" in text and "sigma0 = 10000000.0" in text and "t_rise = 1e-05" in text
    (d / "back.toml").write_text(text)
    assert scene_mod.load(str(d / "back.toml")) == scene_mod.load(str(d / "mine.toml"))
    assert cli.main(["show", "case1", "--set", "loading.sigma0=-1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "loading.sigma0" in err and "Pa" in err
