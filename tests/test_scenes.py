"""Scenes: shipped ones validate, malformed ones are named; the run directory reads back."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

from fricfem import load_scene
from fricfem.output import quantities
from fricfem import scene as scenes
from fricfem import runner
from fricfem.scene import SceneError
from rankcheck import serial_env


@pytest.mark.parametrize("name", sorted(scenes.shipped()))
def test_shipped_scene_validates(name):
    scene = load_scene(name)
    assert scene.name == name
    assert scene.t_end > 0 and scene.sigma0 > 0


def test_every_scene_key_is_listed():
    """`fricfem scenes --keys` names every key of the schema with its default."""
    text = scenes.describe_keys()
    for section, fields in scenes.SCHEMA.items():
        for key, f in fields.items():
            name = f"{section}.{key}" if section else key
            assert f"\n{name} = {f.default!r}" in "\n" + text, name
    assert "loading.kind = 'velocity'" in text and "time.skip_quiet = True" in text


def test_paper_cases_carry_the_paper_loading():
    table = {"case1": (6e6, 2.0), "case2": (30e6, 2.0), "case3": (10e6, 20.0), "case4": (0.9e6, 10.0),
             "case5": (40e6, 2.0), "symmetric": (10e6, 5.0)}
    for name, (s, v) in table.items():
        scene = load_scene(name)
        assert (scene.sigma0, scene.pulse.v_imp) == (s, v)
    assert load_scene("case4").Cn == 3e10 and load_scene("case4").Cs == 1e10
    assert load_scene("case5").params["p"] == 0.5 and load_scene("case5").params["V1"] == 1.0
    assert load_scene("symmetric").symmetric


BAD = [
    ("[loading]\nsigma0 = -6e6", "loading.sigma0 = -6000000.0 Pa: must lie in [1, 1e+09]"),
    ("[loading]\nvimp = 2.0", "loading.vimp: unknown key"),
    ("[loading]\nv_imp = 'fast'", "loading.v_imp = 'fast': expected a number"),
    ("[material]\nrho = -1230.0", "material.rho = -1230.0 kg/m^3: must lie in [1, 100000]"),
    ("[material]\nnu = 0.5", "material.nu = 0.5 : must lie in (-1, 0.5)"),
    ("[material]\nplane = 'shell'", "material.plane = 'shell': allowed 'stress' or 'strain'"),
    ("[loading]\ndirection = 'sideways'", "loading.direction = 'sideways': allowed 'push' or 'pull'"),
    ("[time]\ndt_safety = 1.0", "time.dt_safety = 1.0 : must lie in (0, 1)"),
    ("[time]\nend = 0.0", "time.end = 0.0 s: must lie in (0, 1]"),
    ("[mesh]\nfine_x1 = 0.2", "the fine region must satisfy 0 <= fine_x0 < fine_x1 <= length"),
    ("[mesh]\npreset = 'huge'", "mesh.preset = 'huge': no such mesh; allowed: coarse, fine, half, reference, rupture_band"),
    ("[mesh]\ndx = 1e-7\ndy = 1e-7", "at most 5e6 are allowed"),
    ("[friction]\nlaw = 'coulomb'", "friction.law = 'coulomb': unknown friction law"),
    ("[friction.params]\nmu_s = -0.6", "friction.params.mu_s = -0.6: must lie in [0, 10000]"),
    ("[friction.params]\nmu_k = 0.5", "friction.params.mu_k: unknown parameter"),
    ("[[friction.regions]]\nx1_min = 0.05\nx1_max = 0.01", "friction.regions[0]: x1_min = 0.05 m must be < x1_max"),
    ("[[friction.regions]]\nx1_min = 0.0\nx1_max = 0.3", "friction.regions[0].x1_max = 0.3 m: must lie in [0, 0.137]"),
    ("[interface]\nCs = 0.0", "interface.Cs = 0.0 Pa/m: must lie in [1e+06, 1e+16]"),
    ("[output]\nfields = [50e-6]", "output.fields[0] = 5e-05 s: must lie in (0, 4e-05]"),
    ("[output]\nstations = { far = 0.5 }", "output.stations.far = 0.5 m: must lie in [0, 0.137]"),
    ("[output]\nenergy_every = 2.5", "output.energy_every = 2.5: expected a whole number"),
    ("sigma0 = 6e6", "sigma0: unknown key or section"),
    ("[loading\nsigma0 = 6e6", "is not valid TOML"),
    ("base = 'case9'", "base = 'case9': no such shipped scene"),
]


@pytest.mark.parametrize("text, message", BAD, ids=[m[:40] for _, m in BAD])
def test_malformed_scene_is_named(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(("base = 'case1'\n" if not text.startswith("base") else "") + text + "\n")
    with pytest.raises(SceneError) as err:
        load_scene(str(path))
    assert message in str(err.value), str(err.value)


def test_command_line_overrides_and_inheritance(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("base = 'case3'\nname = 'mine'\n[loading]\nv_imp = 7.0\n")
    scene = load_scene(str(path), ["loading.sigma0=16e6", "friction.params.gamma=1.0", "mesh.preset='coarse'"])
    assert (scene.name, scene.sigma0, scene.pulse.v_imp, scene.params["gamma"]) == ("mine", 16e6, 7.0, 1.0)
    assert scene.mesh.dx == 2.1e-3
    with pytest.raises(SceneError, match="expected <section.key>=<value>"):
        load_scene("case1", ["loading.sigma0"])


def _short_scene(*extra):
    return load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=10", "time.end=20e-6",
                                 "output.fields=[10e-6, 20e-6]", "output.interface_every=1e-6", *extra])


def test_run_directory_reads_back(comm, tmp_dir_shared):
    """interface.h5 reads with h5py; fields.xdmf with meshio/pyvista; summary says complete."""
    out = tmp_dir_shared / "run"
    summary = runner.run_scene(_short_scene(), out, comm, quiet=True)
    assert summary["complete"] and summary["steps"] > 0
    if comm.rank == 0:
        with h5py.File(out / "interface.h5", "r") as f:
            n = f.attrs["n_time"]
            assert n == len(f["time"]) and n >= 15
            assert f["slip_rate"].shape == (n, len(f["x1"]))
            for q in quantities.QUANTITIES:
                assert np.isfinite(f[q.name][:n]).all(), q.name
            st = f["stations/x16.1mm"]
            assert st.attrs["n"] == summary["steps"] and abs(st.attrs["x1"] - 16.1e-3) < 0.5e-3  # nearest Gauss point, coarse mesh
            assert set(f["state"]) == {"theta0", "theta1", "theta2"}
        data = json.loads((out / "summary.json").read_text())
        assert data["complete"] and data["dofs"] == summary["dofs"]
        # VTK's XDMF reader, in a process without dolfinx (whose HDF5 it would pick up)
        code = (
            "import json, sys, numpy as np, pyvista\n"
            "r = pyvista.get_reader(sys.argv[1]); r.set_active_time_value(r.time_values[-1]); b = r.read()\n"
            "b = b[0] if isinstance(b, pyvista.MultiBlock) else b  # one grid with every function\n"
            "s = b.cell_data['stress_difference']\n"
            "u = b\n"
            "print(json.dumps({'times': list(r.time_values), 'median_s': float(np.median(s)),"
            " 'bounds': list(u.bounds), 'max_u1': float(np.abs(u.point_data['displacement'][:, 0]).max())}))\n"
        )
        pytest.importorskip("pyvista")
        res = subprocess.run([sys.executable, "-c", code, str(out / "fields.xdmf")], capture_output=True,
                             text=True, env=serial_env())
        got = json.loads(res.stdout.strip().splitlines()[-1])
        assert len(got["times"]) == 2
        # σ1 − σ2 includes the prestress: Σ0 = 6 MPa far from the loading
        assert got["median_s"] == pytest.approx(6e6, rel=0.05)
        assert got["bounds"][:4] == pytest.approx([0.0, 0.137, -0.075, 0.075])
        assert 0 < got["max_u1"] < 1e-3


def test_non_empty_run_directory_is_kept(comm, tmp_dir_shared):
    out = tmp_dir_shared / "kept"
    if comm.rank == 0:
        out.mkdir()
        (out / "precious.txt").write_text("data")
    comm.Barrier()
    with pytest.raises(SceneError, match="directory is not empty; pass --overwrite"):
        runner.run_scene(_short_scene(), out, comm, quiet=True)
    assert (out / "precious.txt").read_text() == "data"


def test_sigterm_leaves_a_readable_interface_file(comm, tmp_dir_shared):
    """SIGTERM half-way: the run stops cleanly, interface.h5 holds what was recorded."""
    out = tmp_dir_shared / "killed"
    scene = _short_scene("output.flush_every=1e-3")

    def kill_at_step(st):
        if st.n == 30:
            os.kill(os.getpid(), signal.SIGTERM)

    summary = runner.run_scene(scene, out, comm, quiet=True, on_step=kill_at_step)
    assert summary["interrupted"] and not summary["complete"]
    assert 30 <= summary["steps"] < 40
    if comm.rank == 0:
        with h5py.File(out / "interface.h5", "r") as f:
            n = f.attrs["n_time"]
            assert n >= 3 and np.isfinite(f["slip_rate"][:n]).all()
            assert f["time"][n - 1] <= summary["t_s"] + 1e-12
        assert json.loads((out / "summary.json").read_text())["complete"] is False


def test_run_ends_when_the_tip_leaves_the_region_of_interest(comm, tmp_dir_shared):
    """time.stop_at_tip ends a run early (a sweep's question answered), complete and labelled."""
    scene = _short_scene("time.stop_at_tip=0.01", "output.fields=[]")
    summary = runner.run_scene(scene, tmp_dir_shared / "early", comm, quiet=True)
    assert summary["complete"] and summary["ended_early"].startswith("the sliding tip passed x1 = 10 mm")
    assert summary["t_s"] < scene.t_end
    assert summary["tip"]["x1_m"][-1] > 0.01
