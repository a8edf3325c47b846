"""Gauges inside the plates (``output.gauges``), isochromatic frames at camera times
(``output.frames``) and friction regions in ``interface.h5``.

The physics: both plates struck over their whole edge x1 = 0 (symmetric
loading, ``mesh.impact_b`` = the plate height) send a plane P wave along x1.
Until waves from the struck edge's ends (x2 = ±75 mm) or from the interface
reach a gauge, its particle velocity is the edge's, delayed by the travel time,
v1(x1, t) = V(t − x1/c_l), and the wave's stress is σ11 = −ρ c_l v1, with
σ22 = λ/(λ + 2μ) σ11 in uniaxial strain (λ, μ the in-plane Lamé constants: ν σ11
in plane stress, ν/(1 − ν) σ11 in plane strain), on top of the prestress S22 = −Σ0.
"""

import math
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, open_run, runner
from fricfem.model.build import build_model
from fricfem.output.gauges import GAUGES_FILE, evaluate, open_gauges
from fricfem.output.line_gauges import LineGauges
from fricfem.output.points import locate
from fricfem.scene import SceneError
from rankcheck import serial_env

V_IMP = 10.0
D = 5e-3  # gauges 5 mm from the struck edge, mid-plate
X2 = 37.5e-3
PLANE_WAVE = ["mesh.preset='coarse'", "loading.symmetric=true", "mesh.impact_b=0.075", f"loading.v_imp={V_IMP}",
              "time.end=17e-6", "output.fields=[]", "output.stations={}", "output.diagnostics=false",
              f"output.gauges={{lower=[{D}, {-X2}], upper=[{D}, {X2}]}}"]


def _clean_until(scene) -> float:
    """The first time anything but the plane wave reaches the gauges [s]: the P wave
    from the struck edge's ends or from the interface's struck corner."""
    return math.hypot(D, X2) / scene.material.c_l


@pytest.mark.parametrize("plane", ["stress", "strain"])
def test_plane_p_wave_at_gauges(comm, tmp_dir_shared, plane):
    scene = load_scene("case1", PLANE_WAVE + [f"material.plane='{plane}'"])
    end = math.floor(0.98 * _clean_until(scene) * 1e7) / 1e7  # stop before any other wave arrives
    scene = load_scene("case1", PLANE_WAVE + [f"material.plane='{plane}'", f"time.end={end!r}"])
    runner.run_scene(scene, tmp_dir_shared / "run", comm, quiet=True)
    g = open_gauges(tmp_dir_shared / "run")
    mat = scene.material
    lo, up = g["lower"], g["upper"]
    assert lo.time[0] == 0.0 and np.all(lo.velocity[0] == 0.0)
    assert np.allclose(lo.stress[0], [0.0, -scene.sigma0, 0.0]) and lo.stress_difference[0] == scene.sigma0
    clean = _clean_until(scene)
    assert lo.time[-1] < clean  # the whole record is before any other wave arrives

    # the particle velocity is the edge's, delayed by D / c_l (2 % of V_imp: the mesh's dispersion)
    expected = V_IMP * np.clip((lo.velocity_time - D / mat.c_l) / scene.pulse.t_rise, 0.0, 1.0)
    assert np.max(np.abs(lo.velocity[:, 0] - expected)) < 0.02 * V_IMP
    assert np.max(np.abs(lo.velocity[:, 1])) < 0.01 * V_IMP  # a plane wave along x1
    # on the plateau (the ramp has passed): v1 = V_imp, σ11 = −ρ c_l v1, uniaxial strain
    plateau = lo.time > D / mat.c_l + scene.pulse.t_rise + 0.5e-6
    assert plateau.sum() >= 5
    v1 = lo.velocity[plateau, 0]
    s11, s22, s12 = lo.stress[plateau].T
    assert np.allclose(v1, V_IMP, rtol=1.5e-2)  # the ramp's end rings by < 1 % on this mesh
    assert np.allclose(s11, -mat.rho * mat.c_l * v1, rtol=1e-2)
    assert np.allclose(lo.strain[plateau, 0], -v1 / mat.c_l, rtol=1e-2)
    ratio = mat.lmbda / (mat.lmbda + 2 * mat.mu)
    assert math.isclose(ratio, mat.nu if plane == "stress" else mat.nu / (1 - mat.nu), rel_tol=1e-12)
    assert np.allclose(s22 + scene.sigma0, ratio * s11, rtol=1e-2)
    assert np.max(np.abs(s12)) < 1e-2 * np.max(np.abs(s11))
    assert np.allclose(lo.stress_difference[plateau], np.abs(s11 - s22), rtol=1e-2)
    # the two plates are struck alike: the upper gauge mirrors the lower one
    assert np.allclose(up.velocity[:, 0], lo.velocity[:, 0], atol=1e-9 * V_IMP)
    assert np.allclose(up.velocity[:, 1], -lo.velocity[:, 1], atol=1e-9 * V_IMP)


def test_gauges_on_one_and_two_ranks_are_bit_identical(comm, tmp_dir_shared):
    over = PLANE_WAVE + ["time.end=8e-6", "output.gauges_every=3",
                         "output.gauges={a=[0.0123, -0.0004], b=[0.0211, 0.0031], c=[0.001, -0.07]}"]
    scene = load_scene("case1", over)
    runner.run_scene(scene, tmp_dir_shared / "world", comm, quiet=True)
    if comm.rank == 0:
        runner.run_scene(scene, tmp_dir_shared / "self", MPI.COMM_SELF, quiet=True)
    comm.Barrier()
    a, b = open_gauges(tmp_dir_shared / "world"), open_gauges(tmp_dir_shared / "self")
    assert a.names == ("a", "b", "c") and len(a.time) == int(8e-6 / open_run(tmp_dir_shared / "world")
                                                               .summary["dt_s"] + 1e-9) // 3 + 1
    assert np.max(np.abs(a["a"].velocity[:, 0])) > 0.1  # the wave reached the gauge
    for q in ("time", "velocity_time"):
        assert np.array_equal(getattr(a, q), getattr(b, q))
    for q, v in a.data.items():
        assert np.array_equal(v, b.data[q]), q
    # every numeric dataset says its unit ("1": dimensionless, as for the strain), none empty
    if comm.rank == 0:
        with h5py.File(tmp_dir_shared / "world" / GAUGES_FILE, "r") as f:
            units = {}
            f.visititems(lambda name, d: units.update({name: d.attrs.get("unit")})
                         if isinstance(d, h5py.Dataset) and d.dtype.kind in "iuf" else None)
        assert units and all(isinstance(u, str) and u for u in units.values()), units
        assert units["strain"] == "1" and units["stress"] == "Pa"


def _line_run(scene, out, comm, lines):
    """Run ``scene`` with :class:`LineGauges` ``lines`` recorded after every step:
    (the histories, on every rank; the node lines' x1)."""
    holder = {}

    def build(sc, c):
        pm, model = build_model(sc, c)
        holder["g"] = LineGauges(model, lines)
        return pm, model

    runner.run_scene(scene, out, comm, quiet=True, build=build, on_step=lambda st: holder["g"].record(st))
    return comm.bcast(holder["g"].result(), root=0), holder["g"].positions


def scene_dt(rows) -> float:
    return float(rows["t_u"][1] - rows["t_u"][0])


def test_line_gauges_in_the_plane_wave(comm, tmp_dir_shared):
    """A line gauge across the lower plate (x1 ≈ 5 mm, −50 ≤ x2 ≤ −25 mm) in the plane
    P wave: its mean velocity is the edge's ramp delayed by x1/c_l, its strain across
    2 mm is −v1/c_l on the plateau; the same bits on one rank and on two."""
    scene = load_scene("case1", PLANE_WAVE + ["time.end=11e-6", "loading.t_rise=2e-6"])  # clean to 11.7 µs
    lines = {"sg": (D, -0.05, -0.025, 1e-3)}
    got, at = _line_run(scene, tmp_dir_shared / "world", comm, lines)
    one = _line_run(scene, tmp_dir_shared / "self", MPI.COMM_SELF, lines)[0] if comm.rank == 0 else None
    one = comm.bcast(one, root=0)
    assert sorted(got) == ["sg.eps11", "sg.v1", "t_u", "t_v"]  # no bodies: no projectile
    for k in got:
        assert np.array_equal(got[k], one[k]), k
    X, Xp, Xm = at["sg"]
    assert abs(X - D) < 1.5e-3 and Xp > X > Xm
    mat, ramp = scene.material, scene.pulse.t_rise
    half = got["t_v"][np.argmax(got["sg.v1"] > 0.5 * V_IMP)]  # the ramp's middle arrives at X / c_l + ramp / 2
    assert abs(half - (X / mat.c_l + 0.5 * ramp)) < scene_dt(got)
    plateau = got["t_u"] > X / mat.c_l + ramp + 1e-6
    assert plateau.sum() >= 5 and np.allclose(got["sg.v1"][plateau], V_IMP, rtol=4e-2)  # the coarse mesh rings
    assert np.allclose(got["sg.eps11"][plateau], -got["sg.v1"][plateau] / mat.c_l, rtol=2e-2)
    _, model = build_model(scene, comm)
    with pytest.raises(ValueError, match="line gauge empty: no node on x1 = .* within x2"):
        LineGauges(model, {"empty": (D, 0.01, 0.02, 1e-3)})  # above the interface: no lower node


def test_locate_interpolates_linear_fields_exactly():
    """Weights and gradients reproduce a linear displacement field at any point,
    on either side of the interface (a patch test of :func:`locate` / :func:`evaluate`)."""
    from fricfem.model.grid import grid_arrays
    from fricfem.model.mesh import preset

    x, cells = grid_arrays(preset("coarse"))[:2]
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(0, 0.137, 40), rng.uniform(-0.075, 0.075, 40)])
    pts = np.vstack([pts, [[0.0, -0.075], [0.137, 0.075], [0.03, 1e-9], [0.03, -1e-9]]])
    loc = locate(x, cells, pts)
    assert np.all(np.sign(loc.vertices[:, :, 1].mean(axis=1)) == np.sign(pts[:, 1]))  # the point's own plate
    A = np.array([[2e-3, -1e-3], [5e-4, 3e-3]])  # u = A x + c, v = 7 u
    u = x[loc.triangle] @ A.T + [1e-5, -2e-5]
    nodal = np.concatenate([u, 7 * u], axis=2)
    out = evaluate(nodal, loc, mu=2.0e9, lmbda=3.0e9, sigma0=6e6, tau0=3e6)
    assert np.allclose(out["displacement"], pts @ A.T + [1e-5, -2e-5], rtol=0, atol=1e-15)
    assert np.allclose(out["velocity"], 7 * (pts @ A.T + [1e-5, -2e-5]), rtol=0, atol=1e-14)
    eps = np.array([A[0, 0], A[1, 1], 0.5 * (A[0, 1] + A[1, 0])])
    assert np.allclose(out["strain"], eps, rtol=1e-10, atol=0)
    s11 = 4e9 * eps[0] + 3e9 * (eps[0] + eps[1])
    s22 = 4e9 * eps[1] + 3e9 * (eps[0] + eps[1]) - 6e6
    s12 = 4e9 * eps[2] + 3e6
    assert np.allclose(out["stress"], [s11, s22, s12], rtol=1e-10)
    assert np.allclose(out["stress_difference"], 2 * math.hypot((s11 - s22) / 2, s12), rtol=1e-10)
    with pytest.raises(ValueError, match="no plate"):
        locate(x, cells, [[0.2, 0.01]])


@pytest.mark.parametrize("over, message", [
    ("output.gauges={g=[0.01, 0.0]}", r"output.gauges.g\[1\] = 0.0 m: on the interface"),
    ("output.gauges={g=[0.2, 0.01]}", r"output.gauges.g\[0\] = 0.2 m: must lie in \[0, 0.137\] m"),
    ("output.gauges={g=[0.01, -0.08]}", r"output.gauges.g\[1\] = -0.08 m: must lie in \[-0.075, 0.075\] m"),
    ("output.gauges={g=[0.01]}", r"output.gauges.g = \[0.01\]: expected \[x1, x2\]"),
    ("output.gauges={G=[0.01, 0.01], g=[0.02, 0.01]}", r"output.gauges.g: the same name as output.gauges.G"),
    ("output.gauges={'a/b'=[0.01, 0.01]}", r"a gauge name = 'a/b': must be 1–64 letters"),
    ("output.gauges_every=0", r"output.gauges_every = 0 steps: must lie in \[1, 1e\+06\]"),
    ("output.frames={start=10e-6, interval=2e-6, count=50}", r"the last of 50 frames .* lower count to at most 16"),
    ("output.frames={start=10e-6, interval=1e-9, count=5}", r"output.frames.interval = 1e-09 s: shorter than one step"),
    ("output.frames={start=10e-6, count=5}", r"output.frames.interval: missing"),
    ("output.frames={start=10e-6, interval=1e-6, count=5, fps=3}", r"output.frames.fps: unknown key"),
    ("output.frames=[10e-6, 10e-6]", r"within one step"),
    ("output.frames=[50e-6]", r"output.frames\[0\] = 5e-05 s: must lie in \(0, 4e-05\] s"),
    ("output.frames=3", r"output.frames = 3: expected a list or a table"),
    ("output.thickness=0", r"output.thickness = 0 m: must lie in \(0, 1\] m"),
    ("output.f_sigma=-1", r"output.f_sigma = -1 N/m: must lie in \(0, 1e\+09\] N/m"),
])
def test_bad_gauges_and_frames_are_refused_with_the_key(over, message):
    with pytest.raises(SceneError, match=message):
        load_scene("case1", [over])


def test_frames_regions_and_a_live_read(comm, tmp_dir_shared):
    """Frames become field snapshots at their nearest steps; each interface point
    carries its friction region; gauges.h5 reads while the run writes it, and a
    run that ends early keeps exactly the rows it computed."""
    from fricfem.output.regions import region_spans
    from fricfem.output.rundir import FieldReader, open_interface, pyvista_module
    from fricfem.plot.frames import frame_series

    out = tmp_dir_shared / "run"
    scene = load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=10.0", "time.end=24e-6",
                                 "output.fields=[]", "output.flush_every=1e-9", "time.stop_at_tip=0.02",
                                 "friction.regions=[{x1_min=0.03, x1_max=0.04, params={mu_s=0.8}}]",
                                 "output.frames={start=6e-6, interval=2e-6, count=4}",
                                 "output.gauges={g=[0.01, -0.002]}"])
    seen = []
    env = serial_env()
    read = ("import sys, numpy as np; from fricfem.output.gauges import open_gauges; g = open_gauges(sys.argv[1]); "
            "print(len(g.time), int(np.isfinite(g.data['stress']).all() and np.isfinite(g.data['velocity']).all()))")

    def on_step(st):  # another process reads the file as the run writes it (rank 0)
        if comm.rank == 0 and st.n in (20, 40):
            text = subprocess.run([sys.executable, "-c", read, str(out)], env=env, capture_output=True, text=True,
                                  check=True).stdout.split()
            seen.append((st.n, int(text[0]), text[1] == "1"))

    summary = runner.run_scene(scene, out, comm, quiet=True, on_step=on_step)
    assert summary["ended_early"], "the tip should pass 20 mm before 24 µs"
    if comm.rank == 0:
        assert [n for n, _, _ in seen] == [20, 40] and all(ok for _, _, ok in seen)
        assert all(0 < rows <= n + 1 for n, rows, _ in seen)  # flushed rows only, every one complete
        g = open_gauges(out)
        assert len(g.time) == summary["steps"] + 1 and np.isfinite(g.data["velocity"]).all()
        import h5py

        with h5py.File(out / GAUGES_FILE, "r") as f:  # compacted: no NaN rows left
            assert f["time"].shape[0] == summary["steps"] + 1
        reader = FieldReader(out / "fields.xdmf")
        dt = summary["dt_s"]
        written = [t for t in reader.times]
        assert len(written) == 4 and np.allclose(written, [6e-6, 8e-6, 10e-6, 12e-6], atol=0.51 * dt, rtol=0)
        assert summary["photoelastic"]["frames_s"] == pytest.approx([6e-6, 8e-6, 10e-6, 12e-6])
        with open_interface(out) as itf:
            region = itf.file["regions/index"][...]
            inside = (itf.x1 >= 0.03) & (itf.x1 <= 0.04)
            assert np.array_equal(region, np.where(inside, 0, -1)) and inside.any()
            assert itf.file["regions/index"].attrs["x1_min"][0] == 0.03
            (k, xa, xb, params), = region_spans(itf.file, itf.x1)  # what the interface figures shade
            assert k == 0 and 0.03 <= xa < xb <= 0.04 and params == {"mu_s": 0.8}
        if pyvista_module() is not None:  # the camera's frames as one figure
            path = frame_series(out / "fields.xdmf", out / "frames.png", summary["photoelastic"]["frames_s"])
            assert path.stat().st_size > 10_000
    comm.Barrier()
