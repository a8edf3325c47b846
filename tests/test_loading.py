"""The forms of the impact load (:mod:`fricfem.model.loading`): a prescribed edge
velocity (the paper), a traction ρ c_l V(t), a projectile of impedance Z.
Run under ``mpirun -n 2``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene
from fricfem.scene import SceneError
from fricfem.model.build import build_model
from fricfem.step import State, evolve, step
from reference.two_pass import step_two_pass

RTOL = 1e-12


def _model(comm, kind, extra=()):
    scene = load_scene("case1", ["loading.v_imp=10", "mesh.preset=coarse", f"loading.kind='{kind}'", *extra])
    return scene, build_model(scene, comm)[1]


def _edge_velocity(model, state, comm, x2_range):
    """Mean x1 velocity of the struck dofs with x2 in ``x2_range`` [m/s]."""
    x = model.V.tabulate_dof_coordinates()
    d = model.impact.dofs
    sel = (x[d // 2, 1] > x2_range[0]) & (x[d // 2, 1] < x2_range[1])
    tot = comm.allreduce(np.array([state.v.array_r[d[sel]].sum(), float(sel.sum())]))
    return tot[0] / tot[1]


@pytest.mark.parametrize("kind", ["traction", "projectile"])
def test_traction_load_fused_equals_two_pass_and_balances_energy(comm, kind):
    """The fused step with a traction load equals the two-pass step to
    round-off over 200 steps, and the energy budget closes to 1 % of the work."""
    _, model = _model(comm, kind)
    runs = {}
    for name, stepper in (("two_pass", step_two_pass), ("fused", step)):
        st = State(model)
        energy = None
        for _, energy in evolve(model, st, 200 * model.dt, end_energy=True, stepper=stepper):
            pass
        runs[name] = (st.u.array_r.copy(), st.v.array_r.copy(), comm.allreduce(st.work_ext), energy)
    (u0, v0, w0, e0), (u1, v1, w1, e1) = runs["two_pass"], runs["fused"]
    for a0, a1 in ((u0, u1), (v0, v1)):
        den = comm.allreduce(float(np.abs(a0).max()), op=MPI.MAX)
        assert comm.allreduce(float(np.abs(a0 - a1).max()), op=MPI.MAX) <= RTOL * den
    assert e0["external"] == pytest.approx(e1["external"], rel=RTOL)
    assert w0 > 0 and abs(w1 - w0) <= RTOL * w0
    assert abs(e1["balance_error"]) <= 0.01 * e1["external"]


def test_traction_launches_the_plane_wave_velocity(comm):
    """ρ c_l V(t) on the edge: away from the segment's ends the edge moves at
    V(t) while the wave is plane (here at 4 µs, within 3 %)."""
    scene, model = _model(comm, "traction")
    st = State(model)
    for _ in evolve(model, st, math.ceil(4e-6 / model.dt) * model.dt):  # the first step that reaches 4 µs
        pass
    v = _edge_velocity(model, st, comm, (-18e-3, -7e-3))
    assert v == pytest.approx(scene.pulse.velocity(st.t - 0.5 * model.dt), rel=0.03)


def test_a_stiff_projectile_imposes_its_velocity(comm):
    """A projectile 1000 times stiffer than the plate moves the edge at V(t)
    (within 0.5 %), as the prescribed-velocity load does."""
    scene, model = _model(comm, "projectile", ["loading.impedance=2.7e9"])
    st = State(model)
    for _ in evolve(model, st, math.ceil(12e-6 / model.dt) * model.dt):  # the first step that reaches 12 µs
        pass
    v = _edge_velocity(model, st, comm, (-24e-3, -1e-3))
    assert v == pytest.approx(scene.pulse.velocity(st.t - 0.5 * model.dt), rel=0.005)


def test_unknown_load_kind_is_refused():
    with pytest.raises(SceneError, match="loading.kind = 'hammer'.*'velocity', 'traction', 'projectile'"):
        load_scene("case1", ["loading.kind='hammer'"])
    with pytest.raises(SceneError, match="loading.impedance"):
        load_scene("case1", ["loading.kind='projectile'", "loading.impedance=-1"])
