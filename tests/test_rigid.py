"""The rigid (split-node) interface in the finite-element model
(``interface.kind = "rigid"``; fricfem.kernels.interface.advance_pairs).

- the energy budget closes to round-off with an impact and sliding
  (kinetic + strain + interface work = external work);
- 1 and 2 ranks give the same bits;
- both plates struck alike: nothing slides and the shear traction stays at
  its initial value (the mirror-symmetric mesh);
- opening: the plates pulled apart in the middle of the interface open a gap
  there, the normal traction is never tensile (0 where open), the closed pairs
  keep no gap, and the budget still closes (the energy of the pull goes into
  the plates and the interface's work, none is made);
- a patch edge on a node: the pair there carries the mean of the two sides
  (model.interface.pair_mean), so the patch acts over its own length.

Coarse meshes, a few seconds each on 2 ranks.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from rankcheck import world_against_self

from fricfem import friction, load_scene
from fricfem.model import mesh
from fricfem.model.build import build, build_model
from fricfem.model.interface import pair_mean
from fricfem.model.loading import ImpactPulse
from fricfem.model.material import Material
from fricfem.step import State, evolve, step

COARSE_RIGID = ["mesh.preset='coarse'", "interface.kind='rigid'", "output.fields=[]"]


def _gmax(comm, a, initial=0.0) -> float:
    return comm.allreduce(float(np.max(a, initial=initial)), op=MPI.MAX)


def test_energy_budget_closes_with_impact(comm):
    """Case I at 10 m/s on the coarse mesh, rigid, Povirk–Needleman in its rigid
    limit: the interface slides and dissipates, and the budget closes to
    round-off at every energy evaluation (the pairs' work is the trapezoid over
    each step, the central-difference energy identity)."""
    scene = load_scene("case1", COARSE_RIGID + ["loading.v_imp=10", "time.end=30e-6"])
    model = build_model(scene, comm)[1]
    energies = [e for _, e in evolve(model, State(model), scene.t_end, 5) if e]
    last = energies[-1]
    assert last["dissipated"] > 0.01 * last["external"], last  # it slid
    assert last["interface_elastic"] == 0.0  # a rigid contact stores nothing
    worst = max(abs(e["balance_error"]) for e in energies)
    assert worst < 1e-12 * last["external"], (worst, last["external"])


def test_one_and_two_ranks_same_bits(comm, tmp_dir_shared):
    """The same rigid run (sliding) on 1 and 2 ranks: every interface quantity and
    station history bit for bit."""
    scene = load_scene("case1", COARSE_RIGID + ["loading.v_imp=10", "time.end=20e-6"])
    bad = world_against_self(scene, tmp_dir_shared, comm, min_peak=0.1)
    assert not bad, f"1 and 2 ranks differ in {bad}"


def test_symmetric_loading_never_slides(comm):
    """Both plates struck alike (Σ0 = 10 MPa, 10 m/s): no pair slips and the shear
    traction stays at round-off while the plates are loaded hard."""
    scene = load_scene("symmetric", COARSE_RIGID + ["loading.v_imp=10"])
    model = build_model(scene, comm)[1]
    peak_v = peak_ts = peak_u = 0.0
    for st, _ in evolve(model, State(model), scene.t_end):
        p = st.points
        peak_v = max(peak_v, float(p.slip_rate.max(initial=0.0)))
        peak_ts = max(peak_ts, float(np.abs(p.Ts).max(initial=0.0)))
        peak_u = max(peak_u, float(np.abs(st.u.array_r).max()))
    assert _gmax(comm, [peak_u]) > 1e-6  # the plates are strongly loaded
    assert _gmax(comm, [peak_v]) == 0.0
    assert _gmax(comm, [peak_ts]) < 1e-6 * scene.sigma0


def _pulled_apart(comm, kind="rigid"):
    """Two 40 × 20 mm plates (1 mm cells), Σ0 = 1 MPa, slip weakening, the
    plates started moving apart over a Gaussian of 5 mm around x1 = 20 mm (the
    interface nodes at rest): the tension there exceeds Σ0 within ~1 µs."""
    spec = mesh.MeshSpec(length=0.04, height=0.02, dx=1e-3, dy=1e-3, fine_x0=0.0, fine_x1=0.04, fine_height=0.02,
                         impact_b=0.01, grading=1.0, max_size=1e-3)
    law = friction.get_law("slip_weakening")
    p = friction.pack(law, {"mu_s": 0.6, "mu_d": 0.5, "Dc": 1e-5})
    model = build(mesh.build(spec, comm), Material(plane="strain"), ImpactPulse(v_imp=0.0), law, p, 1e6, 1e13,
                  1e13, impact_tags=(), interface_kind=kind)
    st = State(model, skip_quiet=False)
    x = model.num.x[model.num.owned_nodes]
    g = np.exp(-((x[:, 0] - 0.02) / 0.005) ** 2)
    st.v.array[1::2] = 1.0 * np.sign(x[:, 1]) * np.minimum(np.abs(x[:, 1]) / 5e-3, 1.0) * g
    st.wake()
    return model, st


def test_opening_under_tension(comm):
    """The plates pulled apart in the middle: a gap opens there (and only there),
    T_n >= 0 at every pair and step and 0 where open, closed pairs keep Δu_n at
    round-off, and the budget closes (its error stays the initial kinetic energy,
    which the external work does not count)."""
    model, st = _pulled_apart(comm)
    p = st.points
    tn_min, errs = np.inf, []
    for _, e in evolve(model, st, 6e-6, energy_every=1):
        errs.append(e["balance_error"])
        tn_min = min(tn_min, float(p.Tn.min(initial=np.inf)))
    assert comm.allreduce(tn_min, op=MPI.MIN) >= 0.0
    opened = p.is_open == 1
    x_open = comm.allgather(model.interface.geometry.x1[opened])
    x_open = np.concatenate(x_open)
    assert len(x_open) >= 3 and np.all(np.abs(x_open - 0.02) < 0.01), x_open  # in the middle only
    assert np.all(p.Tn[opened] == 0.0) and np.all(p.Ts[opened] == 0.0)
    gap = _gmax(comm, p.jump_n[opened])
    assert gap > 1e-7
    assert _gmax(comm, np.abs(p.jump_n[~opened])) < 1e-12 * gap
    e0 = errs[0]
    assert max(abs(e - e0) for e in errs) < 1e-10 * abs(e0), (errs[0], errs[-1])


def _final_u(comm, kind, C=1e13):
    scene = load_scene("case1", ["mesh.preset='coarse'", "friction.law='stuck'", "loading.v_imp=10",
                                 "time.end=12e-6", "time.dt=50e-9", "output.fields=[]", f"interface.kind='{kind}'",
                                 f"interface.Cn={C!r}", f"interface.Cs={C!r}"])
    model = build_model(scene, comm)[1]
    st = State(model)
    for st, _ in evolve(model, st, scene.t_end):
        pass
    return st.u.array_r.copy(), st.t


def test_elastic_converges_to_rigid_as_C_grows(comm):
    """A bonded interface (law ``stuck``), struck at 10 m/s: the elastic springs
    tend to the rigid pairs as C grows, the difference of the displacement field
    falling like the compliance μ/(C h) (about 10× per decade of C)."""
    u_rigid, t_rigid = _final_u(comm, "rigid")
    norm = np.sqrt(comm.allreduce(float(u_rigid @ u_rigid)))
    diffs = []
    for C in (1e12, 1e13, 1e14):
        u, t = _final_u(comm, "elastic", C)
        assert abs(t - t_rigid) < 1e-12  # the same steps (time.dt fixed)
        diffs.append(np.sqrt(comm.allreduce(float((u - u_rigid) @ (u - u_rigid)))) / norm)
    # measured: 0.116, 0.0221, 0.00267 (μ/(C h) = 0.92, 0.092, 0.0092 on the 2.1 mm cells)
    assert diffs[0] > 3.0 * diffs[1] and 5.0 < diffs[1] / diffs[2] < 20.0, diffs


def test_patch_edge_pair_carries_the_mean():
    """A traction that jumps at a node gives that pair the mean of its two sides;
    uniform and linear tractions are kept inside the interface."""
    xn = np.linspace(0.0, 0.01, 11)
    k = np.arange(11)
    step_field = pair_mean(lambda x: np.where((x >= 0.003 - 1e-12) & (x <= 0.006 + 1e-12), 1.0, 0.0), xn, k)
    assert np.allclose(step_field, [0, 0, 0, 0.5, 1, 1, 0.5, 0, 0, 0, 0])
    assert np.allclose(pair_mean(lambda x: np.full(x.shape, 7.0), xn, k), 7.0)
    lin = pair_mean(lambda x: 1.0 + 100.0 * x, xn, k)
    assert np.allclose(lin[1:-1], 1.0 + 100.0 * xn[1:-1])


@pytest.mark.parametrize("kind", ["rigid", "elastic"])
def test_patch_tau0_on_the_points(comm, kind):
    """tpv205_2d's patches on a 1 mm band: a rigid pair on a patch edge takes the
    mean of the background and the patch; the Gauss points of the elastic
    interface take the value of the side they lie on."""
    scene = load_scene("tpv205_2d", ["mesh.dx=1e-3", "mesh.dy=1e-3", f"interface.kind='{kind}'"])
    model = build_model(scene, comm)[1]
    x1, ts0 = model.interface.geometry.x1, model.interface.initial.Ts0
    edge = np.abs(x1 - 0.032) < 1e-9
    inside = (x1 > 0.0325) & (x1 < 0.0375)
    assert np.allclose(ts0[inside], 6.8e6)
    if kind == "rigid":
        assert np.allclose(ts0[edge], 0.5 * (6.8e6 + 5.833e6))
    else:
        near = np.abs(x1 - 0.032) < 2e-4
        assert set(np.round(ts0[near] / 1e3)) <= {6800.0, 5833.0}
