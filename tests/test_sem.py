"""Spectral elements (``mesh.degree`` 2 to 6, :mod:`fricfem.model.sem`) in the
model: the GLL lattice's mass and edge weights are the exact integrals, the
assembled K has the rigid-body modes as its null space and the exact energy of
a linear field, a static manufactured solution converges at order p + 1 in L2,
a rupture runs with its energy balanced and the same bits on 1 and 2 ranks,
and the scene refuses what the elements do not carry."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from mpi4py import MPI
from rankcheck import on_rank0, world_against_self

from fricfem import load_scene
from fricfem.model import assembly, grid, sem
from fricfem.model import mesh as mesh_mod
from fricfem.model.material import Material
from fricfem.model.numbering import numbering
from fricfem.scene.schema import SceneError

MAT = Material(E=5.2e9, nu=0.34, rho=1230.0, plane="strain")


def small_spec(p: int, h: float, length=4e-3, height=2e-3) -> mesh_mod.MeshSpec:
    """Two uniform plates ``length × height`` of ``h`` elements (no grading)."""
    return mesh_mod.MeshSpec(length=length, height=height, dx=h, dy=h, fine_x0=0.0, fine_x1=length,
                             fine_height=height, impact_b=height / 2, grading=1.15, max_size=h, degree=p)


def built(spec, comm):
    pm = mesh_mod.build(spec, comm)
    V = assembly.function_space(pm.mesh)
    return pm, V, numbering(pm, V)


@pytest.mark.parametrize("p", [2, 4, 6])
def test_mass_and_edge_weights_are_the_exact_integrals(comm, p):
    """Σ of the diagonal mass = ρ × both plates' area (per component); the struck
    edge's weights sum to its length and the interface pairs' to the plate's
    length, and each pair's weight is the GLL weight w_k h/2 summed over its
    elements (not half of each lattice edge)."""
    spec = small_spec(p, 1e-3)
    pm, V, num = built(spec, comm)
    mass = assembly.canonical_mass(num, MAT.rho)
    total = comm.allreduce(float(mass.sum()), op=MPI.SUM)
    assert math.isclose(total, 2 * MAT.rho * 2 * spec.length * spec.height, rel_tol=1e-13)
    dofs = assembly.impact_dofs(V, pm.facet_tags, ("impact_lower",))
    w = assembly.edge_weights(num, ("impact_lower",), dofs)
    assert math.isclose(comm.allreduce(float(w.sum()), op=MPI.SUM), spec.impact_b, rel_tol=1e-13)
    K = assembly.Stiffness(num, assembly.canonical_rows(num, MAT), comm)
    from fricfem.model import interface as iface

    g = iface.build_pairs(num, K.createVecRight(), mass, comm)
    assert math.isclose(comm.allreduce(float(g.wq.sum()), op=MPI.SUM), spec.length, rel_tol=1e-13)
    # the elastic kind's springs sit at the same nodes with the same weights: one point a node pair
    e = iface.build_geometry(num, K.createVecRight(), comm)
    assert e.shape.tolist() == [[1.0, 0.0]] and e.n_points == len(e.x1_nodes) == len(g.x1_nodes)
    assert np.array_equal(e.x1, g.x1) and np.array_equal(e.wq, g.wq)
    nodes, weights = sem.lattice(grid.plate_axes(spec, True)[0], p)
    np.testing.assert_allclose(g.wq, weights[g.pairs], rtol=1e-14)
    np.testing.assert_array_equal(g.x1, nodes[g.pairs])
    # the GLL weights are not the lattice's trapezoid weights
    trap = np.zeros(len(nodes))
    trap[:-1] += 0.5 * np.diff(nodes)
    trap[1:] += 0.5 * np.diff(nodes)
    assert np.abs(weights - trap).max() > 0.05 * weights.max()


@pytest.mark.parametrize("p", [2, 3, 5])
def test_stiffness_null_space_and_linear_energy(comm, p):
    """K (assembled from the canonical rows) annihilates translations and the
    rotation of each plate, and u·Ku of a linear field is twice its strain energy
    over both plates, exactly (GLL quadrature integrates it)."""
    spec = small_spec(p, 1e-3, length=3e-3, height=2e-3)
    _, _, num = built(spec, comm)
    K = assembly.Stiffness(num, assembly.canonical_rows(num, MAT), comm)
    x = num.x[num.owned_nodes]
    u, f = K.createVecRight(), K.createVecRight()
    scale = float(np.abs(assembly.canonical_rows(num, MAT)[2]).max())
    for mode in (np.column_stack([np.ones(len(x)), np.zeros(len(x))]),
                 np.column_stack([np.zeros(len(x)), np.ones(len(x))]),
                 np.column_stack([-x[:, 1], x[:, 0]]) / spec.length):
        u.array[:] = mode.ravel()
        K.mult(u, f)
        assert comm.allreduce(float(np.abs(f.array).max()), op=MPI.MAX) < 1e-11 * scale
    a, b, c, d = 1e-3, 2e-3, -3e-3, 0.5e-3
    u.array[:] = np.column_stack([a * x[:, 0] + b * x[:, 1], c * x[:, 0] + d * x[:, 1]]).ravel()
    K.mult(u, f)
    energy = comm.allreduce(float(u.array @ f.array), op=MPI.SUM)
    exx, eyy, exy = a, d, 0.5 * (b + c)
    w = 0.5 * MAT.lmbda * (exx + eyy) ** 2 + MAT.mu * (exx ** 2 + eyy ** 2 + 2 * exy ** 2)
    assert math.isclose(energy, 2 * w * 2 * spec.length * spec.height, rel_tol=1e-11)


@pytest.mark.parametrize("p", [2, 4, 6])
def test_matrix_free_action_equals_the_assembled_one(comm, p):
    """The run's K (matrix-free, sum-factorized: SemStiffness) against the
    canonical rows assembled from the element matrices, on every rank's rows,
    owned and off-rank columns alike (a graded mesh: elements of many sizes)."""
    spec = mesh_mod.MeshSpec(length=6e-3, height=3e-3, dx=0.5e-3, dy=0.4e-3, fine_x0=1e-3, fine_x1=3e-3,
                             fine_height=1e-3, impact_b=1e-3, grading=1.3, max_size=1.5e-3, degree=p)
    _, _, num = built(spec, comm)
    A = assembly.Stiffness(num, assembly.canonical_rows(num, MAT), comm)
    B = assembly.SemStiffness(num, MAT, comm)
    x, ya, yb = A.createVecRight(), A.createVecRight(), A.createVecRight()
    x.array[:] = np.sin(1e3 * num.x[num.owned_nodes]).ravel()
    A.mult(x, ya)
    B.mult(x, yb)
    scale = comm.allreduce(float(np.abs(ya.array).max()), op=MPI.MAX)
    assert comm.allreduce(float(np.abs(ya.array - yb.array).max()), op=MPI.MAX) < 1e-12 * scale


def _static_error(p: int, h: float) -> float:
    """Relative L2 error (GLL quadrature) of the static manufactured solution
    u = U (sin ax cos by, cos ax sin by) on both plates, every boundary node
    prescribed; the load ∫ f N_i by the GLL quadrature (serial)."""
    spec = small_spec(p, h)
    _, _, num = built(spec, MPI.COMM_SELF)
    ptr, cols, vals = assembly.canonical_rows(num, MAT)
    n = len(num.x)
    node = num.owned_nodes
    rows = np.repeat(node, np.diff(ptr))
    I = np.concatenate([2 * rows, 2 * rows, 2 * rows + 1, 2 * rows + 1])
    J = np.concatenate([2 * cols, 2 * cols + 1, 2 * cols, 2 * cols + 1])
    K = sp.csr_matrix((np.concatenate([vals[:, 0], vals[:, 1], vals[:, 2], vals[:, 3]]), (I, J)), shape=(2 * n, 2 * n))
    m = np.zeros(2 * n)
    m[np.column_stack([2 * node, 2 * node + 1]).ravel()] = assembly.canonical_mass(num, 1.0)
    a, b = 2 * math.pi / spec.length * 1.5, 2 * math.pi / spec.height
    X, Y = num.x[:, 0], num.x[:, 1] + spec.height  # both plates: one smooth field
    ue = np.column_stack(exact(a, b, X, Y)).ravel()
    lam, mu = MAT.lmbda, MAT.mu
    fx = ((lam + 2 * mu) * a * a + mu * b * b) * np.sin(a * X) * np.cos(b * Y) + (lam + mu) * a * b * np.sin(a * X) * np.cos(b * Y)
    fy = ((lam + 2 * mu) * b * b + mu * a * a) * np.cos(a * X) * np.sin(b * Y) + (lam + mu) * a * b * np.cos(a * X) * np.sin(b * Y)
    F = m * np.column_stack([fx, fy]).ravel()
    bnd = np.unique(num.facets.ravel())
    fixed = np.zeros(2 * n, dtype=bool)
    fixed[2 * bnd] = fixed[2 * bnd + 1] = True
    free = ~fixed
    u = ue.copy()
    u[free] = spla.spsolve(K[free][:, free].tocsc(), F[free] - K[free][:, fixed] @ ue[fixed])
    return _l2_error(num.elements, num.x, u.reshape(-1, 2), lambda x, y: exact(a, b, x, y + spec.height))


def exact(a, b, x, y):
    return np.sin(a * x) * np.cos(b * y), np.cos(a * x) * np.sin(b * y)


def _l2_error(el, xg, u, ue) -> float:
    """‖u_h − u‖ / ‖u‖ in L2, u_h the element's degree-p interpolant of the nodal
    values ``u`` [n, 2], by a (p+3)-point Gauss–Legendre rule in each direction
    (the true L2 norm, not the nodal one, which converges faster at the GLL points)."""
    p = el.p
    xi, _ = sem.gll(p)
    g, gw = np.polynomial.legendre.leggauss(p + 3)
    B = np.ones((len(g), p + 1))  # B[q, i] = l_i(g_q)
    for i in range(p + 1):
        for j in range(p + 1):
            if j != i:
                B[:, i] *= (g - xi[j]) / (xi[i] - xi[j])
    ue_n = u[el.nodes].reshape(len(el.nodes), p + 1, p + 1, 2)  # [element, j (x2), i (x1), comp]
    uh = np.einsum("qi,rj,njic->nrqc", B, B, ue_n)  # [element, r (x2), q (x1), comp]
    x0 = xg[el.nodes[:, 0]]
    X = x0[:, 0, None, None] + 0.5 * (1 + g)[None, None, :] * el.hx[:, None, None]
    Y = x0[:, 1, None, None] + 0.5 * (1 + g)[None, :, None] * el.hy[:, None, None]
    X, Y = np.broadcast_arrays(X, Y)
    ex, ey = ue(X, Y)
    W = (gw[:, None] * gw[None, :])[None] * (el.hx * el.hy / 4)[:, None, None]
    err = np.sum(W * ((uh[..., 0] - ex) ** 2 + (uh[..., 1] - ey) ** 2))
    return math.sqrt(err / np.sum(W * (ex ** 2 + ey ** 2)))


#: Two element sizes [m] in the asymptotic range of each degree (on 4 mm × 2 mm plates, a field
#: of 1.5 × 1 wavelengths).  Measured (true L2): p = 2: orders 3.54, 3.25, 3.08 from 0.5 mm
#: down to 0.0625 mm; p = 3: 4.39, 4.15 (0.5 → 0.125 mm); p = 4: 5.28, 5.19, 5.06 (1 → 0.125
#: mm); p = 5: 6.35, 6.11 and p = 6: 7.07, 7.06 (1 → 0.25 mm); p = 7: 8.20, 8.04 and p = 8: 9.00,
#: 9.03 (1 → 0.25 mm): p + 1, approached from above.
LADDER = {2: (0.125e-3, 0.0625e-3), 3: (0.25e-3, 0.125e-3), 4: (0.25e-3, 0.125e-3), 5: (0.5e-3, 0.25e-3),
          6: (0.5e-3, 0.25e-3), 7: (0.5e-3, 0.25e-3), 8: (1e-3, 0.5e-3)}


@pytest.mark.parametrize("p", sorted(LADDER))
def test_static_manufactured_solution_order_p_plus_1(comm, p):
    """The L2 error of a static manufactured solution falls as h^(p+1)."""
    errs = on_rank0(comm, lambda: [_static_error(p, h) for h in LADDER[p]])
    order = math.log2(errs[0] / errs[1])
    assert p + 1 - 0.2 < order < p + 1 + 0.4, (p, errs, order)


@pytest.mark.parametrize("kind", ["rigid", "elastic"])
def test_rupture_energy_and_ranks(comm, tmp_dir_shared, kind):
    """A slip-weakening rupture on degree-3 elements, either interface kind: it
    slides, its energy budget closes, and 1 and 2 ranks give the same bits.  Its
    1.6 mm elements put no edge on the patch ends, and summary.json says so."""
    scene = load_scene("tpv205_2d", ["mesh.degree=3", "mesh.dx=1.6e-3", "mesh.dy=1.6e-3", "time.end=6e-6",
                                     "output.fields=[]", f"interface.kind='{kind}'"])
    bad = world_against_self(scene, tmp_dir_shared, comm, min_peak=0.5)
    assert not bad, f"1 and 2 ranks differ in {bad}"

    def balance():
        import json

        s = json.loads((tmp_dir_shared / "world" / "summary.json").read_text())
        return s["energy"], s["warnings"]

    e, warned = on_rank0(comm, balance)
    assert warned == list(scene.warnings) and any("inside a spectral element at x1 = 5 mm" in w for w in warned), \
        warned
    assert e["kinetic"] > 0 and e["dissipated"] > 0, e
    assert abs(e["balance_error"]) < 1e-9 * (e["kinetic"] + e["strain"] + e["dissipated"]), e


def _end_slip(comm, sets) -> np.ndarray:
    """Every interface point's slip at the end of a short degree-3 tpv205_2d run, by x1 (rank 0)."""
    from fricfem.model.build import build_model
    from fricfem.step import State, evolve

    scene = load_scene("tpv205_2d", ["mesh.degree=3", "mesh.dx=1.6e-3", "mesh.dy=1.6e-3", "time.end=5e-6",
                                     "output.fields=[]", *sets])
    model = build_model(scene, comm)[1]
    st = State(model, skip_quiet=scene.skip_quiet)
    for _ in evolve(model, st, scene.t_end, energy_every=50):
        pass
    x1 = np.concatenate(comm.allgather(model.interface.geometry.x1))
    slip = np.concatenate(comm.allgather(np.asarray(st.points.slip)))
    return slip[np.argsort(x1, kind="stable")]


def test_elastic_kind_tends_to_the_rigid_one_as_its_springs_stiffen(comm):
    """The elastic kind on spectral elements is the rigid kind's split nodes with
    springs of stiffness C between them: as C grows, its slip approaches the
    rigid kind's at the same nodes.  Measured (1 rank, the default step): 1.4 %
    of the peak slip at C = 1e14 Pa/m, 0.43 % at 1e15 and 0.50 % at 1e16, where
    the two kinds' different time steps and updates leave their floor (with
    time.dt_safety = 0.2: 2.9, 0.38 and 0.21 %)."""
    rigid = _end_slip(comm, ["interface.kind='rigid'"])
    gaps = []
    for c in (1e14, 1e15):
        el = _end_slip(comm, ["interface.kind='elastic'", f"interface.Cn={c!r}", f"interface.Cs={c!r}"])
        assert el.shape == rigid.shape
        gaps.append(float(np.abs(el - rigid).max() / np.abs(rigid).max()))
    assert rigid.max() > 1e-7, rigid.max()  # it slid
    assert gaps[0] < 0.05 and gaps[1] < 0.5 * gaps[0] and gaps[1] < 0.01, gaps


@pytest.mark.parametrize("scene,sets,match", [
    ("experiment_42", ["mesh.degree=4"], "mesh.degree = 4: spectral elements are not available with the experiment"),
    ("tpv205_2d", ["mesh.degree=9"], "mesh.degree"),
    ("tpv205_2d", ["mesh.degree=2.5"], "mesh.degree"),
])
def test_refused_before_anything_is_built(scene, sets, match):
    with pytest.raises(SceneError, match=match):
        load_scene(scene, sets)


def test_patch_ends_inside_an_element_are_named():
    """A patch or barrier end inside a spectral element is smeared over its nodes:
    the scene says where, and a mesh that puts element edges there says nothing."""
    off = load_scene("tpv205_2d", ["mesh.degree=6", "mesh.dx=0.6e-3", "mesh.dy=0.6e-3"])
    assert any("end inside a spectral element at x1 = 5 mm, 17 mm" in w for w in off.warnings), off.warnings
    on = load_scene("tpv205_2d", ["mesh.degree=6", "mesh.dx=0.5e-3", "mesh.dy=0.5e-3"])
    assert not any("spectral element" in w for w in on.warnings), on.warnings
