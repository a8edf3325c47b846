"""The stable step's λmax (:func:`fricfem.model.assembly.max_eigenvalue`, Lanczos)
against scipy's ARPACK on the assembled M^-½ K M^-½, on the linear triangles and
on spectral elements: the largest eigenvalue to 1e-11, from below or equal
(the power iteration it replaced stopped 8e-4 low on the reference meshes)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from mpi4py import MPI
from rankcheck import on_rank0

from fricfem.model import assembly
from fricfem.model import mesh as mesh_mod
from fricfem.model.material import Material
from fricfem.model.numbering import numbering

MAT = Material(E=5.2e9, nu=0.34, rho=1230.0, plane="strain")


class _NoSprings:
    def add_spring_action(self, x, y):
        pass


def _both(p: int, comm) -> tuple:
    """(Lanczos λmax on ``comm``, ARPACK's on the assembled matrix) on a graded two-plate mesh."""
    spec = mesh_mod.MeshSpec(length=8e-3, height=4e-3, dx=0.5e-3 * max(p, 1), dy=0.4e-3 * max(p, 1), fine_x0=2e-3,
                             fine_x1=5e-3, fine_height=1.5e-3, impact_b=2e-3, grading=1.3, max_size=2e-3, degree=p)

    def build(c):
        pm = mesh_mod.build(spec, c)
        num = numbering(pm, assembly.function_space(pm.mesh))
        rows = assembly.canonical_rows(num, MAT)
        K = assembly.SemStiffness(num, MAT, c) if p > 1 else assembly.Stiffness(num, rows, c)
        return num, rows, K, assembly.canonical_mass(num, MAT.rho)

    num, rows, K, mass = build(comm)
    lam = assembly.max_eigenvalue(K, mass, _NoSprings(), num)

    def reference():
        num, (ptr, cols, vals), _, mass = build(MPI.COMM_SELF)
        n = len(num.x)
        r = np.repeat(num.owned_nodes, np.diff(ptr))
        A = sp.csr_matrix((np.concatenate([vals[:, k] for k in range(4)]),
                           (np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1]),
                            np.concatenate([2 * cols, 2 * cols + 1, 2 * cols, 2 * cols + 1]))), shape=(2 * n, 2 * n))
        m = np.zeros(2 * n)
        m[np.column_stack([2 * num.owned_nodes, 2 * num.owned_nodes + 1]).ravel()] = mass
        s = sp.diags(1.0 / np.sqrt(m))
        return float(spla.eigsh(s @ A @ s, k=1, which="LA", tol=1e-14)[0][0])

    return lam, on_rank0(comm, reference)


@pytest.mark.parametrize("p", [1, 2, 4, 6])
def test_lanczos_finds_the_largest_eigenvalue(comm, p):
    lam, ref = _both(p, comm)
    assert abs(lam - ref) <= 1e-11 * ref, (lam, ref, (lam - ref) / ref)
