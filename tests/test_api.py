"""The documented Python API (docs/api.md): the tour demo runs as written (coarse
mesh), its arrays are the run directory's, a user's law registered at run time
is the one that runs, and a law off the contract is refused with a clear message."""

import json
import re
import runpy
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from userlaws import coulomb_advance, coulomb_rigid

import fricfem
from fricfem import friction
from fricfem.friction import Law, Param

ROOT = Path(__file__).resolve().parents[1]


def test_api_tour_demo(comm, tmp_dir_shared, clean_laws, monkeypatch):
    out = tmp_dir_shared / "tour"
    monkeypatch.setattr(sys, "argv", ["api_tour.py", "--mesh", "coarse", "--out", str(out)])
    ns = runpy.run_path(str(ROOT / "demos" / "api_tour.py"), run_name="__main__")
    run = fricfem.open_run(out / "case1_v10")
    # the plotted profiles are the stored rows nearest to the chosen times
    for t, rate in ns["profiles"].items():
        k = int(np.argmin(np.abs(run.t - t)))
        assert np.array_equal(rate, run.slip_rate[k]) and run.at(t) == k
    assert run.units["slip_rate"] == "m/s" and run.units["t"] == "s" and run.units["x1"] == "m"
    assert run.gauges.names == ("SG",) and run.gauges.units["stress_difference"] == "Pa"
    assert len(run.gauges["SG"].time) == run.summary["steps"] + 1
    # the registered law is the one the run used: wherever it slides, |T_s| = μ T_n
    assert friction.LAWS["coulomb"].name == "coulomb"
    mine = fricfem.open_run(out / "case1_v10_coulomb")
    assert mine.summary["input"]["friction"]["law"] == "coulomb"
    _coulomb_holds(mine, 0.5, min_sliding=100, rtol=1e-12)
    if comm.rank == 0:
        result = json.loads((out / "api_tour.json").read_text())
        assert result["coulomb_mu_0.5"]["sliding_Ts_over_Tn"] == pytest.approx([0.5, 0.5], rel=1e-12)
        assert (out / "slip_rate_and_gauge.png").stat().st_size > 10_000
    # the user law's part of the demo is under 30 lines (from its import to its registration)
    text = (ROOT / "demos" / "api_tour.py").read_text().splitlines()
    start = next(i for i, line in enumerate(text) if line.startswith("from fricfem.friction import Law"))
    end = next(i for i, line in enumerate(text) if line.startswith("fricfem.register_law("))
    assert end - start + 1 < 30


def _coulomb_holds(run, mu: float, min_sliding: int, rtol: float) -> None:
    """Coulomb's law in a run's records: |T_s| = μ T_n wherever the interface slides
    (at ``min_sliding`` samples at least), |T_s| <= μ T_n where it sticks."""
    sliding = run.slip_rate > 0
    assert sliding.sum() > min_sliding
    ratio = np.abs(run.shear_traction[sliding]) / run.normal_traction[sliding]
    assert np.allclose(ratio, mu, rtol=rtol, atol=0)
    assert np.all(np.abs(run.shear_traction[~sliding]) <= mu * run.normal_traction[~sliding] * (1 + rtol))


@numba.njit
def _stick(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    return Ts + Cs * vs * dt, 0.0, 0.0, 0.0, 1


@numba.njit
def _bad_tuple(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    return Ts, 0.0


@numba.njit
def _negative_slip(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    return Ts, -1.0, 0.0, 0.0, 1


@numba.njit
def _mu(p, v):
    return 0.5


def _law(**kw):
    base = dict(name="user_law", doc="test law", params=(Param("mu", 0.5, "", 0.0, 1.0, "coefficient"),),
                state=(), advance=_stick, steady_mu=_mu, initial_state=lambda p, Tn0, Ts0: np.zeros(0))
    return Law(**{**base, **kw})


@pytest.mark.parametrize("kw, message", [
    ({"name": "povirk_needleman"}, r"register_law\('povirk_needleman'\): a law of that name is registered already"),
    ({"name": "a law"}, r"name 'a law' must be a Python identifier"),
    ({"advance": _stick.py_func}, r"\.advance: must be a numba function"),
    ({"params": (Param("mu", 2.0, "", 0.0, 1.0, "x"),)}, r"params.mu: default 2.0 must lie in its finite range"),
    ({"params": (Param("mu", 0.5, "", 0.0, 1.0, "x"),) * 2}, r"'mu' must be a unique Python identifier"),
    ({"state": ("theta",)}, r"initial_state returned shape \(0,\); the law declares 1 state variable"),
    ({"advance": _bad_tuple}, r"advance must return \(Ts1, slip_rate, dslip, dwork, nsub\)"),
    ({"advance": _negative_slip}, r"every output finite, slip rate, slip and work >= 0"),
])
def test_register_law_refuses_a_law_off_the_contract(kw, message, clean_laws):
    with pytest.raises(ValueError, match=message):
        fricfem.register_law(_law(**kw))
    assert "user_law" not in friction.LAWS


def test_registered_law_is_a_scene_key(clean_laws):
    fricfem.register_law(_law())
    scene = fricfem.load_scene("case1", ["friction.law='user_law'", "friction.params.mu=0.25"])
    assert scene.params == {"mu": 0.25}
    with pytest.raises(fricfem.scene.SceneError, match=r"friction.params.mu = 3: must lie in \[0, 1\]"):
        fricfem.load_scene("case1", ["friction.law='user_law'", "friction.params.mu=3"])
    with pytest.raises(ValueError, match="registered already; pass replace=True"):
        fricfem.register_law(_law())
    assert fricfem.register_law(_law(doc="again"), replace=True).doc == "again"
    assert "friction.params.mu = 0.5" in fricfem.scene.describe_keys()


def test_every_call_docs_api_names_exists():
    """Each ``fricfem.<name>`` docs/api.md writes as code resolves (a renamed call fails here)."""
    text = (ROOT / "docs" / "api.md").read_text()
    names = sorted(set(re.findall(r"`[^`]*?\b(fricfem(?:\.[A-Za-z_][A-Za-z0-9_]*)+)", text)))
    assert len(names) >= 8
    missing = []
    for dotted in names:
        parts = dotted.split(".")
        obj, k = None, len(parts)
        while k > 0:  # the longest importable module, then attributes
            try:
                obj = __import__(".".join(parts[:k]), fromlist=["_"])
                break
            except ImportError:
                k -= 1
        for attr in parts[k:]:
            obj = getattr(obj, attr, None)
        if obj is None:
            missing.append(dotted)
    assert not missing, f"docs/api.md names what does not exist: {missing}"


@numba.njit
def _rigid_nan(p, s, T_stick, Z, Tn0, Tn1, dt):
    return np.nan, 0.0, 0.0, 0.0, 1


def test_registered_law_with_a_rigid_verb_runs_on_split_nodes(comm, tmp_dir_shared, clean_laws):
    """A user's law that gives the optional ``rigid`` verb runs with interface.kind = 'rigid'
    (its split-node kernel compiled for it), and the law holds at every sliding pair;
    one without it is refused before anything is built; a broken verb is refused at registration."""
    with pytest.raises(ValueError, match=r"rigid returned .*every output finite"):
        fricfem.register_law(_law(name="coulomb_r", advance=coulomb_advance, rigid=_rigid_nan))
    fricfem.register_law(_law(name="no_rigid", advance=coulomb_advance))
    with pytest.raises(fricfem.scene.SceneError, match=r"law 'no_rigid' has no rigid \(split-node\) form"):
        fricfem.load_scene("case1", ["friction.law='no_rigid'", "interface.kind='rigid'"])
    fricfem.register_law(_law(name="coulomb_r", advance=coulomb_advance, rigid=coulomb_rigid))
    scene = fricfem.load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=20.0", "time.end=25e-6",
                                         "output.fields=[]", "interface.kind='rigid'",
                                         "friction.law='coulomb_r'", "friction.params.mu=0.3"])
    fricfem.run(scene, tmp_dir_shared / "rigid_user", overwrite=True)
    run = fricfem.open_run(tmp_dir_shared / "rigid_user")
    assert run.summary["input"]["interface"]["kind"] == "rigid"
    _coulomb_holds(run, 0.3, min_sliding=50, rtol=1e-9)
