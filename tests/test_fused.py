"""The fused bulk step (:mod:`fricfem.step.fused`) against the two-pass step
(tests/reference/two_pass.py), and the throughput benchmark in smoke mode.
Run under ``mpirun -n 2``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import load_scene
from fricfem.friction.povirk_needleman_integrator import _PREV_T, _PREV_V
from fricfem.model.build import build_model
from fricfem.step import State, evolve, step
from reference.two_pass import step_two_pass

ROOT = Path(__file__).resolve().parents[1]
RTOL = 1e-12  # round-off


def same_bits(a, b) -> bool:
    """``a`` and ``b`` hold the same bits: same dtype, shape and bytes.  Stricter
    than ``np.array_equal`` (tells -0.0 from 0.0), and true for NaN in the same
    slots, which ``np.array_equal`` never is (NaN != NaN): a law's memo keeps NaN
    where nothing is remembered (:func:`fricfem.friction.base.storage`)."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def rel_diff(a, b, comm) -> float:
    num = comm.allreduce(float(np.abs(a - b).max(initial=0.0)), op=MPI.MAX)
    den = comm.allreduce(float(np.abs(a).max(initial=0.0)), op=MPI.MAX)
    return num / den


def test_fused_step_equals_two_pass_step_while_sliding(comm):
    """Coarse case I at V_imp = 10 m/s: over 100 steps (the interface slides near
    the struck edge) the fused step gives the same u, v and interface tractions
    as the two-pass step bit for bit, and the same strain energy and external
    work to round-off (those sums run in another order)."""
    scene = load_scene("case1", ["loading.v_imp=10", "mesh.preset=coarse"])
    _, model = build_model(scene, comm)
    every, nsteps = 25, 100

    ref = State(model)
    strain_ref = [e["strain"] for _, e in evolve(model, ref, nsteps * model.dt, every, stepper=step_two_pass) if e]
    ref_points = ref.points

    st = State(model)
    strain = [e["strain"] for _, e in evolve(model, st, nsteps * model.dt, every) if e]  # the fused sweep
    points = st.points

    assert len(strain) == len(strain_ref) == nsteps // every
    assert comm.allreduce(int((points.slip > 0).sum())) > 0, "the interface should slide"
    same = np.array_equal(ref.u.array_r, st.u.array_r) and np.array_equal(ref.v.array_r, st.v.array_r)
    assert comm.allreduce(int(same), op=MPI.MIN), "u, v differ from the two-pass step"
    for name in ("Ts", "Tn", "slip", "slip_rate"):
        i = points._fields.index(name)
        assert comm.allreduce(int(np.array_equal(ref_points[i], points[i])), op=MPI.MIN), name
    np.testing.assert_allclose(strain, strain_ref, rtol=RTOL)
    w_ref, w = comm.allreduce(ref.work_ext), comm.allreduce(st.work_ext)
    assert w_ref > 0 and abs(w - w_ref) <= RTOL * abs(w_ref)
    assert st.t == ref.t


def test_fused_rows_with_off_rank_columns(comm):
    """Plates 137 mm long and 30 mm tall: the partition cuts across them, so
    on 2 ranks rows have off-rank columns (and the interface's segments and
    nodes live on different ranks).  Over 100 steps of Case I loading at
    10 m/s the fused step equals the two-pass oracle bit for bit."""
    scene = load_scene("case1", ["loading.v_imp=10", "mesh.preset=coarse", "mesh.height=0.03",
                                 "mesh.impact_b=0.02"])
    _, model = build_model(scene, comm)
    if comm.size > 1:
        assert comm.allreduce(len(model.bulk.rows.ghost)) > 0, "the partition should cut a plate"
    out = []
    for stepper in (step_two_pass, step):
        st = State(model)
        for _ in evolve(model, st, 100 * model.dt, stepper=stepper):
            pass
        out.append((st.u.array_r.copy(), st.v.array_r.copy(), list(st.points)))
    (u0, v0, p0), (u1, v1, p1) = out
    same = same_bits(u0, u1) and same_bits(v0, v1) and all(same_bits(a, b) for a, b in zip(p0, p1))
    assert comm.allreduce(int(same), op=MPI.MIN)
    # Povirk-Needleman's storage ends with the rigid verb's T^{n-1}, V^{n-1/2}: the
    # elastic step leaves them NaN (no history), so the comparison above meets NaN
    assert scene.law == "povirk_needleman"
    assert np.isnan(p1[st.points._fields.index("state")][:, [_PREV_T, _PREV_V]]).all()
    assert comm.allreduce(float(np.abs(u1).max()), op=MPI.MAX) > 0


def test_throughput_benchmark_smoke(comm, tmp_dir_shared):
    """benchmarks/throughput.py --smoke writes its table, JSON and figure."""
    import throughput as bench  # benchmarks/ is on pytest's pythonpath

    data = bench.main(["--smoke", "--out", str(tmp_dir_shared)], comm)
    entry = data["runs"][f"coarse/{comm.size}/onset"]
    for key in ("fused", "matmult_aij", "matmult_sell", "interface"):
        assert entry["us_per_step"][key] > 0, key
    assert np.isfinite(entry["ratio_fused"])
    if comm.rank == 0:
        assert json.loads((tmp_dir_shared / "throughput.json").read_text())["runs"]
        assert (tmp_dir_shared / "throughput.png").stat().st_size > 0


def test_skipping_quiet_rows_is_the_full_computation(comm):
    """Coarse Case I at 10 m/s to 20 µs (the interface slides near the edge):
    the fused step that skips the rows the motion has not reached gives the same
    u, v and interface data as the one that computes every row, bit for bit, and
    it does skip rows (about half of them in the first microseconds)."""
    scene = load_scene("case1", ["loading.v_imp=10", "mesh.preset=coarse", "time.end=20e-6", "output.fields=[]"])
    _, model = build_model(scene, comm)
    out, skipped = {}, []
    for skip in (False, True):
        st = State(model, skip_quiet=skip)
        for _ in evolve(model, st, scene.t_end):
            if skip:
                skipped.append(1.0 - comm.allreduce(st.active_fraction) / comm.size)
        out[skip] = (st.u.array_r.copy(), st.v.array_r.copy(), list(st.points))
    assert comm.allreduce(int((st.points.slip > 0).sum())) > 0, "the interface should slide"
    assert max(skipped[:5]) > 0.4
    # rows wake and never fall asleep again, until the motion has reached them all
    assert all(a >= b for a, b in zip(skipped, skipped[1:])) and skipped[-1] < skipped[0]
    u0, v0, p0 = out[False]
    u1, v1, p1 = out[True]
    assert comm.allreduce(int(np.array_equal(u0, u1) and np.array_equal(v0, v1)), op=MPI.MIN)
    for name in ("Ts", "Tn", "slip", "slip_rate"):
        i = st.points._fields.index(name)
        assert rel_diff(p0[i], p1[i], comm) <= RTOL, name  # in fact 0
        assert np.array_equal(p0[i], p1[i]), name


def test_a_state_set_by_hand_is_woken(comm):
    """A state stepped from rest skips rows; one whose u is written by hand (a
    restored snapshot) is woken and then steps every row, and gives the same
    result as a state that never skipped."""
    scene = load_scene("case1", ["mesh.preset=coarse", "loading.v_imp=10"])
    _, model = build_model(scene, comm)
    st = State(model)
    step(model, st)
    assert st.active_fraction < 1.0
    results = []
    for skip in (True, False):
        st = State(model, skip_quiet=skip)
        st.u.array[:] = 1e-9 * np.sin(np.arange(len(st.u.array)))  # a state set by hand
        if skip:
            st.wake()
            assert st.active_fraction == 1.0
        for _ in evolve(model, st, 5 * model.dt):
            pass
        results.append(st.u.array_r.copy())
    assert comm.allreduce(int(np.array_equal(results[0], results[1])), op=MPI.MIN)
