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
    if MPI.COMM_WORLD.rank:  # only rank 0 prints
        assert text == ""
        return
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
    if MPI.COMM_WORLD.rank:  # only rank 0 prints; the bad input below is refused on every rank
        assert cli.main(["show", "case1", "--set", "loading.sigma0=-1"]) == 2
        return
    assert "case3.toml <- " in text and "case1.toml" in text
    assert "v_imp = 7.5" in text and "sigma0 = 10000000.0" in text and "t_rise = 1e-05" in text
    (d / "back.toml").write_text(text)
    assert scene_mod.load(str(d / "back.toml")) == scene_mod.load(str(d / "mine.toml"))
    assert cli.main(["show", "case1", "--set", "loading.sigma0=-1"]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:  # only rank 0 prints
        assert err.count("\n") == 1 and "loading.sigma0" in err and "Pa" in err


# --- two real runs of Case III (coarse mesh, 30 µs: it slides from ~8.4 µs), differing in the step only
STATIONS = 'output.stations={"x16.1mm"=0.0161, x30mm=0.030}'
SHORT = ["mesh.preset='coarse'", "time.end=30e-6", "output.fields=[]", STATIONS]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from fricfem import load_scene, runner

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(str(tmp_path_factory.mktemp("researcher")) if comm.rank == 0 else None, root=0))
    for name, extra in (("a", []), ("b", ["time.dt_safety=0.45"])):
        runner.run_scene(load_scene("case3", SHORT + extra), root / name, comm, quiet=True)
    return root / "a", root / "b"


def _raw_stations(rundir: Path) -> dict:
    """Station histories straight from interface.h5 (h5py, no fricfem reader)."""
    import h5py

    with h5py.File(rundir / "interface.h5", "r") as f:
        return {name: {k: g[k][: int(g.attrs["n"])] for k in g if g[k].ndim == 1} | {"x1": float(g.attrs["x1"])}
                for name, g in f["stations"].items()}


def test_export_scec_is_the_stations_with_the_exercise_signs(runs, tmp_path):
    """Each station's SCEC file holds its every step: time, slip, slip rate as stored; the shear stress
    positive in the direction of sliding and equal to μ_app·T_n there, the normal stress −T_n (MPa,
    negative in compression); the CSV holds the same numbers in SI to the last bit."""
    from fricfem.output import export

    a, _ = runs
    if MPI.COMM_WORLD.rank:
        return
    out = _own(tmp_path)
    assert cli.main(["export", str(a), "--format", "scec", "--out", str(out / "scec"), "--author", "A. Referee"]) == 0
    assert cli.main(["export", str(a), "--format", "csv", "--out", str(out / "csv")]) == 0
    raw = _raw_stations(a)
    assert sorted(p.name for p in (out / "scec").iterdir()) == sorted(f"{n}.dat" for n in raw)
    csv = np.genfromtxt(out / "csv" / "stations.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    for name, st in raw.items():
        header, names, data = export.read_scec(out / "scec" / f"{name}.dat")
        assert names == ["t", "h-slip", "h-slip-rate", "h-shear-stress", "n-stress"]
        assert "# code=fricfem" in header and "# author=A. Referee" in header
        assert f"# num_time_steps={len(st['time'])}" in header
        assert any(f"x1 = {st['x1'] * 1e3:.4f} mm" in line for line in header)
        np.testing.assert_allclose(data[:, 0], st["time"], rtol=1e-7)
        np.testing.assert_allclose(data[:, 1], st["slip"], rtol=1e-7, atol=1e-30)
        np.testing.assert_allclose(data[:, 2], st["slip_rate"], rtol=1e-7, atol=1e-30)
        np.testing.assert_allclose(data[:, 4], -st["normal_traction"] / 1e6, rtol=1e-7)
        assert np.all(data[:, 4] < 0)  # the plates stay pressed together at these stations
        sliding = st["slip_rate"] > 1e-2
        assert sliding.sum() > 5, f"{name}: the station must slide in this run"
        # friction resists: the exported shear stress is positive where it slides, and is μ_app T_n
        assert np.all(data[sliding, 3] > 0)
        np.testing.assert_allclose(data[sliding, 3], np.abs(st["mu_app"][sliding]) * st["normal_traction"][sliding]
                                   / 1e6, rtol=1e-6)
        rows = csv[csv["station"] == name]
        assert np.array_equal(rows["t_s"], st["time"]) and np.array_equal(rows["slip_rate_m_s"], st["slip_rate"])
        np.testing.assert_array_equal(rows["shear_stress_Pa"], data_sign(st) * st["shear_traction"])
        np.testing.assert_array_equal(rows["normal_stress_Pa"], -st["normal_traction"])


def data_sign(st) -> float:
    """The sliding sign of one station: sgn Σ Δu̇_slip T_s."""
    return -1.0 if float(np.sum(st["slip_rate"] * st["shear_traction"])) < 0 else 1.0


def test_export_refuses_a_run_without_stations_or_a_folder_that_is_not_one(tmp_path, capsys):
    d = _own(tmp_path)
    assert cli.main(["export", str(d)]) == 2
    assert "not a run directory" in capsys.readouterr().err or MPI.COMM_WORLD.rank  # rank 0 prints


def test_compare_is_the_station_data_and_zero_against_itself(runs, capsys):
    """compare A B prints one line per station whose rupture time, final slip and peak slip rate are
    those of interface.h5's histories (the rupture time interpolated as the summary's); A against itself is zero everywhere; halving the step moves
    the rupture times by less than 0.5 µs and gives a relative L2 difference in (0, 1)."""
    from fricfem.analysis import compare

    a, b = runs
    if MPI.COMM_WORLD.rank:
        return
    assert cli.main(["compare", str(a), str(b)]) == 0
    lines = capsys.readouterr().out.splitlines()
    raw_a, raw_b = _raw_stations(a), _raw_stations(b)
    assert sum(1 for line in lines if line.split()[:1] in ([n] for n in raw_b)) == len(raw_b)
    assert any(line.startswith("tip: V_tip median") for line in lines)
    cmp = compare.compare(a, b)
    for s in cmp["stations"]:
        for side, raw in (("a", raw_a), ("b", raw_b)):
            st = raw[s["name"]]
            # the summary's crossing: linear between the sample before and the first one past 1 mm/s
            # (case3's elastic interface holds its slip rate at the row's time, an instant)
            k = int(np.flatnonzero(st["slip_rate"] >= 1e-3)[0])
            t0, t1, v0, v1 = st["time"][k - 1], st["time"][k], st["slip_rate"][k - 1], st["slip_rate"][k]
            if v0 > 0 and v1 > v0:  # log-linear where both are positive (rupture.rupture_times)
                expect = t0 + np.log(1e-3 / v0) / np.log(v1 / v0) * (t1 - t0)
            else:
                expect = t0 + (1e-3 - v0) / (v1 - v0) * (t1 - t0)
            assert s[side]["rupture_time_s"] == pytest.approx(expect, rel=0, abs=1e-15)
            assert t0 <= s[side]["rupture_time_s"] <= t1
            assert s[side]["final_slip_m"] == st["slip"][-1] > 0
            assert s[side]["peak_slip_rate_m_s"] == st["slip_rate"].max()
        assert abs(s["a"]["rupture_time_s"] - s["b"]["rupture_time_s"]) < 0.5e-6
        assert 0 < s["l2_rel"] < 1
    self_cmp = compare.compare(a, a)
    assert all(s["l2_rel"] == 0 for s in self_cmp["stations"])
    assert self_cmp["rupture_time_error_s"] == 0 and self_cmp["tip"]["front_distance_max_m"] == 0
    assert cmp["tip"]["a"]["v_tip_median_m_s"] == json_summary(a)["tip"]["v_tip_median_m_s"]


def json_summary(rundir: Path) -> dict:
    import json

    return json.loads((rundir / "summary.json").read_text())


def test_compare_names_a_directory_that_is_not_a_run(runs, tmp_path, capsys):
    a, _ = runs
    d = _own(tmp_path)
    assert cli.main(["compare", str(a), str(d)]) == 2
    assert f"{d}: not a run directory" in capsys.readouterr().err or MPI.COMM_WORLD.rank  # rank 0 prints


# --- fricfem plot on a sweep directory, and the mode map's typesetting


def _sweep_dir(d: Path, labels, conf, title="povirk_needleman law · V_imp and Σ0\nC_n = 0.3, C_s = 0.1 MPa/µm"):
    import json

    s, v = [2.0, 10.0, 30.0], [2.0, 10.0, 40.0]
    doc = {"title": title, "grid": {"sigma0_MPa": s, "v_imp_m_s": v},
           "labels": {"values": labels}, "confidence": {"values": conf}, "points": []}
    (d / "points").mkdir(parents=True, exist_ok=True)
    (d / "modemap.json").write_text(json.dumps(doc))
    return s, v


LABELS = [["crack-like", "crack-like", "pulse"], ["none", "crack-like", "mixed"], ["none", "none", "pulse"]]
CONF = [[1.0, 0.9, 0.5], [1.0, 0.61, 0.75], [1.0, 1.0, 1.0]]


def test_plot_on_a_sweep_directory_draws_its_map_or_says_why_not(tmp_path, capsys, monkeypatch):
    """A sweep directory's map is drawn from its modemap.json: each point's marker where the JSON
    puts it, in its label's style; a sweep with no map yet, or a directory that is neither a run nor
    a sweep, is one error line and status 2 (it used to print three 'skipped' lines and exit 0)."""
    import matplotlib

    matplotlib.use("Agg")
    from fricfem.plot import modemap as pm

    d = _own(tmp_path)
    sweep = d / "sweep"
    sweep.mkdir()
    s, v = _sweep_dir(sweep, LABELS, CONF)
    drawn = {}
    real = pm.figure

    def spy(maps, path, note=None, suptitle=None):
        import matplotlib.pyplot as plt

        for title, panel in maps.items():
            fig, ax = plt.subplots()
            pm.draw(ax, panel[0], panel[1], panel[2], title, *panel[3:5])
            drawn[title] = ax
        real(maps, path, note=note, suptitle=suptitle)

    monkeypatch.setattr(pm, "figure", spy)
    assert cli.main(["plot", str(sweep)]) == 0
    if MPI.COMM_WORLD.rank == 0:
        assert capsys.readouterr().out.split() == [str(sweep / "plots" / "modemap.png")]
        assert (sweep / "plots" / "modemap.png").stat().st_size > 10_000
        (ax,) = drawn.values()
        where = {}
        for coll in ax.collections:
            label = coll.get_label()
            for x, y in coll.get_offsets():
                where[(round(float(x), 6), round(float(y), 6))] = label
        for i, si in enumerate(s):
            for j, vj in enumerate(v):
                assert (si, vj) in where, f"no marker at Σ0 = {si}, V = {vj}"
                if CONF[i][j] >= pm.LOW_CONFIDENCE:  # filled markers carry the label's legend name
                    assert where[(si, vj)] == pm.MARKERS[LABELS[i][j]]["label"]
    empty = d / "stopped"
    (empty / "points").mkdir(parents=True)
    assert cli.main(["plot", str(empty)]) == 2
    (d / "other").mkdir()
    assert cli.main(["plot", str(d / "other")]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert "mode map is not written yet" in err and "nothing to plot" in err
    assert not (empty / "plots").exists() and not (d / "other" / "plots").exists()


def test_modemap_labels_are_subscripts_and_confidences_readable():
    """Axis labels and titles set V_imp, Σ0, C_n, C_s as subscripts; every confidence below 1 is
    printed under its point, as the data's value to two places, at a readable size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fricfem.plot import modemap as pm

    s, v = [2.0, 10.0, 30.0], [2.0, 10.0, 40.0]
    fig, ax = plt.subplots()
    pm.draw(ax, s, v, LABELS, "law · C_n = 0.3, C_s = 0.1 MPa/µm, V_imp ≤ 40", CONF)
    assert ax.get_xlabel() == r"$\Sigma_0$ [MPa]" and ax.get_ylabel() == r"$V_\mathrm{imp}$ [m/s]"
    assert "$C_n$" in ax.get_title() and "$C_s$" in ax.get_title() and r"$V_\mathrm{imp}$" in ax.get_title()
    notes = {(round(t.xy[0], 6), round(t.xy[1], 6)): t for t in ax.texts}
    expected = {(si, vj): CONF[i][j] for i, si in enumerate(s) for j, vj in enumerate(v) if CONF[i][j] < 1}
    assert set(notes) == set(expected)
    for xy, c in expected.items():
        assert notes[xy].get_text() == f"{c:.2f}" and notes[xy].get_fontsize() >= 8
    fig.canvas.draw()  # the mathtext parses
    plt.close(fig)
