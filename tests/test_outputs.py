"""What a run directory says (issue 15, items 3–5): units in every file, the energy
budget at the end time, per-step arrays in evidence.json, fields.xdmf read whole by
meshio and pyvista, and ``fricfem plot`` on a run killed or interrupted midway.

Under ``mpirun -n 2``: the runs are on both ranks; rank 0 reads.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, open_run, runner
from fricfem.model.build import build_model
from fricfem.output import quantities
from fricfem.output.record import EVIDENCE_FILE, read_evidence, read_summary
from fricfem.output.rundir import FieldReader
from fricfem.step import State, evolve
from fricfem.step.stepper import energies_at
from rankcheck import serial_env

RANK = MPI.COMM_WORLD.rank
SHORT = ["mesh.preset='coarse'", "loading.v_imp=10", "time.end=20e-6", "output.fields=[8e-6,16e-6]"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """case1 at 10 m/s on the coarse mesh to 20 µs, two field snapshots (both ranks)."""
    comm = MPI.COMM_WORLD
    out = comm.bcast(str(tmp_path_factory.mktemp("outputs")) if RANK == 0 else None, root=0)
    record = runner.run_scene(load_scene("case1", SHORT), out, comm, quiet=True)
    from pathlib import Path

    return Path(out), record


def test_units_in_every_file(run):
    out, record = run
    if RANK:
        return
    with h5py.File(out / "interface.h5", "r") as f:
        assert f.attrs["units"] == "SI"
        for q in quantities.QUANTITIES:
            assert f[q.name].attrs["unit"] == q.unit
        assert f["time"].attrs["unit"] == "s" and f["x1"].attrs["unit"] == "m"
        for k, u in quantities.ENERGY.items():
            assert f["energy"][k].attrs["unit"] == u
        st = f["stations/x16.1mm"]
        assert st["slip_rate"].attrs["unit"] == "m/s" and st["shear_traction"].attrs["unit"] == "Pa"
    for snapshot in sorted((out / "fields").glob("t*.h5")):
        with h5py.File(snapshot, "r") as f:
            for name, unit in quantities.FIELDS.items():
                assert all(d.attrs["unit"] == unit for d in f["Function"][name].values())
    summary = json.loads((out / "summary.json").read_text())
    assert summary["units"]["energy"].startswith("J/m") and summary["units"]["*_s"] == "s"
    assert open_run(out).units["shear_traction"] == "Pa"


def test_energy_is_reported_at_the_end_time(run, comm, tmp_dir_shared):
    """The summary's energy is at the run's end time t_s (the state after its last
    step), not at the last evaluation of the cadence (every 50 steps) nor at the
    last step's start, and equals what a run one step longer, evaluating every
    step, records at t_s; the balance closes there."""
    out, record = run
    e = record["energy"]
    assert e["at"] == "end"
    assert e["time_s"] == record["t_s"]
    assert abs(e["balance_error"]) <= 1e-9 * e["external"]
    history = open_run(out).energy["time"] if RANK == 0 else None
    if RANK == 0:
        assert history[-1] < e["time_s"] - 10 * record["dt_s"]  # the cadence stops well before the end
    longer = [k for k in SHORT if not k.startswith("time.end")] + [f"time.end={record['t_s'] + 1.5 * record['dt_s']!r}"]
    every = runner.run_scene(load_scene("case1", longer + ["output.energy_every=1", "output.fields=[]"]),
                             tmp_dir_shared / "every", comm, quiet=True)
    assert every["steps"] == record["steps"] + 1
    if RANK == 0:
        h = open_run(tmp_dir_shared / "every").energy
        assert h["time"][-1] == e["time_s"]  # the longer run's last row: t_s, the step it took from there
        for k in ("kinetic", "strain", "external", "dissipated"):
            assert e[k] == h[k][-1]  # the same step, taken and undone: the same bits


def test_the_end_energy_leaves_the_state_as_it_was(comm):
    """Taking the end energies (one more step, undone) leaves u, v, t, n and the
    interface points as a run without them: a run continued afterwards gives
    the same bits as one never stopped to take them."""
    _, model = build_model(load_scene("case1", SHORT), comm)
    a, b = State(model), State(model)
    for _ in evolve(model, a, 60 * model.dt):
        pass
    for _ in evolve(model, b, 40 * model.dt):
        pass
    e = energies_at(model, b)
    assert e["time"] == b.t and b.n == 40
    for _ in evolve(model, b, 60 * model.dt):
        pass
    assert b.n == a.n and b.t == a.t
    assert np.array_equal(a.u.array_r, b.u.array_r) and np.array_equal(a.v.array_r, b.v.array_r)
    for field in a.points.evolving:
        x, y = np.asarray(getattr(a.points, field)), np.asarray(getattr(b.points, field))
        assert x.tobytes() == y.tobytes(), field


def test_per_step_arrays_live_in_the_evidence_file(run):
    out, record = run
    if RANK:
        return
    summary = json.loads((out / "summary.json").read_text())
    evidence = read_evidence(out)

    def longest(o):
        if isinstance(o, dict):
            return max([longest(v) for v in o.values()] + [0])
        if isinstance(o, list):
            return max([len(o)] + [longest(v) for v in o])
        return 0

    assert longest({k: v for k, v in summary.items() if k != "input"}) <= 8
    assert summary["evidence"] == EVIDENCE_FILE and len(evidence["tip"]["time_s"]) > 20
    assert summary["tip"]["last_x1_m"] == evidence["tip"]["x1_m"][-1]
    merged = read_summary(out)
    assert merged["tip"]["x1_m"] == evidence["tip"]["x1_m"] and "history" in merged["mode"]["evidence"]
    assert merged == json.loads(json.dumps(record))  # run_scene returns what read_summary reads


def test_meshio_reads_every_field(run):
    """meshio's TimeSeriesReader: every function at every snapshot, the values written."""
    meshio = pytest.importorskip("meshio")
    out, _ = run
    if RANK:
        return
    with meshio.xdmf.TimeSeriesReader(str(out / "fields.xdmf")) as reader:
        points, cells = reader.read_points_cells()
        got = [reader.read_data(k) for k in range(reader.num_steps)]
    assert len(got) == 2 and cells[0].type == "triangle"
    for name in quantities.FIELDS:
        ours = FieldReader(out / "fields.xdmf", name)
        assert np.allclose([t for t, _, _ in got], ours.times, rtol=0, atol=0)
        for k, (t, point_data, cell_data) in enumerate(got):
            data = point_data[name] if name in point_data else cell_data[name][0]
            assert np.array_equal(np.asarray(data).reshape(ours.values(k).shape), ours.values(k))
    assert len(points) == len(got[0][1]["displacement"])


def test_pyvista_reads_every_field(run):
    """VTK's XDMF reader (pyvista), in a process without dolfinx: every function at each time."""
    pytest.importorskip("pyvista")
    out, _ = run
    if RANK:
        return
    code = ("import json, sys, numpy as np, pyvista\n"
            "r = pyvista.get_reader(sys.argv[1]); res = []\n"
            "for t in r.time_values:\n"
            "    r.set_active_time_value(t); g = r.read()\n"
            "    g = g[0] if isinstance(g, pyvista.MultiBlock) else g\n"
            "    res.append({'t': t, 'points': sorted(g.point_data.keys()), 'cells': sorted(g.cell_data.keys()),"
            " 'u_max': float(np.abs(g.point_data['displacement']).max()),"
            " 's_median': float(np.median(g.cell_data['stress_difference']))})\n"
            "print(json.dumps(res))\n")
    env = serial_env()
    res = subprocess.run([sys.executable, "-c", code, str(out / "fields.xdmf")], capture_output=True, text=True,
                         env=env, timeout=120)
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert [g["t"] for g in got] == pytest.approx(list(FieldReader(out / "fields.xdmf").times))
    for g, k in zip(got, range(2)):
        assert g["points"] == ["displacement", "stress_difference_nodal", "velocity"]  # σ1 − σ2 also at the nodes
        assert g["cells"] == ["stress_difference"]
        u = FieldReader(out / "fields.xdmf", "displacement").values(k)
        assert g["u_max"] == pytest.approx(float(np.abs(u).max()))
        assert g["s_median"] == pytest.approx(6e6, rel=0.1)  # σ1 − σ2 with the prestress Σ0 = 6 MPa


def test_plot_of_a_killed_run(comm, tmp_dir_shared):
    """The files as a SIGKILL at step 25 leaves them (copied while the run holds them
    open: what is on disk then is all a kill leaves) — before any field snapshot —
    read and plot: summary.json says incomplete, interface.h5 has the flushed rows,
    ``fricfem plot`` exits 0 without the isochromatics."""
    out, frozen = tmp_dir_shared / "live", tmp_dir_shared / "killed"

    def freeze(state):
        if state.n == 25 and RANK == 0:
            shutil.copytree(out, frozen)

    runner.run_scene(load_scene("case1", SHORT), out, comm, quiet=True, on_step=freeze)
    if RANK:
        return
    summary = json.loads((frozen / "summary.json").read_text())
    assert summary["complete"] is False and "mode" not in summary
    run = open_run(frozen)
    assert len(run.t) == 20  # a flush every 10 rows (a row every step on this mesh)
    assert np.array_equal(run.slip_rate, open_run(out).slip_rate[:len(run.t)])
    assert not (frozen / "fields.xdmf").exists()
    from fricfem.plot import run as plot_run

    assert plot_run.main([str(frozen)]) == 0
    names = {p.name for p in (frozen / "plots").iterdir()}
    assert "spacetime.png" in names and not any(n.startswith("isochromatics") for n in names)


def test_an_interrupted_run_says_its_mode_is_unknown(comm, tmp_dir_shared):
    """SIGTERM at step 45: the run stops cleanly, complete false, mode "unknown" (with
    what the classifier saw so far as partial_label), interface.h5 trimmed to its rows."""
    def term(state):
        if state.n == 45:
            os.kill(os.getpid(), signal.SIGTERM)

    out = tmp_dir_shared / "term"
    record = runner.run_scene(load_scene("case1", SHORT), out, comm, quiet=True, on_step=term)
    assert record["interrupted"] and not record["complete"]
    assert record["mode"]["label"] == "unknown" and "interrupted at t = " in record["mode"]["reason"]
    assert record["mode"]["partial_label"] in ("none", "crack-like", "pulse", "pulse-train", "mixed")
    if RANK == 0:
        with h5py.File(out / "interface.h5", "r") as f:
            assert len(f["time"]) == record["steps"] and np.isfinite(f["time"][:]).all()
        assert len(FieldReader(out / "fields.xdmf").times) == 1  # 8 µs written, 16 µs not reached


@pytest.mark.parametrize("ended", ["at its end", "early"])
def test_a_finished_interface_file_holds_exactly_its_rows(comm, tmp_dir_shared, ended):
    """When a run ends, interface.h5 holds exactly the rows it computed, counted in
    ``n_time`` and each group's ``n``, no NaN row, every value as the run recorded it:
    a run that reached time.end (its laid-out file copied as it is, the counts
    added) and one the tip stopped early (its rows copied into a smaller file)."""
    sets = ["mesh.preset='coarse'", "output.fields=[]", "loading.v_imp=40", "time.end=16e-6",
            "output.energy_every=7"] + (["time.stop_at_tip=0.005"] if ended == "early" else [])
    seen = []
    out = tmp_dir_shared / f"finished_{ended.replace(' ', '_')}"
    s = runner.run_scene(load_scene("case1", sets), out, comm, quiet=True,
                         on_step=lambda st: seen.append(st.n))
    assert s["complete"] and (s["ended_early"] is not None) == (ended == "early")
    if comm.rank == 0:
        with h5py.File(out / quantities.INTERFACE_FILE, "r") as f:
            n = int(f.attrs["n_time"])
            assert n == f["time"].shape[0] == f["slip_rate"].shape[0] > 0
            assert np.isfinite(f["time"][...]).all() and np.isfinite(f["slip_rate"][...]).all()
            for name, g in f["stations"].items():
                assert g.attrs["n"] == g["time"].shape[0] == s["steps"] and np.isfinite(g["time"][...]).all()
            assert f["energy"].attrs["n"] == f["energy/time"].shape[0] == (s["steps"] - 1) // 7 + 1
            assert np.all(np.diff(f["time"][...]) > 0)
        run = open_run(out)
        assert len(run.t) == n and np.array_equal(run.slip_rate, run.quantity("slip_rate"))


def test_mu_app_is_the_masked_division():
    """mu_app = T_s/T_n where T_n > 0, else 0: the same bits as NumPy's masked division
    (NaN and zero normal tractions included)."""
    from types import SimpleNamespace

    from fricfem.output.quantities import BY_NAME

    rng = np.random.default_rng(0)
    for _ in range(50):
        Tn, Ts = rng.normal(size=300) * 1e6, rng.normal(size=300) * 1e6
        Tn[::7], Tn[::11], Ts[::13] = 0.0, np.nan, np.nan
        got = BY_NAME["mu_app"].read(SimpleNamespace(Ts=Ts, Tn=Tn))
        assert got.tobytes() == np.divide(Ts, Tn, out=np.zeros_like(Ts), where=Tn > 0).tobytes()


@pytest.mark.parametrize("moduli", ["uniform", "per cell"])
def test_compiled_stress_is_dolfinx_interpolating_the_ufl_stress(moduli):
    """The field output's σ1 − σ2 per cell (kernels.stress, a numba loop) is what
    dolfinx gives interpolating the UFL expression into DG0 (prestress and τ0
    included; moduli uniform, or a DG0 function as the experiment's steel parts
    have them), to round-off, on a distorted mesh with a random displacement."""
    from types import SimpleNamespace

    from dolfinx import fem, mesh

    from fricfem import compat
    from fricfem.output.fields import cell_stress, stress_difference_ufl, stress_inputs

    msh = mesh.create_rectangle(MPI.COMM_SELF, [np.array([0.0, 0.0]), np.array([2e-2, 1e-2])], [13, 7])
    x = msh.geometry.x
    x[:, 0] += 1e-3 * np.sin(300.0 * x[:, 1])  # not a structured grid: every cell its own Jacobian
    V = compat.function_space(msh, "Lagrange", 1, (2,))
    W = compat.function_space(msh, "DG", 0)
    u = fem.Function(V)
    u.x.array[:] = np.random.default_rng(1).normal(size=u.x.array.size) * 1e-6
    if moduli == "uniform":
        mat = SimpleNamespace(mu=2.1e9, lmbda=1.3e9)
    else:
        mat = SimpleNamespace(mu=fem.Function(W), lmbda=fem.Function(W))
        mat.mu.interpolate(lambda p: np.where(p[0] < 1e-2, 80e9, 2.1e9))
        mat.lmbda.interpolate(lambda p: np.where(p[1] < 5e-3, 1.3e9, 110e9))
    sigma0, tau0 = 7e6, 1.5e6
    ref = fem.Function(W)
    ref.interpolate(fem.Expression(stress_difference_ufl(u, mat, sigma0, tau0), compat.interpolation_points(W)))
    n = msh.topology.index_map(2).size_local
    out = cell_stress(stress_inputs(V, mat, sigma0, tau0, n), u.x.array)
    expected = ref.x.array[compat.cell_dofs(W.dofmap)[:n]]
    assert np.ptp(expected) > 0.1 * np.max(expected)  # the cells differ: a real comparison
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=0.0)
