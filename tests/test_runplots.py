"""``fricfem plot``: every figure of a (synthetic) run directory is drawn and not blank.

The run directory is made here, following the layout ``fricfem run`` writes:
a crack-like sliding front leaving the impact edge at 10 µs and running at
2000 m/s (Case I-like magnitudes: Δu̇_slip 5–7 m/s, T_s ≈ −3.6…−3.9 MPa,
T_n ≈ 6 MPa), healing behind x1 = 1200 m/s (t − 25 µs), one station at
x1 = 16.1 mm, a summary.json, and a small real dolfinx ``fields.xdmf`` with
σ1 − σ2 at 22 and 32 µs. Every rank works in its own directory (no
collectives): the figures are drawn by both ranks independently.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fricfem.output import rundir as rd
from fricfem.output import quantities
from fricfem.plot import isochromatics as plot_iso
from fricfem.plot import run as plot_run
from rankcheck import serial_env

SIGMA0, V_IMP = 6e6, 2.0  # Pa, m/s
C_L, C_S, C_R = 2187.0, 1255.0, 1155.0  # m/s
V_RUPT, T_START = 2000.0, 10e-6  # m/s, s
V_HEAL, T_HEAL = 1200.0, 25e-6
C_SHEAR, DT = 1e11, 50e-9  # Pa/m, s
STATION_X = 16.1e-3  # m
FIELD_TIMES = (22e-6, 32e-6)  # s
GARBAGE = 1e30  # fills rows past n_time: must never reach a figure


def interface_state(x, t) -> dict:
    """Synthetic interface quantities at x [m] (1-D) and t [s] (1-D): [n_t, n_x] arrays, SI."""
    X, T = np.meshgrid(x, t)
    tip = V_RUPT * (T - T_START)
    heal = V_HEAL * (T - T_HEAL)
    front = C_L * T
    sliding = (X < tip) & (X > heal)
    behind = np.clip(tip - X, 0.0, None)
    rise = np.clip(behind / 0.5e-3, 0.0, 1.0)  # the slip rate rises over 0.5 mm at the tip
    slip_rate = np.where(sliding, rise * (5.0 + 2.0 * np.exp(-behind / 3e-3)), 0.0)
    ahead = np.clip((front - X) / np.maximum(front - np.maximum(tip, 0.0), 1e-6), 0.0, 1.0)
    ts_mag = np.where(X < tip, 3.6e6 + 0.3e6 * np.exp(-behind / 2e-3), 3.9e6 * ahead)
    ts_mag = np.where(X < heal, 3.75e6, ts_mag)
    elastic = 0.5 * np.exp(-(((X - tip - 1e-3) / 2e-3) ** 2)) * (T > T_START)
    tn = SIGMA0 + 0.39e6 * np.exp(-(((X - tip) / 3e-3) ** 2))
    slip = np.cumsum(slip_rate, axis=0) * (t[1] - t[0] if len(t) > 1 else 0.0)
    ts = -ts_mag  # Δu = u⁺ − u⁻: T_s < 0 under the paper's loading
    return {
        "slip_rate": slip_rate,
        "jump_rate_s": -(slip_rate + elastic),
        "shear_traction": ts,
        "normal_traction": tn,
        "shear_traction_increment": -C_SHEAR * elastic * DT,
        "slip": slip,
        "jump_s": -(slip + ts_mag / C_SHEAR),
        "mu_app": ts / tn,
        "open": np.zeros_like(X, dtype=np.int8),
    }


def write_interface(path: Path, n_time: int, n_alloc: int | None = None) -> np.ndarray:
    """interface.h5 with ``n_time`` valid rows of ``n_alloc`` allocated; returns the times."""
    n_alloc = n_alloc or n_time
    edges = np.linspace(0.0, 0.137, 251)  # 250 interface elements, 4 Gauss points each
    gp = np.array([-0.861136, -0.339981, 0.339981, 0.861136])
    x1 = (0.5 * (edges[:-1, None] + edges[1:, None]) + 0.5 * np.diff(edges)[:, None] * gp).ravel()
    t = np.linspace(0.4e-6, 40e-6, n_time)
    q = interface_state(x1, t)
    with h5py.File(path, "w") as f:
        f.attrs.update({"scene": "case1-synthetic", "sigma0": SIGMA0, "v_imp": V_IMP,
                        "c_l": C_L, "c_s": C_S, "c_R": C_R, "n_time": n_time})
        f["x1"] = x1
        ds = f.create_dataset("time", (n_alloc,), maxshape=(None,), dtype="f8")
        ds[:n_time] = t
        for name, a in q.items():
            d = f.create_dataset(name, (n_alloc, len(x1)), maxshape=(None, len(x1)), dtype=a.dtype,
                                 chunks=(1, len(x1)))
            d[:n_time] = a
            if n_alloc > n_time and a.dtype.kind == "f":
                d[n_time:] = GARBAGE
        for k, name in enumerate(("theta0", "theta1", "theta2")):
            f[f"state/{name}"] = np.full((n_alloc, len(x1)), float(k))
        ts = np.arange(0.0, t[-1], DT * 4)  # every (4th) time step
        qs = interface_state(np.array([STATION_X]), ts)
        g = f.create_group("stations/x16p1")
        g.attrs.update({"x1": STATION_X, "n": len(ts)})
        pad = 17 if n_alloc > n_time else 0  # a station half-written too
        g.create_dataset("time", data=np.concatenate([ts, np.zeros(pad)]))
        for name, a in qs.items():
            fill = GARBAGE if a.dtype.kind == "f" else 0
            g.create_dataset(name, data=np.concatenate([a[:, 0], np.full(pad, fill, dtype=a.dtype)]))
    return t


def write_summary(path: Path) -> None:
    t = np.linspace(T_START + 0.4e-6, 40e-6, 60)
    rng = np.random.default_rng(0)
    heal_t = np.linspace(T_HEAL + 0.4e-6, 40e-6, 30)
    summary = {
        "tip": {"time_s": t.tolist(), "x1_m": (V_RUPT * (t - T_START)).tolist(),
                "v_tip_time_s": t[2:-2].tolist(),  # the 5-point fit's window centres
                "v_tip_m_s": (V_RUPT + 150 * rng.standard_normal(len(t) - 4)).tolist()},
        "fronts": [
            {"kind": "rupture", "t": t.tolist(), "x": (V_RUPT * (t - T_START)).tolist(),
             "speed": [V_RUPT] * len(t)},
            {"kind": "healing", "t": heal_t.tolist(), "x": (V_HEAL * (heal_t - T_HEAL)).tolist(),
             "speed": [V_HEAL] * len(heal_t)},
        ],
        "mode": {"label": "crack-like", "evidence": {"stick_gaps": 0}},
        "speeds": {"c_l": C_L, "c_s": C_S, "c_R": C_R, "sqrt2_c_s": np.sqrt(2) * C_S},
        "dt_s": DT,
    }
    path.write_text(json.dumps(summary))


def write_fields(path: Path) -> None:
    """A small real dolfinx XDMF: P1 displacement/velocity, DG0 σ1 − σ2 [Pa] at FIELD_TIMES.

    σ: the prestress S22 = −Σ0, a compressive loading wave behind x1 = c_l t
    (stronger in the struck lower plate), a shear concentration at the tip and
    a shear Mach front behind the lines x1 = tip − |x2| cot θ, sin θ = c_s/V.
    """
    from dolfinx import fem, mesh
    from dolfinx.io import XDMFFile

    from fricfem import compat

    msh = mesh.create_rectangle(MPI.COMM_SELF, [np.array([0.0, -0.075]), np.array([0.137, 0.075])],
                                [110, 120])
    V = compat.function_space(msh, "Lagrange", 1, (2,))
    W = compat.function_space(msh, "DG", 0)
    u = fem.Function(V, name="displacement")
    v = fem.Function(V, name="velocity")
    s = fem.Function(W, name="stress_difference")
    cot = np.sqrt(1.0 - (C_S / V_RUPT) ** 2) / (C_S / V_RUPT)
    with XDMFFile(MPI.COMM_SELF, str(path), "w") as xdmf:
        xdmf.write_mesh(msh)
        for t in FIELD_TIMES:
            tip = V_RUPT * (t - T_START)

            def sdiff(x, t=t, tip=tip):
                loaded = np.clip((C_L * t - x[0]) / 5e-3, 0.0, 1.0) * (1.0 + (x[1] < 0))
                s11 = -3e6 * loaded
                r = np.hypot(x[0] - tip, x[1])
                s12 = 4e6 * np.exp(-r / 6e-3) + 2e6 * (x[0] < tip - np.abs(x[1]) * cot)
                return np.sqrt((s11 + SIGMA0) ** 2 + 4 * s12 ** 2)  # σ1 − σ2 with S22 = −Σ0

            s.interpolate(sdiff)
            u.interpolate(lambda x, t=t: np.vstack([1e-6 * np.clip(C_L * t - x[0], 0, None) / 1e-2, 0 * x[1]]))
            v.interpolate(lambda x: np.vstack([np.exp(-x[0] / 0.02), 0 * x[1]]))
            for fn in (u, v, s):
                xdmf.write_function(fn, t)


def make_run(rundir: Path, n_time: int = 100, n_alloc: int | None = None, fields: bool = True,
             summary: bool = True) -> Path:
    """A synthetic run directory in the layout of ``fricfem run``."""
    rundir.mkdir(parents=True, exist_ok=True)
    write_interface(rundir / quantities.INTERFACE_FILE, n_time, n_alloc)
    if summary:
        write_summary(rundir / quantities.SUMMARY_FILE)
    if fields:
        write_fields(rundir / quantities.FIELDS_FILE)
    return rundir


def not_blank(path: Path) -> bool:
    import matplotlib.image

    img = matplotlib.image.imread(str(path))
    return path.stat().st_size > 0 and float(np.var(img[..., :3])) > 0.0


@pytest.fixture(scope="module")
def run_plots(tmp_path_factory):
    """(run directory, written PNGs) of the full synthetic run, drawn once per rank."""
    rundir = make_run(tmp_path_factory.mktemp(f"run_rank{MPI.COMM_WORLD.rank}") / "case1")
    return rundir, plot_run.plot_run(rundir)


def test_every_figure_is_drawn(run_plots):
    rundir, paths = run_plots
    with rd.open_interface(rundir) as itf:
        rows = itf.nearest(plot_run.default_interface_times(itf))
        tags = {rd.time_tag(t) for t in itf.time[rows]}
    assert len(tags) == 4
    expected = {f"interface_{tag}.png" for tag in tags}
    expected |= {"tip_speed.png", "station_x16p1.png", "spacetime.png"}
    expected |= {f"isochromatics_{rd.time_tag(t)}.png" for t in FIELD_TIMES}
    names = {p.name for p in paths}
    assert names == expected
    for p in paths:
        assert p.parent == rundir / "plots"
        assert not_blank(p), p


def test_isochromatics_show_fringes(run_plots):
    """The fringe picture has dark and bright fringes, not a flat grey."""
    import matplotlib.image

    _, paths = run_plots
    for p in (p for p in paths if p.name.startswith("isochromatics_")):
        img = matplotlib.image.imread(str(p))[..., :3].mean(axis=2)
        inner = img[img.shape[0] // 4 : 3 * img.shape[0] // 4, img.shape[1] // 4 : 3 * img.shape[1] // 4]
        assert inner.min() < 0.15 and inner.max() > 0.85, p


def test_sliding_sign_and_zones(run_plots):
    """T_s < 0 where it slides gives sign −1; the zones at 32 µs span heal…tip."""
    rundir, _ = run_plots
    with rd.open_interface(rundir) as itf:
        assert rd.sliding_sign(itf) == -1.0
        zones = plot_iso.sliding_zones(itf, 32e-6)
        row = int(itf.nearest([32e-6])[0])
    t = float(np.linspace(0.4e-6, 40e-6, 100)[row])
    assert len(zones) == 1
    a, b = zones[0]
    assert abs(a - max(0.0, V_HEAL * (t - T_HEAL))) < 1e-3
    assert abs(b - V_RUPT * (t - T_START)) < 1e-3


def test_half_written_run_plots_only_valid_rows(tmp_path, monkeypatch):
    """interface.h5 with 150 rows allocated and n_time = 60: only the 60 are read and drawn."""
    rundir = make_run(tmp_path / f"killed{MPI.COMM_WORLD.rank}", n_time=60, n_alloc=150, fields=False,
                      summary=False)
    figures = {}
    from fricfem.plot import common, interface, spacetime, station, tip

    def keep(fig, path, **kw):
        figures[Path(path).name] = fig
        return common.save(fig, path, **kw)

    for mod in (interface, spacetime, station, tip):
        monkeypatch.setattr(mod, "save", keep)
    paths = plot_run.plot_run(rundir, out=tmp_path / "out")
    with h5py.File(rundir / quantities.INTERFACE_FILE) as f:
        itf = rd.InterfaceFile(f)
        t_valid = itf.time.copy()
        assert itf.n_time == 60 and itf.all("slip_rate").shape == (60, 1000)
        assert np.all(np.isfinite(itf.all("slip_rate"))) and itf.all("slip_rate").max() < 10.0
        station = itf.stations()["x16p1"]
        assert np.all(station.data["slip_rate"] < 10.0) and np.all(np.diff(station.time) > 0)
    last = f"interface_{rd.time_tag(t_valid[-1])}.png"
    assert last in {p.name for p in paths}
    assert not any(n.startswith("isochromatics") for n in figures)  # no fields.xdmf: skipped
    # the space-time map stops at the last valid row and its colour scale at the valid peak
    ax = figures["spacetime.png"].axes[0]
    assert ax.get_ylim()[1] == pytest.approx(t_valid[-1] * 1e6)
    assert ax.collections[0].norm.vmax < 10.0
    # the tip (no summary.json here) comes from the valid slip-rate rows only
    tip_ax = figures["tip_speed.png"].axes[0]
    assert max(line.get_xdata().max() for line in tip_ax.lines) <= t_valid[-1] * 1e6 + 1e-9
    for p in paths:
        assert not_blank(p), p


def test_nothing_to_plot_yet(tmp_path, caplog):
    """n_time = 0 (a run that just started): no interface figures, a note, no crash."""
    rundir = make_run(tmp_path / "fresh", n_time=5, fields=False, summary=False)
    with h5py.File(rundir / quantities.INTERFACE_FILE, "a") as f:
        f.attrs["n_time"] = 0
    with caplog.at_level("WARNING", logger="fricfem.output"):
        paths = plot_run.plot_run(rundir)
    assert paths == []
    assert "no valid rows" in caplog.text


def test_command_line(run_plots, tmp_path, monkeypatch, capsys):
    """``fricfem plot RUNDIR --times 22,32 --out DIR`` (µs); other MPI ranks draw nothing."""
    rundir, _ = run_plots
    for key in ("OMPI_COMM_WORLD_RANK", "PMI_RANK"):
        monkeypatch.delenv(key, raising=False)
    out = tmp_path / "cli"
    assert plot_run.main([str(rundir), "--times", "22,32", "--out", str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert "interface_22us.png" in names and "interface_32us.png" in names
    assert "isochromatics_22us.png" in names and "isochromatics_32us.png" in names
    assert len(capsys.readouterr().out.splitlines()) == len(names)
    assert plot_run.main([str(rundir), "--times", "22,x"]) == 2
    assert plot_run.main([str(tmp_path / "no-such-run")]) == 2
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "1")
    assert plot_run.main([str(rundir), "--out", str(tmp_path / "rank1")]) == 0
    assert not (tmp_path / "rank1").exists()


def test_module_entry_point():
    """``python -m fricfem.plot.run`` is a working command."""
    env = serial_env()
    res = subprocess.run([sys.executable, "-m", "fricfem.plot.run", "--help"], capture_output=True,
                         text=True, env=env, timeout=60)
    assert res.returncode == 0 and "RUNDIR" in res.stdout.upper()


def test_field_reader_with_dolfinx_loaded(run_plots):
    """fields.xdmf is read with the real mesh (VTK's own XDMF reader returns all
    points at the origin once dolfinx's libhdf5 is in the process)."""
    import dolfinx  # noqa: F401 (the situation of a demo that runs and then plots)

    rundir, _ = run_plots
    reader = rd.FieldReader(rundir / quantities.FIELDS_FILE)
    assert np.allclose(reader.times, FIELD_TIMES)
    grid = reader.grid(1)
    assert grid.n_cells == 2 * 110 * 120
    assert np.allclose(grid.bounds[:4], (0.0, 0.137, -0.075, 0.075))
    values = grid.cell_data["stress_difference"]
    assert values.shape == (grid.n_cells,) and values.min() >= 0.0 and values.max() > SIGMA0


def test_tip_speed_figure_draws_the_summary_speeds_at_their_times(run_plots, tmp_path, monkeypatch):
    """Panel (b) of tip_speed.png holds V_tip at ``v_tip_time_s`` (the centres of the
    fitting windows), every value of the summary, to the last one — not against the
    first per-step tip times, which ended the curve early."""
    from fricfem.plot import common, tip

    figures = {}

    def keep(fig, path, **kw):
        figures[Path(path).name] = fig
        return common.save(fig, path, **kw)

    monkeypatch.setattr(tip, "save", keep)
    rundir, _ = run_plots
    summary = rd.read_summary(rundir)
    rec = summary["tip"]
    tip.tip_speed(rec, tmp_path / "tip_speed.png", info=rd.run_info(rundir, summary=summary))
    ax_v = figures["tip_speed.png"].axes[1]
    curve = ax_v.lines[0]  # the V_tip line (every finite estimate, clipped to the frame)
    t_want = np.asarray(rec["v_tip_time_s"]) * 1e6
    v_want = np.asarray(rec["v_tip_m_s"])
    assert np.array_equal(curve.get_xdata(), t_want)
    assert np.allclose(curve.get_ydata(), np.clip(v_want, 0, ax_v.get_ylim()[1]), rtol=0, atol=0)
    assert curve.get_xdata()[-1] == pytest.approx(rec["v_tip_time_s"][-1] * 1e6)
    assert not np.array_equal(t_want, np.asarray(rec["time_s"][: len(v_want)]) * 1e6)  # the old bug would differ


def _keep_figures(monkeypatch, *modules) -> dict:
    """{file name: Figure} of every figure the given plot modules save."""
    from fricfem.plot import common

    figures = {}

    def keep(fig, path, **kw):
        figures[Path(path).name] = fig
        return common.save(fig, path, **kw)

    for module in modules:
        monkeypatch.setattr(module, "save", keep)
    return figures


def _impact_lines(ax) -> list:
    """The black dash-dot / dotted lines x1 = c_l t, c_s t drawn from the struck corner."""
    return [ln for ln in ax.lines if ln.get_color() == "k" and ln.get_linestyle() in ("-.", ":")]


def test_spacetime_x_axis_holds_the_sliding_and_impact_lines_only_with_an_impact(run_plots, tmp_path,
                                                                                  monkeypatch):
    """The space-time map's x1 axis runs from the struck edge to just past the furthest point that
    ever slid (not to the plate's end), and the lines x1 = c_l t, c_s t are drawn only when the run
    was struck: a rupture problem (V_imp = 0, no projectile) has none, nor does its tip figure."""
    import shutil

    from fricfem.plot import spacetime, tip

    figures = _keep_figures(monkeypatch, spacetime, tip)
    rundir, _ = run_plots
    summary = rd.read_summary(rundir)
    spacetime.spacetime(rundir, tmp_path / "struck.png", summary=summary, info=rd.run_info(rundir, summary=summary))
    ax = figures["struck.png"].axes[0]
    with rd.open_interface(rundir) as itf:
        slid = itf.x1[np.any(itf.all("slip_rate") > 0, axis=0)]
        plate = itf.x1[-1]
    lo, hi = ax.get_xlim()
    assert lo <= 0.0 and slid.max() * 1e3 <= hi <= (slid.max() + 0.1 * (slid.max() - slid.min())) * 1e3 + 3.0
    assert hi < 0.9 * plate * 1e3  # the synthetic front stops at 60 mm of a 137 mm plate
    assert len(_impact_lines(ax)) == 2
    fronts = [ln for ln in ax.lines if ln.get_color() in ("C3", "C1")]
    assert len(fronts) == len(summary["fronts"])  # each front drawn thin and see-through over the pulses
    for ln, front in zip(fronts, summary["fronts"]):
        assert np.allclose(ln.get_xdata(), np.asarray(front["x"]) * 1e3) and ln.get_linewidth() <= 1.0
        assert ln.get_alpha() < 1
    for ln, c in zip(_impact_lines(ax), (C_L, C_S)):  # x1 = c t [mm, µs]
        xs, ts = ln.get_xdata(), ln.get_ydata()
        assert np.allclose(xs[-1] / ts[-1], c * 1e-3, rtol=1e-12)

    quiet = tmp_path / "rupture"
    shutil.copytree(rundir, quiet)
    with h5py.File(quiet / "interface.h5", "r+") as f:
        f.attrs["v_imp"] = 0.0
    with rd.open_interface(quiet) as itf:  # as `fricfem plot` reads it: interface.h5's attributes
        info = rd.run_info(quiet, interface=itf, summary=summary)
    assert info.v_imp == 0.0
    spacetime.spacetime(quiet, tmp_path / "rupture.png", summary=summary, info=info)
    ax = figures["rupture.png"].axes[0]
    assert _impact_lines(ax) == []
    assert not any("c_l" in t.get_text() or "c_s" in t.get_text() for t in ax.get_legend().get_texts())
    tip.tip_speed(summary["tip"], tmp_path / "tip.png", info=info)
    assert [ln.get_label() for ln in figures["tip.png"].axes[0].lines] == [r"$x_{\rm tip}$"]


def test_interface_panel_b_draws_the_rate_of_shear_traction_whatever_the_step(tmp_path, monkeypatch):
    """Panel (b)'s right axis is Ṫ_s = dT_s/dt in MPa/µs: the file's increment divided by the
    summary's dt, times the sliding sign; the same run written with twice the step draws the
    same curve (the per-step increment doubled with it, and switched units between runs)."""
    import sys

    from fricfem.plot import interface

    figures = _keep_figures(monkeypatch, interface)
    curves = []
    for k, dt in enumerate((DT, 2 * DT)):
        monkeypatch.setattr(sys.modules[__name__], "DT", dt)
        rundir = make_run(tmp_path / f"dt{k}", n_time=60, fields=False)
        with rd.open_interface(rundir) as itf:
            last = itf.n_time - 1
            sign = rd.sliding_sign(itf)
            want = sign * itf.rows("shear_traction_increment", [last])[0] / dt * 1e-12
            info = rd.run_info(rundir)
            interface.interface_distributions(itf, [itf.time[last]], tmp_path / f"i{k}.png", info=info)
        fig = figures[f"i{k}.png"]
        (rate_ax,) = [a for a in fig.axes if "MPa/µs" in a.get_ylabel()]
        assert rate_ax.get_ylabel() == (r"$-\dot T_s$" if sign < 0 else r"$\dot T_s$") + " [MPa/µs]"
        (line,) = rate_ax.lines
        np.testing.assert_allclose(line.get_ydata(), want, rtol=1e-12, atol=0)
        assert np.max(np.abs(want)) > 0
        curves.append(line.get_ydata())
    np.testing.assert_allclose(curves[0], curves[1], rtol=1e-12, atol=1e-12)



def test_station_legend_leaves_the_panel_and_its_letter_clear(run_plots, tmp_path, monkeypatch):
    """The tractions legend of panel (c) lies outside the panel, so it covers neither the
    T_s and T_n curves nor the "(c)" label (with loc="best" it hid the label)."""
    from fricfem.plot import station

    figures = _keep_figures(monkeypatch, station)
    rundir, _ = run_plots
    with rd.open_interface(rundir) as itf:
        st = itf.stations()["x16p1"]
    station.station_history(st, tmp_path / "station.png", info=rd.run_info(rundir))
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = figures["station.png"]
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    ax = fig.axes[2]
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == [quantities.label("shear_traction"),
                                                          quantities.label("normal_traction")]
    box = legend.get_window_extent(renderer)
    (letter,) = [t for t in ax.texts if t.get_text() == "(c)"]
    assert not box.overlaps(letter.get_window_extent(renderer))
    assert box.x0 >= ax.get_window_extent(renderer).x1  # right of the panel, off the curves
    assert box.x1 <= fig.bbox.x1  # and inside the saved figure


def test_interface_host_curves_are_drawn_over_their_twins(run_plots, tmp_path, monkeypatch):
    """In the twin-axis panels (a)–(c) the left-axis (blue) curve is drawn above the right-axis
    (red) one, so where they coincide (Case I's panel (b): Δu̇_s and Ṫ_s) the blue stays visible;
    each panel letter sits on the top axes of its panel."""
    from matplotlib.colors import same_color

    from fricfem.plot import interface

    figures = _keep_figures(monkeypatch, interface)
    rundir, _ = run_plots
    with rd.open_interface(rundir) as itf:
        interface.interface_distributions(itf, [itf.time[-1]], tmp_path / "i.png", info=rd.run_info(rundir))
    fig = figures["i.png"]
    hosts, twins = fig.axes[:4], fig.axes[4:]
    assert len(twins) == 3
    for k, (host, twin) in enumerate(zip(hosts, twins)):
        assert np.allclose(host.get_position().bounds, twin.get_position().bounds)
        assert host.get_zorder() > twin.get_zorder() and not host.patch.get_visible()
        assert same_color(host.lines[0].get_color(), "C0") and same_color(twin.lines[0].get_color(), "C3")
        assert any(t.get_text() == f"({'abc'[k]})" for t in host.texts)
        if k:  # (b), (c): the twin's curve wide and pale under the host's, visible where they coincide
            assert twin.lines[0].get_linewidth() >= 2 * host.lines[0].get_linewidth()
            assert twin.lines[0].get_alpha() < 1
        assert not any(t.get_text().startswith("(") for t in twin.texts)


def test_isochromatics_keep_the_interface_clear_and_show_a_rupture_box_whole(run_plots, tmp_path, monkeypatch):
    """The sliding zones are a strip above the fringe picture at their x1 (the orange bar on x2 = 0
    covered the fringes there); a struck run shows the impact region, a run with no impact the whole
    box (a rupture problem's picture was cut to ±30 mm)."""
    import dataclasses

    from matplotlib.colors import same_color

    figures = _keep_figures(monkeypatch, plot_iso)
    rundir, _ = run_plots
    with rd.open_interface(rundir) as itf:
        struck = rd.run_info(rundir, interface=itf)
        t = FIELD_TIMES[1]
        zones = plot_iso.sliding_zones(itf, t)
        assert zones, "the synthetic run slides at 32 µs"
        plot_iso.isochromatics(rundir / quantities.FIELDS_FILE, tmp_path / "struck", times=[t], info=struck,
                               itf=itf)
        quiet = dataclasses.replace(struck, v_imp=0.0)
        plot_iso.isochromatics(rundir / quantities.FIELDS_FILE, tmp_path / "quiet", times=[t], info=quiet, itf=itf)
    name = f"isochromatics_{rd.time_tag(t)}.png"
    assert len(figures) == 1  # both have the same name: the last one drawn is the quiet one
    ax = figures[name].axes[0]
    assert ax.get_xlim() == pytest.approx((0.0, 137.0)) and ax.get_ylim() == pytest.approx((-75.0, 75.0))
    bars = [ln for ln in ax.lines if same_color(ln.get_color(), "C1")]
    assert len(bars) == len(zones)
    for ln, (a, b) in zip(bars, zones):
        assert ln.get_transform() == ax.get_xaxis_transform() and not ln.get_clip_on()
        assert np.allclose(ln.get_xdata(), [a * 1e3, b * 1e3]) and np.all(np.asarray(ln.get_ydata()) > 1.0)
    interface_lines = [ln for ln in ax.lines if np.allclose(ln.get_ydata(), 0.0) and ln.get_linewidth() > 1.0]
    assert interface_lines == []  # nothing thick drawn on x2 = 0
    figures.clear()
    with rd.open_interface(rundir) as itf:
        plot_iso.isochromatics(rundir / quantities.FIELDS_FILE, tmp_path / "struck2", times=[t], info=struck,
                               itf=itf)
    ax = figures[name].axes[0]
    assert ax.get_xlim() == pytest.approx((0.0, 80.0)) and ax.get_ylim() == pytest.approx((-30.0, 30.0))
