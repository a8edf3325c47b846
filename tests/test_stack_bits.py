"""What fricfem's results are made of must not change with the stack under it
(dolfinx 0.5.2 / 0.9 / 0.11, numpy 1.24 to 2.3, reference BLAS or OpenBLAS):
each number that once came from the installed libraries and differed between
them, checked against what fricfem computes from the grid alone.

The interface's 4-point Gauss rule came from ``np.polynomial.legendre.leggauss(4)``,
which takes the points from LAPACK's eigenvalues: numpy 2.3 (the dolfinx 0.11
wheel's, with its own OpenBLAS) gives weights 2 ulp away from numpy 1.24 / 2.2's
(0x1.64340f7e7b666p-2 against ...668p-2).  Every interface point's weight then
differed in its last bit, and the sliding front made that O(1) differences in
three of the four goldens on 0.11.  fricfem now holds the rule as a fixed table.
"""

from __future__ import annotations

import importlib.util
from decimal import Decimal, getcontext

import numpy as np
from mpi4py import MPI

from fricfem.model import interface as iface_mod
from fricfem.model import mesh
from fricfem.model.assembly import function_space
from fricfem.model.numbering import numbering

#: the rule as fricfem has always used it (numpy <= 2.2's leggauss(4); the goldens hold these bits)
XI_HEX = ("-0x1.b8e6dbcf63985p-1", "-0x1.5c23fd9dd3dfcp-2", "0x1.5c23fd9dd3dfcp-2", "0x1.b8e6dbcf63985p-1")
W_HEX = ("0x1.64340f7e7b668p-2", "0x1.4de5f840c24cbp-1", "0x1.4de5f840c24cbp-1", "0x1.64340f7e7b668p-2")
#: numpy 2.3's leggauss(4) weights (seen with the dolfinx 0.11 wheel)
W_HEX_NUMPY23 = ("0x1.64340f7e7b666p-2", "0x1.4de5f840c24cdp-1", "0x1.4de5f840c24cdp-1", "0x1.64340f7e7b666p-2")


def _hex(a) -> list:
    return [float(v).hex() for v in a]


def test_gauss_rule_is_the_fixed_table_and_exact_to_degree_7():
    """The rule's bits are the table's on every numpy; it is a Gauss rule: the
    points within 1 ulp and the weights within 4 ulp of the closed forms
    ±√(3/7 ∓ 2/7 √(6/5)), (18 ± √30)/36, and it integrates x^k on [-1, 1] for
    k <= 7 (2·4 − 1) to round-off."""
    assert _hex(iface_mod.GAUSS_XI) == list(XI_HEX)
    assert _hex(iface_mod.GAUSS_W) == list(W_HEX)
    getcontext().prec = 50
    s65, s30 = (Decimal(6) / 5).sqrt(), Decimal(30).sqrt()
    x_in, x_out = (Decimal(3) / 7 - Decimal(2) / 7 * s65).sqrt(), (Decimal(3) / 7 + Decimal(2) / 7 * s65).sqrt()
    w_in, w_out = (18 + s30) / 36, (18 - s30) / 36
    exact_x = [-x_out, -x_in, x_in, x_out]
    exact_w = [w_out, w_in, w_in, w_out]
    for got, want, ulps in [(iface_mod.GAUSS_XI, exact_x, 1), (iface_mod.GAUSS_W, exact_w, 4)]:
        for g, w in zip(got, want):
            assert abs(Decimal(float(g)) - w) <= ulps * Decimal(np.spacing(abs(float(g)))), (g, w)
    for k in range(8):
        want = 2.0 / (k + 1) if k % 2 == 0 else 0.0
        assert abs(np.sum(iface_mod.GAUSS_W * iface_mod.GAUSS_XI ** k) - want) < 1e-15, k


def test_gauss_rule_does_not_come_from_the_installed_numpy(monkeypatch):
    """The interface module loaded under a numpy whose leggauss rounds as numpy
    2.3's does (the 0.11 wheel's) keeps the table's weights: the rule does not
    pass through LAPACK."""
    real = np.polynomial.legendre.leggauss

    def numpy23(deg):
        x, w = real(deg)
        if deg == 4:
            w = np.array([float.fromhex(h) for h in W_HEX_NUMPY23])
        return x, w

    monkeypatch.setattr(np.polynomial.legendre, "leggauss", numpy23)
    spec = importlib.util.spec_from_file_location("fricfem.model._interface_probe", iface_mod.__file__)
    probe = importlib.util.module_from_spec(spec)  # not put in sys.modules: the real module stays
    spec.loader.exec_module(probe)
    assert _hex(probe.GAUSS_W) == list(W_HEX)
    assert _hex(probe.GAUSS_XI) == list(XI_HEX)


def test_interface_weights_and_points_from_the_grid_alone(comm):
    """Each rank's interface Gauss points x1 and weights wq (Gauss weight × half
    segment length) have the bits of the grid's x1 nodes and the fixed table, on
    any number of ranks; the weights add up to the interface's length."""
    spec = mesh.MeshSpec(length=0.03, height=0.01, dx=1e-3, dy=1e-3, fine_x0=0.0, fine_x1=0.012,
                         fine_height=0.002, impact_b=0.005, grading=1.3, max_size=3e-3)
    pm = mesh.build(spec, comm)
    V = function_space(pm.mesh)
    num = numbering(pm, V)
    x = np.zeros(2 * len(num.owned_nodes))
    from petsc4py import PETSc

    template = PETSc.Vec().createMPI((len(x), PETSc.DECIDE), bsize=2, comm=comm)
    g = iface_mod.build_geometry(num, template, comm)
    # from the grid alone: the lower interface nodes by x1, each segment's 4 points
    lo = np.unique(num.facets[num.facet_tags == mesh.TAGS["interface_lower"]])
    xn = np.sort(num.x[lo, 0])
    assert np.array_equal(g.x1_nodes, xn)
    xi = np.array([float.fromhex(h) for h in XI_HEX])
    w = np.array([float.fromhex(h) for h in W_HEX])
    half = 0.5 * (xn[g.segments + 1] - xn[g.segments])
    mid = 0.5 * (xn[g.segments + 1] + xn[g.segments])
    checks = {"wq": _hex(g.wq) == _hex((half[:, None] * w[None, :]).ravel()),
              "x1": _hex(g.x1) == _hex((mid[:, None] + half[:, None] * xi[None, :]).ravel())}
    lengths = np.unique(np.concatenate(comm.allgather(half)))
    total = comm.allreduce(float(np.sum(g.wq)), op=MPI.SUM)
    template.destroy()
    bad = [(r, k) for r, c in enumerate(comm.allgather(checks)) for k, ok in c.items() if not ok]
    assert not bad, f"(rank, array) not the grid's bits: {bad}"
    assert len(lengths) > 2 and lengths.min() > 0  # graded: segments of several lengths
    assert abs(total - spec.length) < 1e-15
