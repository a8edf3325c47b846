"""Field output: displacement, velocity and σ1 − σ2 (prestress included) to XDMF/HDF5.

Stresses are evaluated only when a field snapshot is written: a run that asks
for no fields never compiles or evaluates the stress expression.
"""

from __future__ import annotations

import ufl
from dolfinx import fem
from dolfinx.io import XDMFFile


def principal_difference(sig):
    """σ1 − σ2 of a 2×2 UFL tensor: 2 √(((σ11 − σ22)/2)² + σ12²)."""
    return 2.0 * ufl.sqrt(((sig[0, 0] - sig[1, 1]) / 2.0) ** 2 + sig[0, 1] ** 2)


def stress_with_prestress(u, material, sigma0: float, tau0: float = 0.0):
    """Total in-plane stress: the increment from ``u`` plus the uniform prestress
    S22 = −Σ0, S12 = τ0 (UFL expression)."""
    eps = ufl.sym(ufl.grad(u))
    sig = 2.0 * material.mu * eps + material.lmbda * ufl.tr(eps) * ufl.Identity(2)
    return sig + ufl.as_matrix([[0.0, tau0], [tau0, -sigma0]])


class FieldWriter:
    """Write u, v and σ1 − σ2 (cell-wise, DG0) at chosen times to ``path`` (.xdmf + .h5)."""

    def __init__(self, path, V, material, sigma0: float, tau0: float = 0.0):
        msh = V.mesh
        self.V = V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        W = fem.FunctionSpace(msh, ("DG", 0))
        self.s = fem.Function(W, name="stress_difference")
        expr = principal_difference(stress_with_prestress(self.u, material, sigma0, tau0))
        self.expr = fem.Expression(expr, W.element.interpolation_points())
        self.n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self.file = XDMFFile(msh.comm, str(path), "w")
        self.file.write_mesh(msh)

    def _fill(self, fn, vec):
        fn.x.array[: self.n_owned] = vec.array_r
        fn.x.scatter_forward()

    def write(self, state) -> None:
        """Write the state's u^n, v^{n−½} and σ1 − σ2 at t^n (collective)."""
        self._fill(self.u, state.u)
        self._fill(self.v, state.v)
        self.s.interpolate(self.expr)
        for fn in (self.u, self.v, self.s):
            self.file.write_function(fn, state.t)  # dolfinx rewrites the .xdmf on every write

    def close(self) -> None:
        self.file.close()
