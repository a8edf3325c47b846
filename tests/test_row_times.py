"""interface.h5 says when each quantity holds: a row's ``time`` is t^n, the
tractions' time; the rigid kind's slip rate is the step's V^{n+½} and its slip
δ^{n+1}, the elastic kind's jump rate the V^{n−½} of the step that ended at t^n.
Each dataset carries ``time_shift_s``, and ``time_of`` gives the times, so no
reader shifts anything of its own.  Checked by the scheme's own identity: the
rigid slip advances by the rate times dt between the times the file gives
(the rate's time is the midpoint of the two slips'), to round-off."""

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, runner
from fricfem.output.export import station_series
from fricfem.output.rundir import open_interface

RANK = MPI.COMM_WORLD.rank
SHORT = ["mesh.dx=0.4e-3", "mesh.dy=0.4e-3", "time.end=6e-6"]


@pytest.fixture(scope="module")
def rigid_run(tmp_path_factory):
    comm = MPI.COMM_WORLD
    out = comm.bcast(str(tmp_path_factory.mktemp("rowtimes")) if RANK == 0 else None, root=0)
    s = runner.run_scene(load_scene("tpv205_2d", SHORT), out, comm, quiet=True)
    return out, s["dt_s"]


def test_the_rigid_kinds_rates_and_slip_hold_where_the_file_says(rigid_run):
    out, dt = rigid_run
    if RANK:
        return
    with open_interface(out) as itf:
        assert itf.file["slip_rate"].attrs["time_shift_s"] == 0.5 * dt
        assert itf.file["slip"].attrs["time_shift_s"] == dt
        assert itf.file["shear_traction"].attrs["time_shift_s"] == 0.0
        states = list(itf.file["state"])
        assert states and [itf.file[f"state/{k}"].attrs["time_shift_s"] for k in states] == [dt] * len(states)
        assert np.array_equal(itf.time_of("slip"), itf.time + dt)
        s = max(itf.stations().values(), key=lambda s: s.data["slip"].max())
    assert s.data["slip"].max() > 1e-6  # it slid
    ts, tv = s.time_of("slip"), s.time_of("slip_rate")
    # δ(t_s[k+1]) − δ(t_s[k]) = V(t_v[k+1]) dt with t_v[k+1] the midpoint of t_s[k] and t_s[k+1]
    assert np.allclose(0.5 * (ts[1:] + ts[:-1]), tv[1:], rtol=0, atol=1e-18)
    assert np.max(np.abs(np.diff(s.data["slip"]) - s.data["slip_rate"][1:] * dt)) <= 1e-12 * s.data["slip"].max()
    # read at the row's own time (no shift), the slip would lead the rate by a step: the identity fails
    assert np.max(np.abs(np.diff(s.data["slip"]) - s.data["slip_rate"][:-1] * dt)) > 1e-3 * s.data["slip"].max()


def test_the_scec_export_has_every_column_at_the_rows_time(rigid_run):
    out, dt = rigid_run
    if RANK:
        return
    series = station_series(out)
    with open_interface(out) as itf:
        stations = itf.stations()
    for name, col in series.items():
        st = stations[name]
        assert np.array_equal(col["t"], st.time)
        # slip at t^n: the previous row's δ^{n}; the slip rate at t^n: the mean of V^{n∓½}
        np.testing.assert_allclose(col["slip"][1:], st.data["slip"][:-1], rtol=1e-12, atol=1e-20)
        np.testing.assert_allclose(col["slip_rate"][1:], 0.5 * (st.data["slip_rate"][1:] + st.data["slip_rate"][:-1]),
                                   rtol=1e-12, atol=1e-20)


def test_the_elastic_kinds_jump_rate_is_the_last_steps(comm, tmp_dir_shared):
    s = runner.run_scene(load_scene("tpv205_2d", SHORT + ["interface.kind='elastic'", "time.end=1e-6"]),
                         tmp_dir_shared / "elastic", comm, quiet=True)
    if RANK:
        return
    with open_interface(tmp_dir_shared / "elastic") as itf:
        assert itf.file["jump_rate_s"].attrs["time_shift_s"] == -0.5 * s["dt_s"]
        assert all(itf.file[q].attrs["time_shift_s"] == 0.0 for q in ("slip_rate", "slip", "shear_traction"))


def test_the_experiments_rigid_interface_says_its_times_too(comm, tmp_dir_shared):
    """With the experiment's bodies the model's interface is the frictional one and the
    projectile's contact in one step; the file's times follow the scene's interface kind."""
    sets = ["mesh.preset='coarse'", "interface.kind='rigid'", "friction.law='slip_weakening'",
            "friction.params.Dc=2e-5", "time.end=2e-6", "output.fields=[]"]
    s = runner.run_scene(load_scene("experiment_42", sets), tmp_dir_shared / "experiment", comm, quiet=True)
    if RANK:
        return
    with open_interface(tmp_dir_shared / "experiment") as itf:
        assert itf.file["slip_rate"].attrs["time_shift_s"] == 0.5 * s["dt_s"]
        assert itf.file["slip"].attrs["time_shift_s"] == s["dt_s"]
