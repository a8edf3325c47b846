"""fricfem's bulk discretisation against a manufactured solution: observed L2
orders in h (dt/h fixed) and in dt, plane stress and plane strain, on its
crossed-triangle two-plate mesh with its lumped mass and its production step
(benchmarks/mms.py holds the machinery and the full ladders;
docs/verification_bulk.md the method).  Built on COMM_WORLD: 1 or 2 ranks."""

from __future__ import annotations

import mms  # benchmarks/ is on pytest's pythonpath
import pytest

LEVELS = (8, 16, 32)  # n × n cells a plate, dt ∝ h at 0.9 of the stable step

# Orders and finest-level errors (L2 at T over the largest L2 norm of the exact
# field at the checkpoints) the ladders must reach.  Measured on 2 ranks
# (benchmarks/results/mms.md): u orders 1.98 … 2.04, v orders 1.92 … 2.06; at
# 32 × 32, u 5.6e-3 … 6.3e-3 and v 5.8e-3 … 6.0e-3 (traction, struck), u 1.3e-3
# … 1.5e-3 and v 1.2e-3 … 1.4e-3 (dirichlet).
MIN_ORDER_U = 1.9
MIN_ORDER_V = 1.85
MAX_ERR_U = {"traction": 8e-3, "struck": 8e-3, "dirichlet": 2e-3}
MAX_ERR_V = {"traction": 8e-3, "struck": 8e-3, "dirichlet": 2e-3}

_BUILT: dict = {}


def ladder(comm, plane, bc="traction", start="projected", stepper="fused", levels=LEVELS):
    return mms.h_ladder(levels, plane, comm, bc, start, stepper, 0.9, _BUILT.setdefault(comm.size, {}))


@pytest.mark.parametrize("plane,bc", [("stress", "traction"), ("strain", "traction"), ("stress", "struck"),
                                      ("strain", "dirichlet")])
def test_h_ladder_second_order(comm, plane, bc):
    """Displacement and velocity converge at second order in h (dt/h fixed),
    with every boundary row free (exact traction), prescribed as fricfem's
    struck edge, or all prescribed."""
    lad = ladder(comm, plane, bc)
    fin = lad["rows"][-1]
    assert all(o >= MIN_ORDER_U for o in lad["order_u_end"] + lad["order_u_max"]), lad["order_u_end"]
    assert all(o >= MIN_ORDER_V for o in lad["order_v_end"] + lad["order_v_max"]), lad["order_v_end"]
    assert fin["err_u_end"] < MAX_ERR_U[bc] and fin["err_v_end"] < MAX_ERR_V[bc], fin
    assert 0.85 < fin["dt_over_crit"] < 0.9  # the stable step is fricfem's λmax estimate


def test_dt_ladder_second_order(comm):
    """On one mesh, the temporal error (against a step 8 times smaller than the
    smallest) falls as dt² from 0.9 of the stable step down."""
    p = mms.get_plates(_BUILT.setdefault(comm.size, {}), 16, "stress", comm)
    lad = mms.dt_ladder(p, (0.9, 0.45, 0.225), ref_factor=8)
    assert all(o >= 1.95 for o in lad["order_time"]), lad["order_time"]
    fin = lad["rows"][-1]
    assert fin["err_time"] < 0.1 * fin["err_u_end"]  # the error against u* is then the spatial one


def test_fused_step_equals_plain_step(comm):
    """The production step (FusedBulk + the load after it) and K.mult + numpy give
    the same errors, with prescribed rows."""
    p = mms.get_plates(_BUILT.setdefault(comm.size, {}), 16, "strain", comm)
    a = mms.solve(p, 48, "struck", stepper="fused")
    b = mms.solve(p, 48, "struck", stepper="plain")
    for key in ("err_u", "err_v"):
        for x, y in zip(a[key], b[key]):
            assert abs(x - y) <= 1e-9 * y, (key, a[key], b[key])


def test_the_start_matters(comm):
    """The test can see a first-order defect: v^{-1/2} = v*(0) (no half-step
    shift) makes u first order.  The nodal interpolant of u*(0) lies O(h) from
    the discrete solution in energy (the corner/centre mismatch of the crossed
    triangles), so its velocity error cannot stay second order."""
    naive = ladder(comm, "stress", "traction", "naive")
    assert all(0.9 < o < 1.1 for o in naive["order_u_end"]), naive["order_u_end"]
    p = mms.get_plates(_BUILT.setdefault(comm.size, {}), 8, "stress", comm)
    q = mms.get_plates(_BUILT[comm.size], 32, "stress", comm)
    coarse, fine = p.start_mismatch("traction"), q.start_mismatch("traction")
    assert 3.5 < coarse["energy"] / fine["energy"] < 4.5  # O(h) in energy over two halvings
    assert 14.0 < coarse["l2"] / fine["l2"] < 18.0  # O(h²) in L2
    # the cause: the nodal equations are off by O(1), independent of h, with
    # opposite signs at corners and centres and a zero mass-weighted mean
    for r in (p.nodal_residual(), q.nodal_residual()):
        assert r["corner"] > 0.1 and r["centre"] > 0.2 and abs(r["mass_weighted_mean"]) < 0.01, r


@pytest.mark.slow
def test_h_ladder_four_levels(comm):
    """One level more (64 × 64 a plate, 33k dofs), both plane states, all three
    boundary treatments: u at second order (≥ 1.95) on every pair, v ≥ 1.9 at the last."""
    for plane in mms.PLANES:
        for bc in mms.BCS:
            lad = ladder(comm, plane, bc, levels=(8, 16, 32, 64))
            assert all(o >= 1.95 for o in lad["order_u_end"]), (plane, bc, lad["order_u_end"])
            assert lad["order_v_end"][-1] >= 1.9, (plane, bc, lad["order_v_end"])
            assert lad["rows"][-1]["err_u_end"] < MAX_ERR_U[bc] / 4.0
