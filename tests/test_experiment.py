"""The experiment's steel bodies (fricfem/model/bodies.py): the grid, the
per-body materials and thicknesses, the projectile's unilateral contact, and
checks that do not depend on the paper's numerics.

* **1-D limit.** Thin strips (4 mm): a steel projectile (effective thickness
  π d/4 = 0.33 of the plates') strikes a long steel buffer bonded to a
  Homalite bar; the upper plate is decoupled (springs of 10⁶ Pa/m, Σ0 = 1 Pa).
  Bar theory: the buffer carries v_b = Z_p v0/(Z_p + Z_b), the bar
  v_bar = 2 Z_b/(Z_b + Z_h) · v_b, Z = ρ c0 t (c0 = √(E/ρ)) per unit height.
  The projectile, of lower impedance than the buffer, separates after 2L/c0
  and flies back at v0 (Z_p − Z_b)/(Z_p + Z_b).  Measured (2 ranks, 1 mm
  cells): bar 9.320 against 9.326 m/s, rebound −9.951 against −10.08 m/s.
* **Energy.** The budget closes to round-off with the projectile's kinetic
  energy as the input, which equals ½ m v0² of the cylinder per unit thickness.
* **Gauge.** At a strain-gauge position 10 mm into the specimen the loading
  front is a plane P wave: the particle velocity is c_l |ε11| (to 15 % on the
  coarse mesh over the 3 µs after its arrival).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from fricfem.model import bodies, grid
from fricfem.model.build import build_model
from fricfem.output.line_gauges import LineGauges
from fricfem.scene import SceneError, load, validate
from fricfem.step import State, evolve

H = 4e-3  # strip height of the 1-D test [m]
V0 = 20.0  # projectile speed [m/s]


def _bar_scene(t_end: float):
    return validate({
        "name": "bar1d",
        "mesh": {"preset": "coarse", "length": 0.15, "height": H, "dx": 1e-3, "dy": 1e-3, "fine_x1": 0.15,
                 "fine_height": H, "max_size": 1e-3},
        "loading": {"sigma0": 1.0, "v_imp": 0.0},
        "experiment": {"projectile_speed": V0, "projectile_length": 0.1, "projectile_diameter": H,
                       "buffer_length": 0.2},
        "interface": {"Cn": 1e6, "Cs": 1e6}, "friction": {"law": "stuck"},
        "time": {"end": t_end}, "output": {"stations": {}},
    })


def _run(scene, comm, lines):
    _, model = build_model(scene, comm)
    st = State(model)
    bodies.launch(model, st)
    gauges = LineGauges(model, lines)
    energies = []
    for s, e in evolve(model, st, scene.t_end, 20):
        gauges.record(s)
        if e is not None:
            energies.append(e)
    return model, gauges.result(), energies


def test_grid_bodies_share_the_struck_edge():
    spec = load("experiment_42", ["mesh.preset='coarse'"]).mesh
    assert isinstance(spec, bodies.BodiesMesh) and spec.impact_b == 0.025
    x, cells, ctags, facets, ftags = spec.grid_arrays()
    p = x[cells]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    assert (area > 0).all()  # counter-clockwise
    for tag, expected in ((grid.TAGS["buffer"], spec.buffer_length * spec.height),
                          (grid.TAGS["projectile"], spec.projectile_length * spec.impact_b),
                          (grid.TAGS["lower"], spec.length * spec.height)):
        assert area[ctags == tag].sum() == pytest.approx(expected, rel=1e-12)
    # coincident nodes: only the interface pairs (x2 = 0, x1 >= 0) and the contact pairs
    _, first, counts = np.unique(x, axis=0, return_index=True, return_counts=True)
    dup = x[first[counts > 1]]
    on_interface = (dup[:, 1] == 0.0) & (dup[:, 0] >= 0.0)
    on_contact = dup[:, 0] == -spec.buffer_length
    assert (on_interface | on_contact).all() and on_contact.sum() == np.count_nonzero(ftags == 41) + 1
    # the buffer's column x1 = 0 is made of the lower plate's nodes: no edge left there
    edge = np.isin(ftags, [grid.TAGS["impact_lower"], grid.TAGS["left"]])
    assert (x[facets[edge]][:, :, 1] >= 0.0).all()  # only the upper plate's x1 = 0 edge remains


def test_masses_and_rigid_motion(comm):
    scene = load("experiment_42", ["mesh.preset='coarse'", "time.end=1e-6", "output.fields=[]"])
    _, model = build_model(scene, comm)
    exp = scene.experiment
    nodes = model.bodies.nodes
    m_proj = comm.allreduce(float(model.mass[2 * nodes].sum()), op=MPI.SUM)
    assert m_proj == pytest.approx(exp.projectile_mass, rel=1e-12)
    total = comm.allreduce(float(model.mass[0::2].sum()), op=MPI.SUM)
    expected = (exp.projectile_mass + exp.steel_rho * exp.buffer_length * scene.mesh.height
                + 2 * scene.material.rho * scene.mesh.length * scene.mesh.height)
    assert total == pytest.approx(expected, rel=1e-12)
    # K annihilates a rigid translation, steel and Homalite alike
    x, y = model.K.createVecs()
    x.array[0::2] = 1.0
    x.array[1::2] = -0.5
    model.K.mult(x, y)
    assert y.norm() < 1e-9 * model.K.norm() * x.norm()
    # the steel costs time step: the model's step stays within a factor 2 of the plates' alone
    assert model.dt_crit > 0.4 * 2.95e-7  # the coarse plates alone: 2.95e-7 s (benchmarks/experiment_dt.py)


def test_one_dimensional_limit(comm):
    """Transmitted particle velocity and the projectile's rebound against bar theory."""
    scene = _bar_scene(92e-6)
    model, r, energies = _run(scene, comm, {"bar": (0.03, -H, 0.0, 1e-3)})
    exp = scene.experiment
    z_s = exp.steel_rho * math.sqrt(exp.steel_E / exp.steel_rho)
    z_h = scene.material.rho * math.sqrt(scene.material.E / scene.material.rho)
    z_p = z_s * exp.projectile_t / exp.thickness
    v_buffer = z_p * V0 / (z_p + z_s)
    v_bar = 2 * z_s / (z_s + z_h) * v_buffer
    v_back = V0 * (z_p - z_s) / (z_p + z_s)
    # the energy budget closes to round-off, the input being the projectile's ½ m v0²
    for e in energies:
        assert abs(e["balance_error"]) < 1e-10 * e["external"]
        assert e["external"] == pytest.approx(exp.kinetic_energy(), rel=1e-12)
    if comm.rank:
        return
    t = r["t_v"]
    # the bar's plateau: the wave arrives at 0.2/c_steel + 0.03/c_bar = 54 us and lasts 2L/c_steel = 40 us
    plateau = (t > 60e-6) & (t < 90e-6)
    assert r["bar.v1"][plateau].mean() == pytest.approx(v_bar, rel=0.02)
    assert (-r["bar.eps11"][plateau].mean() * math.sqrt(scene.material.E / scene.material.rho)
            == pytest.approx(v_bar, rel=0.02))
    # separation after 2L/c = 40 us: no contact force, the projectile flies back at constant speed
    free = t > 45e-6
    assert (r["contact_force"][free] == 0.0).all()
    assert np.ptp(r["projectile.v1"][free]) < 1e-9 * V0
    assert r["projectile.v1"][-1] == pytest.approx(v_back, rel=0.03)
    assert (r["contact_force"] >= 0.0).all()  # unilateral: the contact only pushes


def test_experiment_energy_budget(comm):
    scene = load("experiment_42", ["mesh.preset='coarse'", "time.end=12e-6", "output.fields=[]"])
    model, r, energies = _run(scene, comm, {"edge": (0.0, -scene.mesh.height, 0.0, 1e-3),
                                            "g10": (0.010, -0.025, 0.0, 1e-3)})
    assert energies[-1]["external"] == pytest.approx(scene.experiment.kinetic_energy(), rel=1e-12)
    for e in energies:
        assert abs(e["balance_error"]) < 1e-10 * e["external"]
    # energy went into the specimen: the kinetic energy left the projectile
    assert energies[-1]["kinetic"] < 0.9 * energies[0]["external"]
    if comm.rank == 0:
        assert r["projectile.v1"][-1] < 0.9 * scene.experiment.projectile_speed
        assert r["edge.v1"][-1] > 0.0  # the struck edge moves into the specimen
        # the loading front at a gauge 10 mm into the specimen is a plane P wave: v1 = c_l |ε11|
        t, v = r["t_v"], r["g10.v1"]
        front = (t >= t[np.argmax(v > 5.0)]) & (t <= t[np.argmax(v > 5.0)] + 3e-6)
        c_l = scene.material.c_l
        assert -c_l * r["g10.eps11"][front].mean() == pytest.approx(v[front].mean(), rel=0.15)


@pytest.mark.parametrize("overrides, message", [
    (["loading.v_imp=2.0"], "loading.v_imp must be 0"),
    (["loading.symmetric=true"], "loading.symmetric must be false"),
    (["mesh.impact_b=0.02"], "mesh.impact_b = 0.02 m: with an [experiment]"),
    (["experiment.projectile_diameter=0.1"], "experiment.projectile_diameter = 0.1 m: must not exceed"),
    (["experiment.steel_dx=0.03"], "experiment.steel_dx = 0.03 m: must lie in [1e-05, 0.01] m"),
    (["experiment.steel_dx=0.009", "experiment.buffer_length=0.005"], "experiment.steel_dx = 0.009 m: must not "
                                                                     "exceed the buffer length"),
    (["experiment.steel_nu=0.5"], "experiment.steel_nu = 0.5"),
    (["experiment.projectile_speed=0.0"], "set without experiment.projectile_speed > 0"),
])
def test_bad_experiment_is_refused(overrides, message):
    with pytest.raises(SceneError) as err:
        load("experiment_42", overrides)
    text = str(err.value)
    assert message in text and "\n" not in text
