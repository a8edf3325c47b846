"""What a researcher sees, part 2 (issue 27): ParaView without surprises (float64
declared everywhere, σ1 − σ2 at the nodes, the files saying what the stress and
displacement are, a unit on every dataset of interface.h5 for every law), figure
times that are the rows' times, mode labels that say when the mesh is too coarse
for the pulses they count, fronts named by direction on unstruck runs, and the
gauge figure.

Under ``mpirun -n 2``: the runs are on both ranks; rank 0 reads and draws.
"""

from __future__ import annotations

import importlib
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fricfem import friction, load_scene, runner
from fricfem.output import quantities
from fricfem.output.fields import nodal_projection, to_nodes

COMM = MPI.COMM_WORLD
RANK = COMM.rank
#: a few steps of case1 on the coarse mesh: enough for every dataset to exist
TINY = ["mesh.preset='coarse'", "time.end=1e-6", "output.fields=[]"]


def _tmp(factory, name: str) -> Path:
    return Path(COMM.bcast(str(factory.mktemp(name)) if RANK == 0 else None, root=0))


def _datasets(path: Path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o.attrs.get("unit")) if isinstance(o, h5py.Dataset) else None)
    return out


@pytest.mark.parametrize("law", sorted(friction.LAWS))
def test_every_interface_dataset_has_a_unit(law, tmp_path_factory):
    """state/slip of slip weakening had unit ''; mu_app, open and regions/index too."""
    out = _tmp(tmp_path_factory, f"units_{law}")
    scene = ("rupture_sw", [*TINY]) if law == "slip_weakening" else ("case1", [*TINY, f"friction.law='{law}'"])
    runner.run_scene(load_scene(*scene), out, COMM, quiet=True)
    if RANK:
        return
    units = _datasets(out / "interface.h5")
    state = [n for n in units if n.startswith("state/")]
    assert len(state) == len(friction.LAWS[law].state)
    empty = {n: u for n, u in units.items() if not isinstance(u, str) or not u.strip()}
    assert not empty, f"{law}: datasets without a unit: {empty}"
    for n in state:
        assert units[n] == quantities.STATE_UNITS[n.split("/", 1)[1]]
    if law == "slip_weakening":
        assert units["state/slip"] == "m"


@pytest.fixture(scope="module")
def fields_run(tmp_path_factory):
    out = _tmp(tmp_path_factory, "fields")
    runner.run_scene(load_scene("case3", ["mesh.preset='coarse'", "time.end=6e-6", "output.fields=[3e-6,6e-6]"]),
                     out, COMM, quiet=True)
    return out


def test_fields_xdmf_declares_float64_and_says_what_it_holds(fields_run):
    if RANK:
        return
    root = ET.parse(fields_run / "fields.xdmf").getroot()
    items = list(root.iter("DataItem"))
    floats = [d for d in items if d.get("NumberType", "Float") == "Float"]
    assert floats and all(d.get("Precision") == "8" for d in floats)  # the geometry had no Precision: float32
    geometry = [d for g in root.iter("Geometry") for d in g.iter("DataItem")]
    assert geometry and all(d.get("Precision") == "8" and d.get("NumberType") == "Float" for d in geometry)
    info = {i.get("Name"): i.get("Value") for i in root.find("Domain").findall("Information")}
    assert info["TimeUnit"].startswith("s")
    assert "prestress included" in info["stress_difference"]
    assert "dynamic part only" in info["displacement"]
    for a in root.iter("Attribute"):  # meshio reads an Attribute holding its DataItem alone
        assert [c.tag for c in a] == ["DataItem"]
    names = {a.get("Name"): a.get("Center") for a in root.iter("Attribute")}
    assert names["stress_difference"] == "Cell" and names["stress_difference_nodal"] == "Node"
    for snap in sorted((fields_run / "fields").glob("t*.h5")):
        with h5py.File(snap, "r") as f:
            for name, group in f["Function"].items():
                for d in group.values():
                    assert d.dtype == np.float64 and d.attrs["unit"] and d.attrs["meaning"]
    assert all(u for u in _datasets(fields_run / "fields" / "mesh.h5").values())


def test_nodal_stress_is_the_area_weighted_mean_of_the_cells(fields_run):
    """The nodal σ1 − σ2 against a direct per-node average of the file's own cells."""
    if RANK:
        return
    with h5py.File(fields_run / "fields" / "mesh.h5", "r") as f:
        topo, pts = f["Mesh/mesh/topology"][...], f["Mesh/mesh/geometry"][...]
    snap = sorted((fields_run / "fields").glob("t*.h5"))[-1]
    with h5py.File(snap, "r") as f:
        cells = next(iter(f["Function/stress_difference"].values()))[:, 0]
        nodal = next(iter(f["Function/stress_difference_nodal"].values()))[:, 0]
    assert np.ptp(cells) > 1e5  # the snapshot holds a wave, not the uniform prestress alone
    p = pts[:, :2]
    e1, e2 = p[topo[:, 1]] - p[topo[:, 0]], p[topo[:, 2]] - p[topo[:, 0]]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])  # np.cross of 2-D vectors: deprecated in numpy 2
    rng = np.random.default_rng(3)
    for node in rng.choice(len(p), 200, replace=False):
        around = np.flatnonzero((topo == node).any(axis=1))
        expect = np.sum(area[around] * cells[around]) / np.sum(area[around])
        assert nodal[node] == pytest.approx(expect, rel=1e-12, abs=1e-6)
        assert cells[around].min() - 1e-6 <= nodal[node] <= cells[around].max() + 1e-6
    # a constant field stays constant
    assert np.allclose(to_nodes(nodal_projection(topo, pts), np.full(len(topo), 7.0)), 7.0, rtol=1e-14)


@pytest.fixture(scope="module")
def coarse_case3(tmp_path_factory):
    """case3 on the coarse mesh to 40 µs (rows every 265 ns), snapshots at 16, 28, 32 µs, two gauges."""
    out = _tmp(tmp_path_factory, "coarse_case3")
    runner.run_scene(load_scene("case3", ["mesh.preset='coarse'", "output.fields=[16e-6,28e-6,32e-6]",
                                          "output.gauges={above=[0.02,0.004],below=[0.03,-0.006]}"]),
                     out, COMM, quiet=True)
    return out


def _kept(monkeypatch, *modules) -> dict:
    from fricfem.plot import common

    figures = {}

    def keep(fig, path, **kw):
        figures[Path(path).name] = fig
        return common.save(fig, path, **kw)

    for m in modules:
        monkeypatch.setattr(m, "save", keep)
    return figures


def test_interface_figures_ask_round_times_and_say_the_rows_drawn(coarse_case3, tmp_path, monkeypatch):
    """Rows are 0.265 µs apart: the default figures ask 10, 20, 30 µs and the last row, and each
    figure's legend and title give the time of the row it draws (was '19.9' for 19.875 µs,
    from asked times 9.9, 19.9, 29.8 µs of an even split)."""
    if RANK:
        return
    from fricfem.output.rundir import open_interface
    from fricfem.plot import interface, run as plot_run

    figures = _kept(monkeypatch, interface)
    plot_run.plot_run(coarse_case3, out=tmp_path)
    with open_interface(coarse_case3) as itf:
        t, x = np.array(itf.time), np.array(itf.x1)
        rate = itf.all("slip_rate")
    rows = [int(np.argmin(np.abs(t - a))) for a in (10e-6, 20e-6, 30e-6, t[-1])]
    drawn = {}
    for name, fig in figures.items():
        if name.startswith("interface_"):
            ax = fig.axes[0]
            labels = [h.get_text() for h in ax.get_legend().get_texts()]
            drawn[labels[-1]] = (fig, ax)
    assert sorted(drawn) == sorted(f"t = {t[r] * 1e6:.2f} µs" for r in rows)
    for r in rows:
        fig, ax = drawn[f"t = {t[r] * 1e6:.2f} µs"]
        assert f"{t[r] * 1e6:.2f} µs" in fig._suptitle.get_text()
        solid = [ln for a in fig.axes for ln in a.lines if ln.get_linestyle() == "-" and len(ln.get_xdata()) == len(x)
                 and np.array_equal(ln.get_xdata(), x * 1e3)]
        assert any(np.array_equal(ln.get_ydata(), rate[r]) for ln in solid)  # the row the label names
    assert "19.87 µs" in [k[4:] for k in drawn]  # the row nearest 20 µs (19.875 µs), said as it is


def test_plot_times_say_which_snapshots_are_drawn(coarse_case3, tmp_path, caplog):
    """--times 12,24 drew the snapshots at 16 and 28 µs and silently left out 32 µs."""
    if RANK:
        return
    import logging

    from fricfem.plot import run as plot_run

    with caplog.at_level(logging.WARNING, logger="fricfem.output"):
        paths = plot_run.plot_run(coarse_case3, times=[12e-6, 24e-6], out=tmp_path)
    names = sorted(p.name for p in paths if p.name.startswith("isochromatics_"))
    assert names == ["isochromatics_15.9us.png", "isochromatics_28.1us.png"]
    text = caplog.text
    assert "not drawn: 32.06 µs" in text
    assert "asked 12.00 µs, drew the nearest stored time 15.90 µs" in text


def test_mode_says_the_coarse_mesh_does_not_resolve_its_pulses(coarse_case3, tmp_path, monkeypatch):
    """case3 is 'mixed' on coarse (pulses one cell wide) and 'pulse' on reference: the label's
    evidence, reason and the figures' titles say how many cells a pulse spans and the minimum."""
    if RANK:
        return
    import json

    cl = importlib.import_module("fricfem.analysis.classify")  # the package exports the function classify
    from fricfem.plot import run as plot_run, spacetime, tip

    mode = json.loads((coarse_case3 / "summary.json").read_text())["mode"]
    res = mode["evidence"]["resolution"]
    assert res["min_cells_per_pulse"] == cl.MIN_CELLS_PER_PULSE
    assert res["cells_per_pulse"] < cl.MIN_CELLS_PER_PULSE and res["resolved"] is False
    assert "does not resolve the pulses" in mode["evidence"]["reason"]
    figures = _kept(monkeypatch, spacetime, tip)
    plot_run.plot_run(coarse_case3, out=tmp_path)
    want = f"pulses {res['cells_per_pulse']:.1f} cells wide, < {cl.MIN_CELLS_PER_PULSE:g} needed"
    assert want in figures["spacetime.png"].axes[0].get_title()
    assert want in figures["tip_speed.png"]._suptitle.get_text()


def test_pulse_resolution_counts_cells_of_the_late_pulses():
    """Synthetic: pulses 8 points (2 cells) wide are under-resolved, 24 points (6 cells) resolved."""
    cl = importlib.import_module("fricfem.analysis.classify")  # the package exports the function classify
    from fricfem.analysis.regions import Region

    def reg(i0, n):
        return Region(i0, i0 + n - 1, 0.0, 1.0, n * 1e-4, 1.0, 0.5)

    narrow = [[reg(10, 8), reg(40, 8)], [reg(12, 8), reg(42, 8)]]
    snaps = {0: {"cats": ["pulse", "pulse"]}, 1: {"cats": ["pulse", "pulse"]}}
    assert cl.pulse_resolution(narrow, [0, 1], snaps)["cells_per_pulse"] == 2.0
    assert cl.pulse_resolution(narrow, [0, 1], snaps)["resolved"] is False
    wide = [[reg(10, 24)], [reg(12, 24)]]
    one = {0: {"cats": ["pulse"]}, 1: {"cats": ["pulse"]}}
    assert cl.pulse_resolution(wide, [0, 1], one) == {"cells_per_pulse": 6.0, "pulse_width_m": pytest.approx(24e-4),
                                                       "min_cells_per_pulse": cl.MIN_CELLS_PER_PULSE,
                                                       "resolved": True}
    crack = {0: {"cats": ["crack"]}, 1: {"cats": ["crack"]}}
    assert cl.pulse_resolution(wide, [0, 1], crack)["resolved"] is True  # no pulse to resolve


def test_fronts_of_an_unstruck_rupture_are_named_by_direction(tmp_path_factory):
    """rupture_sw (no impact): the crack grows both ways from its patch; the left-going rupture
    front was listed as 'trailing'.  Struck runs keep leading/trailing."""
    import json

    out = _tmp(tmp_path_factory, "rupture_sw")
    runner.run_scene(load_scene("rupture_sw", ["time.end=12e-6"]), out, COMM, quiet=True)
    if RANK:
        return
    fronts = json.loads((out / "summary.json").read_text())["fronts"]
    rupture = [f for f in fronts if f["kind"] == "rupture"]
    assert {f["edge"] for f in rupture} == {"toward +x1", "toward -x1"}
    for f in rupture:
        assert (f["mean_speed"] > 0) == (f["edge"] == "toward +x1")
        assert f["region_side"] == ("leading" if f["mean_speed"] > 0 else "trailing")
    from fricfem.output.record import split, struck

    record = {"input": {"loading": {"v_imp": 20.0}}, "fronts": [{"kind": "rupture", "edge": "trailing",
                                                                  "mean_speed": -300.0, "t": [], "x": []}]}
    assert struck(record) and split(record)[0]["fronts"][0]["edge"] == "trailing"


@pytest.mark.skipif(not (shutil.which("pvbatch") and shutil.which("xvfb-run")),
                    reason="ParaView's pvbatch and xvfb-run are not installed (apt-get install paraview xvfb)")
def test_paraview_snapshot_script_colours_by_stress_and_velocity(fields_run, tmp_path):
    """docs/paraview.md's script under ``xvfb-run -a pvbatch``: two screenshots of the last
    snapshot, the stress range the file's own nodal σ1 − σ2 (prestress included)."""
    if RANK:
        return
    import subprocess

    from rankcheck import serial_env

    script = Path(__file__).resolve().parents[1] / "scripts" / "paraview_snapshot.py"
    # -noreset: Xvfb resets when its last client leaves (pvbatch connects more than once); on a
    # busy machine (the other rank polling under mpirun) the second open fell in the reset and
    # pvbatch aborted with "bad X server connection" (docs/paraview.md)
    res = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24 -noreset", "pvbatch", str(script),
                          str(fields_run / "fields.xdmf"), "--out", str(tmp_path)],
                         capture_output=True, text=True, env=serial_env(), timeout=600)
    assert res.returncode == 0, "\n".join(s for s in res.stderr.splitlines() if "ERR|" in s) + res.stderr[-2000:]
    pngs = sorted(p.name for p in tmp_path.glob("paraview_*.png"))
    from fricfem.output.rundir import FieldReader

    tag = f"{round(float(FieldReader(fields_run / 'fields.xdmf').times[-1]) * 1e6, 2):g}us"  # the last snapshot
    assert pngs == [f"paraview_stress_{tag}.png", f"paraview_velocity_{tag}.png"]
    assert all((tmp_path / p).stat().st_size > 10_000 for p in pngs)
    line = next(s for s in res.stdout.splitlines() if "stress_difference_nodal" in s)
    lo, hi = (float(v) for v in line.rsplit("from", 1)[1].split(" to "))
    snap = sorted((fields_run / "fields").glob("t*.h5"))[-1]
    with h5py.File(snap, "r") as f:
        nodal = next(iter(f["Function/stress_difference_nodal"].values()))[:, 0]
    assert lo == pytest.approx(nodal.min(), rel=1e-3) and hi == pytest.approx(nodal.max(), rel=1e-3)


def test_gauge_figure_draws_each_gauge_history(coarse_case3, tmp_path, monkeypatch):
    """gauges.png: (a) v1, v2 at velocity_time, (b) σ1 − σ2 [MPa], (c) ε11, ε22, ε12 [1e-3] of every
    gauge of gauges.h5, one colour per gauge named with its position."""
    if RANK:
        return
    from fricfem.output.gauges import open_gauges
    from fricfem.plot import gauges as plot_gauges, run as plot_run

    figures = _kept(monkeypatch, plot_gauges)
    paths = plot_run.plot_run(coarse_case3, out=tmp_path)
    assert tmp_path / "gauges.png" in paths
    fig = figures["gauges.png"]
    g = open_gauges(coarse_case3)
    assert len(g.time) > 100 and np.ptp(g.data["stress_difference"]) > 1e6  # the waves reached the gauges
    ax_v, ax_s, ax_e = fig.axes[:3]
    for k, name in enumerate(g.names):
        h = g[name]
        v_lines = ax_v.lines[2 * k: 2 * k + 2]
        for c, ln in enumerate(v_lines):
            np.testing.assert_array_equal(ln.get_xdata(), g.velocity_time * 1e6)
            np.testing.assert_array_equal(ln.get_ydata(), h.velocity[:, c])
        np.testing.assert_array_equal(ax_s.lines[k].get_xdata(), g.time * 1e6)
        np.testing.assert_array_equal(ax_s.lines[k].get_ydata(), h.stress_difference / 1e6)
        for c in range(3):
            np.testing.assert_array_equal(ax_e.lines[3 * k + c].get_ydata(), h.strain[:, c] * 1e3)
        assert ax_s.lines[k].get_color() == v_lines[0].get_color() == ax_e.lines[3 * k].get_color()
    legend = [t.get_text() for t in ax_s.get_legend().get_texts()]
    assert legend == ["above (20, 4) mm", "below (30, -6) mm"]


def test_isochromatics_average_fringes_finer_than_a_pixel_instead_of_moire():
    """Fringes 1.3 pixels apart (as near the struck corner): sampled once per pixel they alias
    into broad full-contrast stripes (moiré); the supersampled picture is the grey they average to."""
    if RANK:
        return
    pv = pytest.importorskip("pyvista")
    from fricfem.plot import isochromatics as iso

    width, height = 10e-3, 4e-3
    plane = pv.Plane(center=(width / 2, 0, 0), direction=(0, 0, 1), i_size=width, j_size=height,
                     i_resolution=400, j_resolution=160).triangulate()
    period = 0.13e-3  # m: 1.3 pixels of a 100-pixel-wide picture of 10 mm
    plane.cell_data["stress_difference"] = plane.cell_centers().points[:, 0] / period * iso.F_SIGMA / iso.THICKNESS
    window = (0.0, width, -height / 2, height / 2)
    contrast = {}
    for k in (1, iso.SUPERSAMPLE):
        image = iso.fringe_image(plane, window, width_px=100, supersample=k)
        assert image.shape == (40, 100, 3)
        grey = image[5:-5, 5:-5, 0].astype(float)
        assert grey.mean() == pytest.approx(127.5, abs=12)  # sin² averages to 1/2 either way
        contrast[k] = grey.std(axis=1).mean()
    assert contrast[1] > 70  # the moiré: aliased stripes at nearly full contrast
    assert contrast[iso.SUPERSAMPLE] < 0.4 * contrast[1]
    np.testing.assert_array_equal(iso.downsample(np.arange(16, dtype=np.uint8).reshape(4, 4, 1), 2)[..., 0],
                                  [[2, 4], [10, 12]])  # round(2.5) = 2, round(4.5) = 4: numpy's half-even


def test_summary_says_when_the_run_ended_and_when_its_energy_is(coarse_case3):
    """time.end = 40 µs on the coarse mesh (dt 265 ns): the run ends at 39.75 µs, the last whole step
    not past time.end, and its end-of-run energy is at that time too; summary.json says both."""
    if RANK:
        return
    import json

    s = json.loads((coarse_case3 / "summary.json").read_text())
    end = s["end_times"]
    assert end["t_end_s"] == 40e-6 and end["t_s"] == s["t_s"] == pytest.approx(s["steps"] * s["dt_s"], rel=1e-12)
    assert end["t_s"] <= 40e-6 < end["t_s"] + s["dt_s"]
    assert end["energy_time_s"] == s["energy"]["time_s"] == s["t_s"]
    assert s["energy"]["at"] == "end" and f"{end['t_s'] * 1e6:.6g} us" in end["note"]
