"""The time loop's outputs: interface snapshots buffered on each rank and gathered
at flushes (rows bit-identical to the interface at their steps), the loop's cost
split by part in summary.json, the slip-rate spike in the periodic summary and on
the final progress line, and a missing mode read as unknown."""

from __future__ import annotations

import json
import time
from types import SimpleNamespace

import numpy as np
import pytest

from fricfem import load_scene, open_run
from fricfem.analysis import measures
from fricfem.observe import FLUSH_ROWS, LOOP_PARTS
from fricfem.output.recorder import interface_profile
from fricfem.output.quantities import QUANTITIES
from fricfem.runner import run_scene

COARSE = ["mesh.preset='coarse'", "output.fields=[]", "loading.v_imp=40"]


def test_buffered_snapshots_are_the_interface_at_their_steps(comm, tmp_dir_shared):
    """Every row of interface.h5 equals, bit for bit, the interface read directly
    (gathered and sorted by x1) right after its step — across several flushes and
    on any number of ranks, so the buffered gather keeps the rows, the points and
    their order."""
    scene = load_scene("case1", COARSE + ["time.end=6e-6", "output.interface_every=0.1e-6"])
    seen = {}

    def probe(st):
        if (st.n - 1) % every[0] == 0:  # a snapshot step (the monitor's rule)
            seen[st.n] = interface_profile(run_model[0].interface, st.points, [q.name for q in QUANTITIES])

    from fricfem.model.build import build_model

    run_model, every = [], []

    def build(sc, c):
        pm, model = build_model(sc, c)
        run_model.append(model)
        every.append(max(1, int(round(sc.output["interface_every"] / model.dt))))
        return pm, model

    out = tmp_dir_shared / "run"
    summary = run_scene(scene, out, comm, quiet=True, on_step=probe, build=build)
    assert summary["complete"]
    if comm.rank == 0:
        run = open_run(out)
        steps = sorted(seen)
        assert len(run.t) == len(steps) > 2 * FLUSH_ROWS  # several flushes
        assert np.array_equal(run.x1, seen[steps[0]]["x1"])
        for k, n in enumerate(steps):
            for q in QUANTITIES:
                assert np.array_equal(run.quantity(q.name)[k], seen[n][q.name].astype(run.quantity(q.name).dtype)), \
                    (n, q.name)
        assert np.array_equal(run.quantity("slip_rate")[:, :].max() > 0, True)  # it slid: rows not trivial


def test_station_rows_are_the_interface_at_every_step(comm, tmp_dir_shared):
    """Every station's row of every step equals, bit for bit, the interface read
    directly after that step at the station's point — stations on both ranks'
    parts of the interface, across several flushes, ``mu_app`` computed from the
    rows as from the points, ``open`` as 0/1."""
    xs = {"a": 0.5e-3, "b": 30e-3, "c": 70e-3, "d": 120e-3}
    table = ", ".join(f"{k} = {v!r}" for k, v in xs.items())
    scene = load_scene("case1", COARSE + ["time.end=15e-6", f"output.stations={{ {table} }}"])
    seen = []

    def probe(st):
        seen.append(interface_profile(run_model[0].interface, st.points, [q.name for q in QUANTITIES]))

    from fricfem.model.build import build_model

    run_model = []

    def build(sc, c):
        pm, model = build_model(sc, c)
        run_model.append(model)
        return pm, model

    out = tmp_dir_shared / "stations"
    summary = run_scene(scene, out, comm, quiet=True, on_step=probe, build=build)
    assert summary["complete"] and summary["steps"] == len(seen) > 3 * FLUSH_ROWS
    if comm.rank == 0:
        run = open_run(out)
        assert sorted(run.stations) == sorted(xs)
        x1 = seen[0]["x1"]
        for name, x in xs.items():
            st = run.stations[name]
            k = int(np.argmin(np.abs(x1 - x)))
            assert st["x1"] == x1[k] and len(st["time"]) == len(seen)
            for q in QUANTITIES:
                want = np.array([row[q.name][k] for row in seen], dtype=np.float64)
                assert np.array_equal(np.asarray(st[q.name]), want), (name, q.name)
        assert max(np.max(run.stations[n]["slip_rate"]) for n in xs) > 0  # it slid: rows not trivial
    if comm.size > 1:  # the stations lie on more than one rank
        allx = interface_profile(run_model[0].interface, run_model[0].interface.initial, [])["x1"]
        mine = run_model[0].interface.geometry.x1
        held = sum(1 for x in xs.values() if np.any(mine == allx[np.argmin(np.abs(allx - x))]))
        assert sum(1 for h in comm.allgather(held) if h) > 1


def test_summary_splits_the_loop_cost_by_part(comm, tmp_dir_shared):
    """summary.json's loop_cost: every part timed (µs per step, steps after the
    first), the parts summing to the total, the total within the loop's measured
    wall time, the energy steps counted as the cadence says, the snapshots and
    the watch not free."""
    every_e = 7
    scene = load_scene("case1", COARSE + ["time.end=4e-6", f"output.energy_every={every_e}"])
    out = tmp_dir_shared / "cost"
    s = run_scene(scene, out, comm, quiet=True)
    lc = s["loop_cost"]
    n = s["steps"]
    assert lc["steps"] == n - 1
    # steps 2..n: those starting at state.n = 1..n-1 on the cadence, and the end energies' step (taken and
    # undone after the last one: fricfem.step.stepper.energies_at)
    expected = sum(1 for k in range(1, n) if k % every_e == 0) + 1
    assert lc["energy_steps"] == expected
    parts = ["step", "energy", *LOOP_PARTS[2:]]
    assert all(lc[k] >= 0 for k in parts)
    assert lc["total"] == pytest.approx(sum(lc[k] for k in parts), rel=1e-9)
    assert lc["outputs"] == pytest.approx(lc["total"] - lc["step"], rel=1e-9)
    assert lc["step"] > 0 and lc["watch"] > 0 and lc["snapshots"] > 0
    assert lc["total"] <= lc["wall"] * 1.0001  # the parts are inside the loop's wall time
    assert 0 < lc["outputs_share"] < 1
    # the step's parts on every rank, inside the step's time on rank 0
    assert len(lc["step_by_rank"]) == comm.size
    assert all(r["sweep"] > 0 and r["interface"] > 0 and r["wait"] >= 0 for r in lc["step_by_rank"])
    assert sum(lc["step_by_rank"][0].values()) <= (lc["step"] + lc["energy"]) * 1.0001
    if comm.rank == 0:
        assert json.loads((out / "summary.json").read_text())["loop_cost"] == s["loop_cost"]


def test_periodic_summary_and_final_progress_carry_the_spike(comm, tmp_dir_shared, capsys):
    """With a low report threshold the spike is in summary.json already while the
    run goes (the periodic flush), and in the run's last progress line."""
    # the first spike at 4.5 µs (step 17 of 45 on the coarse mesh); the summary so far is
    # rewritten every output.flush_every seconds (1 ms here: at every flush, every 10 steps),
    # by a background thread: looked at after every step, so that the writer's lag
    # (milliseconds) cannot hide the later ones
    scene = load_scene("case1", COARSE + ["time.end=12e-6", "output.interface_every=0.05e-6",
                                          "watchdog.max_slip_rate=0.01", "output.flush_every=1e-3"])
    out = tmp_dir_shared / "spike"
    during = []

    def read():
        return json.loads((out / "summary.json").read_text())

    def look(st):
        if comm.rank == 0:
            doc = read()
            if st.n == 30:  # the event, not the writer's lag: a summary submitted after the spike is on disk
                give_up = time.monotonic() + 120  # (only so that a broken writer fails instead of hanging)
                while doc["steps"] < 20 and time.monotonic() < give_up:  # a flush every 10 steps: one in 20..30
                    time.sleep(0.005)
                    doc = read()
            if doc["steps"] > 0:
                during.append(doc.get("slip_rate_spike"))

    import threading

    threads = threading.active_count()
    s = run_scene(scene, out, comm, quiet=False, on_step=look)
    assert threading.active_count() == threads  # the summary's writer ended with the run
    assert s["slip_rate_spike"]["above_threshold"]
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert during and all(d is not None for d in during)  # every periodic summary has it
        assert any(d["above_threshold"] for d in during)
        last = [line for line in err.replace("\r", "\n").splitlines() if "µs" in line][-1]
        assert f"t = {s['t_s'] * 1e6:7.2f} / " in last  # the final line, at the run's last time
        assert "spike" in last and "m/s at x1 =" in last


def test_a_run_without_a_mode_reads_unknown():
    """measures.mode: the summary's label as it is (none is the classifier's 'no
    sliding'), unknown when there is none (watchdog, still running, no diagnostics)."""
    run = lambda summary: SimpleNamespace(summary=summary)  # noqa: E731
    assert measures.mode(run({"mode": {"label": "none"}})) == "none"
    assert measures.mode(run({"mode": {"label": "crack-like"}})) == "crack-like"
    assert measures.mode(run({"mode": {"label": "unknown", "partial_label": "none"}})) == "unknown"
    assert measures.mode(run({"complete": False})) == "unknown"
    assert measures.mode(run({"watchdog": "stopped", "mode": None})) == "unknown"


def test_loop_cost_benchmark_smoke(comm, tmp_dir_shared):
    """benchmarks/loop_cost.py on the coarse mesh: per run the loop's parts and the
    bare MatMult of the same model, the ratios from them, the medians over runs."""
    import importlib

    bench = importlib.import_module("loop_cost")  # benchmarks/ is on pytest's pythonpath
    res = bench.measure("case1", ["mesh.preset='coarse'", "time.end=4e-6", "output.fields=[]"], 2,
                        tmp_dir_shared / "run", comm)
    assert len(res["runs"]) == 2 and res["ranks"] == comm.size
    for r in res["runs"]:
        lc = r["loop_cost_us"]
        assert r["matmult_us"] > 0 and lc["wall"] > 0
        assert r["loop_over_matmult"] == pytest.approx(lc["wall"] / r["matmult_us"])
        assert r["step_over_matmult"] == pytest.approx(lc["step"] / r["matmult_us"])
    m = res["median"]
    assert sorted(r["loop_over_matmult"] for r in res["runs"])[0] <= m["loop_over_matmult"]
    assert "loop / MatMult" in bench.report(res)
