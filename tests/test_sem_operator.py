"""The spectral elements' matrix-free, sum-factorized stiffness action
(:func:`fricfem.kernels.sem.element_ku`) on its own, without a mesh or MPI: a
small graded GLL lattice (every element of another hx × hy) of two materials,
p = 2 to 6, against the operator assembled densely from the element matrices of
:func:`fricfem.model.sem.element_blocks`; its physics (rigid-body modes, a
linear field's exact energy, symmetry); the off-rank ('gathered') nodes and
any node numbering give a node the same bits; the GLL points are basix's.

Serial work: every rank does the same (no communication)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fricfem.kernels.sem import element_ku
from fricfem.model import sem

DEGREES = sem.DEGREES
# element edges [m]: every element another width and height (hx/hy from 0.3 to 3)
EDGES_X = np.cumsum([0.0, 1.0e-3, 1.3e-3, 0.7e-3, 1.9e-3])
EDGES_Y = np.cumsum([0.0, 0.8e-3, 1.5e-3, 0.6e-3])
# two materials (λ, μ) [Pa]: PMMA-like and steel-like
MATERIALS = ((5.48e9, 1.94e9), (1.15e11, 7.7e10))


def lattice(p: int):
    """The GLL lattice of EDGES_X × EDGES_Y: (x float64[N, 2], element nodes
    int64[n_el, (p+1)²] (node j (p+1) + i at GLL index i along x1, j along x2),
    hx, hy, λ, μ float64[n_el]); nodes numbered along x1 first, the right half
    of the elements (by centre) of the second material."""
    xs, _ = sem.lattice(EDGES_X, p)
    ys, _ = sem.lattice(EDGES_Y, p)
    nx = len(xs)
    x = np.stack(np.meshgrid(xs, ys, indexing="xy"), axis=-1).reshape(-1, 2)
    ex, ey = len(EDGES_X) - 1, len(EDGES_Y) - 1
    n1 = p + 1
    I, J = np.meshgrid(np.arange(ex), np.arange(ey), indexing="xy")
    I, J = I.ravel(), J.ravel()
    i, j = np.meshgrid(np.arange(n1), np.arange(n1), indexing="xy")
    nodes = ((J[:, None] * p + j.ravel()[None, :]) * nx + I[:, None] * p + i.ravel()[None, :]).astype(np.int64)
    hx, hy = np.diff(EDGES_X)[I], np.diff(EDGES_Y)[J]
    second = 0.5 * (EDGES_X[I] + EDGES_X[I + 1]) > 0.5 * EDGES_X[-1]
    lmbda = np.where(second, MATERIALS[1][0], MATERIALS[0][0])
    mu = np.where(second, MATERIALS[1][1], MATERIALS[0][1])
    return x, nodes, hx, hy, lmbda, mu


def assembled(p: int, n_nodes: int, nodes, hx, hy, lmbda, mu) -> np.ndarray:
    """K dense, float64[2N, 2N], dof 2 node + component, from the element blocks
    (K_xx, K_xy, K_yx, K_yy) of :func:`sem.element_blocks`."""
    blocks = sem.element_blocks(hx, hy, p, lmbda, mu)
    K = np.zeros((2 * n_nodes, 2 * n_nodes))
    for e in range(len(nodes)):
        for c in range(2):
            for d in range(2):
                K[np.ix_(2 * nodes[e] + c, 2 * nodes[e] + d)] += blocks[e, :, :, 2 * c + d]
    return K


def matrix_free(p: int, nodes, hx, hy, lmbda, mu, u, ug=None, n_owned=None) -> np.ndarray:
    """K u by the kernel, one call a material (the kernel takes one (λ, μ)); the
    materials' forces summed.  ``n_owned`` rows (default all); ``ug`` the
    gathered nodes' displacements (indices n_owned + k)."""
    n_owned = len(u) // 2 if n_owned is None else n_owned
    ug = np.zeros(0) if ug is None else ug
    D, w = sem.derivative(p), sem.gll(p)[1]
    f = np.zeros(2 * n_owned)
    for lm, m in MATERIALS:
        sel = np.flatnonzero((lmbda == lm) & (mu == m))
        part = np.full(2 * n_owned, np.nan)  # the kernel overwrites all of it
        element_ku(np.ascontiguousarray(nodes[sel]), np.ascontiguousarray(hx[sel]),
                   np.ascontiguousarray(hy[sel]), lm, m, D, w, u, ug, n_owned, part,
                   np.zeros((3, p + 1, p + 1, 2)))
        f += part
    return f


def matrix_free_per_element(p: int, nodes, hx, hy, lmbda, mu, u) -> np.ndarray:
    """K u by the kernel in one call, the moduli one an element (float64[n_el])."""
    f = np.full(len(u), np.nan)
    element_ku(nodes, hx, hy, lmbda, mu, sem.derivative(p), sem.gll(p)[1], u, np.zeros(0), len(u) // 2, f,
               np.zeros((3, p + 1, p + 1, 2)))
    return f


def rounding_scale(K: np.ndarray, u: np.ndarray) -> float:
    """max_i Σ_j |K_ij u_j|: the size of the terms a row sums (its round-off's scale)."""
    return float((np.abs(K) @ np.abs(u)).max())


@pytest.mark.parametrize("p", DEGREES)
def test_matrix_free_equals_the_assembled_operator(p):
    """A random displacement: the kernel's K u against the dense K assembled
    from the element matrices, to 1e-13 of the rows' term scale (the same
    integrals in another order: only round-off differs), two materials, twelve
    elements of distinct sizes."""
    x, nodes, hx, hy, lmbda, mu = lattice(p)
    K = assembled(p, len(x), nodes, hx, hy, lmbda, mu)
    u = np.random.default_rng(p).standard_normal(2 * len(x)) * 1e-6
    f = matrix_free(p, nodes, hx, hy, lmbda, mu, u)
    ref = K @ u
    err = float(np.abs(f - ref).max())
    assert err <= 1e-13 * rounding_scale(K, u), (p, err, rounding_scale(K, u))
    assert err <= 1e-13 * float(np.abs(ref).max())  # and relative to the force itself
    # the moduli one an element, both materials in one call (the sums in list order)
    f1 = matrix_free_per_element(p, nodes, hx, hy, lmbda, mu, u)
    assert float(np.abs(f1 - ref).max()) <= 1e-13 * rounding_scale(K, u)
    # the assembled operator is the kernel's, column by column (a few unit vectors)
    for dof in (0, 2 * len(x) // 2 + 1, 2 * len(x) - 1):
        e = np.zeros(2 * len(x))
        e[dof] = 1.0
        col = matrix_free(p, nodes, hx, hy, lmbda, mu, e)
        assert np.abs(col - K[:, dof]).max() <= 1e-13 * np.abs(K[:, dof]).max()


@pytest.mark.parametrize("p", DEGREES)
def test_rigid_modes_no_force_linear_field_exact_energy_symmetry(p):
    """Translations and the infinitesimal rotation give no force (1e-13 of the
    terms' scale); a linear field u = G x has the exact strain energy
    u·K u/2 = Σ_materials area ∫ σ:ε/2 (σ = λ tr ε I + 2 μ ε, ε = sym G); and
    u·K v = v·K u for random u, v."""
    x, nodes, hx, hy, lmbda, mu = lattice(p)
    K = assembled(p, len(x), nodes, hx, hy, lmbda, mu)
    modes = (np.tile([1.0, 0.0], len(x)), np.tile([0.0, 1.0], len(x)),
             np.stack([-x[:, 1], x[:, 0]], axis=1).ravel())
    for r in modes:
        f = matrix_free(p, nodes, hx, hy, lmbda, mu, r)
        assert float(np.abs(f).max()) <= 1e-13 * rounding_scale(K, r)
    G = np.array([[2.0e-4, -0.7e-4], [1.3e-4, -1.1e-4]])
    u = (x @ G.T).ravel()
    eps = 0.5 * (G + G.T)
    exact = 0.0
    for (lm, m) in MATERIALS:
        sel = (lmbda == lm) & (mu == m)
        area = float((hx[sel] * hy[sel]).sum())
        sigma = lm * np.trace(eps) * np.eye(2) + 2.0 * m * eps
        exact += 0.5 * area * float((sigma * eps).sum())
    energy = 0.5 * float(u @ matrix_free(p, nodes, hx, hy, lmbda, mu, u))
    assert math.isclose(energy, exact, rel_tol=1e-12), (energy, exact)
    rng = np.random.default_rng(10 + p)
    a, b = rng.standard_normal((2, 2 * len(x)))
    uKv = float(a @ matrix_free(p, nodes, hx, hy, lmbda, mu, b))
    vKu = float(b @ matrix_free(p, nodes, hx, hy, lmbda, mu, a))
    scale = float(np.abs(a) @ (np.abs(K) @ np.abs(b)))
    assert abs(uKv - vKu) <= 1e-13 * scale, (uKv, vKu, scale)


@pytest.mark.parametrize("p", DEGREES)
def test_gathered_nodes_and_numbering_keep_a_nodes_bits(p):
    """A rank's view: its owned nodes (the left part of the lattice) numbered in
    a shuffled order, the off-rank nodes its elements need passed apart (``ug``,
    indices n_owned + k, also shuffled), its elements every element touching an
    owned node, in list order.  Each owned node's force has the same bits as in
    the whole lattice's product (its sum runs over its elements in list order,
    whatever the numbering): the same bits on any number of ranks."""
    x, nodes, hx, hy, lmbda, mu = lattice(p)
    n = len(x)
    u = np.random.default_rng(20 + p).standard_normal(2 * n)
    whole = matrix_free(p, nodes, hx, hy, lmbda, mu, u).reshape(n, 2)
    rng = np.random.default_rng(30 + p)
    owned = np.flatnonzero(x[:, 0] < 0.45 * EDGES_X[-1])
    mine = np.zeros(n, dtype=bool)
    mine[owned] = True
    sel = np.flatnonzero(mine[nodes].any(axis=1))  # increasing: the list's order
    ghost = np.setdiff1d(np.unique(nodes[sel]), owned)
    assert len(ghost) and len(sel) < len(nodes)  # the split is a real one
    local = np.full(n, -1)
    local[rng.permutation(owned)] = np.arange(len(owned))
    local[rng.permutation(ghost)] = len(owned) + np.arange(len(ghost))
    order = np.argsort(local[owned])  # owned[order][k] has local index k
    u_own = u.reshape(n, 2)[owned[order]].ravel()
    gnodes = np.empty(len(ghost), dtype=np.int64)
    gnodes[local[ghost] - len(owned)] = ghost
    ug = u.reshape(n, 2)[gnodes].ravel()
    f = matrix_free(p, local[nodes[sel]], hx[sel], hy[sel], lmbda[sel], mu[sel], u_own, ug, len(owned))
    assert np.array_equal(f.reshape(-1, 2), whole[owned[order]])


def test_gll_points_are_basix_gll_warped():
    """sem.gll's points are the nodes of basix's gll_warped Lagrange element on an
    interval (mapped from [0, 1] to [−1, 1]) to 4e-16 for p = 2 to 7, 6e-16 at p = 8, where basix's
    are the ones off: against the roots of P_8' to 40 digits (mpmath), sem.gll is within 5.6e-17 and
    basix within 5.6e-16 (its [0, 1] points mapped); its weights integrate x^k exactly to degree 2p − 1."""
    basix = pytest.importorskip("basix")
    for p in DEGREES:
        e = basix.create_element(basix.ElementFamily.P, basix.CellType.interval, p,
                                 basix.LagrangeVariant.gll_warped)
        pts = np.sort(2.0 * np.asarray(e.points)[:, 0] - 1.0)
        x, w = sem.gll(p)
        assert np.abs(pts - x).max() <= (6e-16 if p == 8 else 4e-16), p
        for k in range(2 * p):
            assert math.isclose(float(w @ x**k), (1 - (-1) ** (k + 1)) / (k + 1), abs_tol=2e-15), (p, k)


def test_benchmark_smoke(tmp_path):
    """benchmarks/sem_operator.py on a small lattice (60 intervals a side, no
    callgrind): the products agree (the matrix-free ones, moduli one for all or
    one an element, to 1e-13 of max |K x|; the block rows and PETSc's AIJ), and
    its tables are written."""
    import sem_operator  # benchmarks/ is on pytest's pythonpath

    out = tmp_path / "sem_operator"
    doc = sem_operator.main(["--side", "60", "--repeats", "1", "--budget", "0.001", "--callgrind-side", "0",
                             "--out", str(out)])
    assert [r["p"] for r in doc["rows"]] == list(sem_operator.TABLE_DEGREES)
    for r in doc["rows"]:
        assert r["nodes"] == 61 * 61 and r["elements"] == (60 // r["p"]) ** 2
        diff = r["max_rel_diff_to_aij"]
        assert {"bcsr", "mf", "mf moduli/el"} <= set(diff) and max(diff.values()) <= 1e-13, diff
        assert all(t > 0.0 for t in r["seconds"].values())
    assert (tmp_path / "sem_operator.md").read_text().startswith("# Spectral elements")
    assert (tmp_path / "sem_operator.json").stat().st_size > 0


@pytest.mark.parametrize("p", [2, 5])
def test_moduli_per_element_or_one_for_all_same_bits(p):
    """One material given as a scalar or as one value an element: the same bits
    (the per-element path changes nothing but where λ, μ are read)."""
    _, nodes, hx, hy, _, _ = lattice(p)
    n = int(nodes.max()) + 1
    u = np.random.default_rng(40 + p).standard_normal(2 * n)
    lm, m = MATERIALS[0]
    D, w = sem.derivative(p), sem.gll(p)[1]
    f = np.empty(2 * n)
    element_ku(nodes, hx, hy, lm, m, D, w, u, np.zeros(0), n, f, np.zeros((3, p + 1, p + 1, 2)))
    g = matrix_free_per_element(p, nodes, hx, hy, np.full(len(nodes), lm), np.full(len(nodes), m), u)
    assert np.array_equal(f, g)
