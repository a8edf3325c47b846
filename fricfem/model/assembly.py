"""Assembled once per run: the stiffness K, the lumped mass, the struck edge's
dofs and weights, and the stable step from λmax of M⁻¹(K + K_int).

Linear triangles (P1 vector space), lumped (row-sum) mass, as in the paper.
The stable step of the explicit central differences is ``2/√λmax`` with λmax
from a power iteration that includes the interface springs
(:func:`max_eigenvalue`); the run's step is ``dt_safety`` times it, rounded
down to 3 significant digits (:func:`round_down`) so that it is the same on
any number of ranks.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from .grid import TAGS
from .material import Material


def function_space(msh):
    return fem.VectorFunctionSpace(msh, ("Lagrange", 1))


def stiffness(V, material: Material) -> PETSc.Mat:
    """Assemble ``K`` (AIJ with I-node kernels off: ~3× faster MatMult here)."""
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = material.mu, material.lmbda

    def eps(w):
        return ufl.sym(ufl.grad(w))

    def sigma(w):
        return 2.0 * mu * eps(w) + lmbda * ufl.tr(eps(w)) * ufl.Identity(2)

    a = fem.form(ufl.inner(sigma(u), eps(v)) * ufl.dx)
    K = fem_petsc.create_matrix(a)
    K.setOption(PETSc.Mat.Option.USE_INODES, False)
    fem_petsc.assemble_matrix(K, a)
    K.assemble()
    return K


def lumped_mass(V, rho: float) -> np.ndarray:
    """Row-sum lumped mass of the owned dofs: ∫ ρ N_i dx for each component."""
    v = ufl.TestFunction(V)
    ones = fem.Constant(V.mesh, PETSc.ScalarType((1.0, 1.0)))
    b = fem_petsc.assemble_vector(fem.form(rho * ufl.inner(ones, v) * ufl.dx))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b.array.copy()


def impact_dofs(V, facet_tags, names) -> np.ndarray:
    """Owned local x1-dof indices on the facets tagged with any of ``names``."""
    if not names:
        return np.zeros(0, dtype=np.int32)
    facets = np.sort(np.concatenate([facet_tags.indices[facet_tags.values == TAGS[n]] for n in names]))
    dofs = fem.locate_dofs_topological(V.sub(0), V.mesh.topology.dim - 1, facets)
    n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    return np.sort(dofs[dofs < n_owned]).astype(np.int32)


def edge_weights(V, facet_tags, names, dofs) -> np.ndarray:
    """A_i = ∫ N_i ds over the facets tagged ``names`` at the x1 dofs ``dofs`` [m per m]."""
    ds = ufl.Measure("ds", domain=V.mesh, subdomain_data=facet_tags)
    e1 = fem.Constant(V.mesh, PETSc.ScalarType((1.0, 0.0)))
    v = ufl.TestFunction(V)
    form = sum((ufl.inner(e1, v) * ds(TAGS[n]) for n in names[1:]), ufl.inner(e1, v) * ds(TAGS[names[0]]))
    b = fem_petsc.assemble_vector(fem.form(form))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b.array[dofs].copy()


def _coordinate_noise(V) -> np.ndarray:
    """A deterministic pseudo-random vector keyed on dof coordinates (identical on any
    number of ranks), to start the power iteration."""
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n, :2]
    h = np.sin(x[:, 0] * 12989.8 + x[:, 1] * 78233.0) * 43758.5453
    h = h - np.floor(h)
    return np.column_stack([h, 1.0 - h]).ravel() - 0.5


def max_eigenvalue(K, mass, interface, V, iterations=500, rtol=1e-8) -> float:
    """λmax of M⁻¹(K + K_int) by power iteration with the Rayleigh quotient
    x·(K + K_int)x / x·Mx (which converges quadratically)."""
    x = K.createVecRight()
    y = K.createVecRight()
    mx = K.createVecRight()
    x.array[:] = _coordinate_noise(V)
    lam = 0.0
    for _ in range(iterations):
        K.mult(x, y)
        interface.add_spring_action(x, y)
        mx.array[:] = x.array_r * mass
        new = x.dot(y) / x.dot(mx)
        y.array[:] /= mass  # y = M⁻¹ (K + K_int) x
        y.scale(1.0 / y.norm())
        x, y = y, x
        converged = abs(new - lam) <= rtol * new
        lam = new
        if converged:
            break
    return lam


def round_down(x: float, digits: int = 3) -> float:
    """Round down to ``digits`` significant digits (makes dt reproducible across rank counts)."""
    e = math.floor(math.log10(x)) - digits + 1
    return math.floor(x / 10.0**e + 1e-9) * 10.0**e


def _per_point(value, x1, width=None):
    """A per-point array from a scalar/array or a callable of x1."""
    v = value(x1) if callable(value) else value
    v = np.asarray(v, dtype=np.float64)
    shape = (len(x1),) if width is None else (len(x1), width)
    return np.array(np.broadcast_to(v, shape), dtype=np.float64, order="C")  # a writable copy
