"""Rupture diagnostics of nucleated ruptures (fricfem/analysis/rupture.py): the
rupture-time field t_r(x1), the rupture speed along the fault (each direction
apart) and between stations, the supershear transition, and their place in
summary.json and the space-time figure.

Ground truth not of fricfem's making: synthetic histories whose front x1(t) is
prescribed (a bilateral rupture from a patch, sub-Rayleigh one way, jumping to
c_s < V_r < √2 c_s and then above √2 c_s the other way), and on the shipped
peer scenes the stations' own threshold crossings, step by step.

Under ``mpirun -n 2``: the runs are on both ranks; rank 0 reads and draws.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene, runner
from fricfem.analysis import rupture
from fricfem.output.rundir import open_interface
from fricfem.model.material import Material
from fricfem.scene.schema import SCHEMA

COMM = MPI.COMM_WORLD
RANK = COMM.rank
SPEEDS = Material(plane="strain").speeds()  # c_s = 1256 m/s, √2 c_s = 1776 m/s
X = np.round(np.arange(0.0, 70.0001e-3, 1e-4), 12)  # a point every 0.1 mm
ROWS = np.arange(0.0, 40e-6 + 1e-12, 0.2e-6)  # snapshots every 0.2 µs
T0, PATCH = 1e-6, (28e-3, 32e-3)  # the patch breaks at once at 1 µs
# toward +x1: 1000 m/s to 45 mm, 1500 m/s (supershear) to 55 mm, then 2000 m/s (> √2 c_s); toward −x1: 800 m/s
KINK_SS, KINK_SQ = 45e-3, 55e-3


def front_time(x) -> np.ndarray:
    """The prescribed rupture time [s] of points ``x`` [m]."""
    x = np.asarray(x, dtype=float)
    t = np.full_like(x, T0)
    r = x > PATCH[1]
    t[r] = (T0 + (np.minimum(x[r], KINK_SS) - PATCH[1]) / 1000.0 + np.clip(x[r] - KINK_SS, 0, KINK_SQ - KINK_SS) / 1500.0
            + np.clip(x[r] - KINK_SQ, 0, None) / 2000.0)
    left = x < PATCH[0]
    t[left] = T0 + (PATCH[0] - x[left]) / 800.0
    return t


def exponential_history(times, x, tau=0.05e-6):
    """A rate-and-state-like rate: |V| = threshold · exp((t − t_r)/τ), capped at 5 m/s."""
    with np.errstate(over="ignore"):
        return np.minimum(5.0, rupture.THRESHOLD * np.exp((times[:, None] - front_time(x)[None, :]) / tau))


def test_the_threshold_default_is_the_scene_keys():
    key = SCHEMA["output"]["rupture_threshold"]
    assert key.default == rupture.THRESHOLD == 1e-3 and key.unit == "m/s"


def test_a_prescribed_front_is_recovered_with_its_speeds_and_supershear_transition():
    block = rupture.diagnose(ROWS, X, exponential_history(ROWS, X), SPEEDS)
    exact = front_time(X)
    t_r = np.array(block["field"]["time_s"], dtype=float)
    # log-linear interpolation of an exponential rise: exact to round-off
    assert np.max(np.abs(t_r - exact)) < 1e-15
    nuc = block["nucleation"]
    assert nuc["time_s"] == pytest.approx(T0) and abs(nuc["x1_m"] - 0.5 * sum(PATCH)) <= 1e-4
    v = np.array([np.nan if a is None else a for a in block["field"]["v_r_m_s"]], dtype=float)
    # the smoothed speed (9-point window) away from the kinks: the prescribed speeds within 0.1 %
    for lo, hi, speed in ((2e-3, 27e-3, 800.0), (33e-3, 44.4e-3, 1000.0), (45.6e-3, 54.4e-3, 1500.0),
                          (55.6e-3, 69e-3, 2000.0)):
        sel = (X >= lo) & (X <= hi)
        assert np.allclose(v[sel], speed, rtol=1e-3), (lo, hi, v[sel])
    by = {d["direction"]: d for d in block["directions"]}
    plus, minus = by["+x1"], by["-x1"]
    # the transitions where they were prescribed, within half the speed window (0.4 mm)
    assert abs(plus["supershear"]["x1_m"] - KINK_SS) <= 0.4e-3, plus["supershear"]
    assert abs(plus["above_sqrt2_c_s"]["x1_m"] - KINK_SQ) <= 0.4e-3, plus["above_sqrt2_c_s"]
    assert plus["supershear"]["time_s"] == pytest.approx(front_time([plus["supershear"]["x1_m"]])[0], abs=1e-15)
    # the patch broke at once: no transition toward −x1, whose front is sub-Rayleigh throughout
    assert minus["supershear"] is None and minus["above_sqrt2_c_s"] is None
    assert minus["mean_v_r_m_s"] == pytest.approx(800.0, rel=1e-9)
    assert plus["reached_x1_m"] == pytest.approx(X[-1]) and minus["reached_x1_m"] == pytest.approx(0.0)


def test_stations_give_their_own_crossings_and_the_speed_between_them():
    dt = 10e-9  # stations every step
    names = {"a": 10e-3, "b": 20e-3, "c": 30e-3, "d": 36e-3, "e": 42e-3, "f": 60e-3, "g": 66e-3}
    steps = np.arange(0.0, 40e-6, dt)
    stations = {n: (x, steps, exponential_history(steps, np.array([x]))[:, 0]) for n, x in names.items()}
    block = rupture.diagnose(ROWS, X, exponential_history(ROWS, X), SPEEDS, stations=stations)
    got = {s["name"]: s["time_s"] for s in block["stations"]}
    for n, x in names.items():
        assert got[n] == pytest.approx(front_time([x])[0], abs=1e-15)
    between = {(b["from"], b["to"]): b for b in block["between_stations"]}
    assert between[("d", "e")]["v_r_m_s"] == pytest.approx(1000.0, rel=1e-9)
    assert between[("f", "g")]["v_r_m_s"] == pytest.approx(2000.0, rel=1e-9)
    assert between[("b", "a")]["v_r_m_s"] == pytest.approx(800.0, rel=1e-9)
    assert not any(b["in_patch"] for b in between.values())


def test_a_front_out_of_stick_is_placed_by_the_slip_of_the_interval():
    """A slip-weakening-like rate: zero until the front, then a jump to 2 m/s within one
    0.2 µs interval.  From the rows alone the crossing is up to one interval early;
    with the slip the rows hold, the midpoint rule is off by half the time since the
    jump, and never past the interval's start: within a third of the interval."""
    fine = np.arange(0.0, 40e-6 + 1e-12, 1e-9)
    rate = np.where(fine[:, None] >= front_time(X)[None, :], 2.0, 0.0)
    slip = np.cumsum(rate, axis=0) * 1e-9
    rows = np.searchsorted(fine, ROWS - 1e-13)
    no_slip = rupture.rupture_times(ROWS, rate[rows], rupture.THRESHOLD)
    with_slip = rupture.rupture_times(ROWS, rate[rows], rupture.THRESHOLD, slip[rows])
    outside = (X < PATCH[0] - 1e-9) | (X > PATCH[1] + 1e-9)
    err0 = np.abs(no_slip - front_time(X))[outside]
    err1 = np.abs(with_slip - front_time(X))[outside]
    assert err0.max() <= 0.2e-6 + 1e-12
    assert err1.max() <= 0.2e-6 / 3 + 1e-12, err1.max()
    assert err1.mean() < 0.5 * err0.mean()


def test_a_step_rate_out_of_stick_is_not_read_where_the_slip_stands_still():
    """The rigid kind's rate is its step's mean, V^{n+½} = (δ^{n+1} − δ^n)/dt at t^{n+½}.
    A slip that starts at t_s within a step (a ramp to 1 m/s in 1 ns: its 1 mm/s
    crossing 1 ps after t_s), sampled so at 200 onsets over two steps: read with the
    step's width, the crossing is never before the last whole step at which the slip
    still stood (t^n ≤ t_s), and within a step of the true one; read as rates at
    instants it always falls in the stuck step before."""
    dt, a = 20e-9, 1e9  # s; m/s² (1 m/s after 1 ns)
    thr = rupture.THRESHOLD
    steps = np.arange(0.0, 2e-6, dt)  # t^n
    mid = steps[:-1] + 0.5 * dt  # t^{n+½}
    t_s = 1e-6 + np.linspace(0.0, 2 * dt, 200, endpoint=False)

    def slip(t):  # ∫ min(a (t − t_s), 1) dt from t_s
        r = np.clip(t[:, None] - t_s[None, :], 0.0, None)
        return np.where(r < 1.0 / a, 0.5 * a * r ** 2, 0.5 / a + (r - 1.0 / a))

    d = slip(steps)
    rate = np.diff(d, axis=0) / dt
    true = t_s + thr / a
    stood = steps[np.argmax(d > 0.0, axis=0) - 1]  # the last t^n with δ^n = 0
    step = rupture.rupture_times(mid, rate, thr, width=dt)
    instant = rupture.rupture_times(mid, rate, thr)
    assert np.all(step >= stood - 1e-18)
    assert np.all(np.abs(step - true) < dt)
    k = np.argmax(rate >= thr, axis=0)
    i = np.arange(len(t_s))
    # out of a zero sample, past the threshold (else the step before slipped < thr, or the sample is thr itself)
    jump = (rate[k - 1, i] == 0.0) & (rate[k, i] > 1.01 * thr)
    assert jump.sum() > 150
    assert np.all(instant[jump] < stood[jump]), (instant - stood)[jump].max()
    assert instant[~jump] == pytest.approx(step[~jump], abs=1e-18)
    # stations every step carry the same width through diagnose
    stations = {f"s{i}": (0.03, mid, rate[:, i], dt) for i in (0, 77, 199)}
    got = rupture.station_times(stations)
    assert [got[f"s{i}"][1] for i in (0, 77, 199)] == pytest.approx(step[[0, 77, 199]], abs=1e-18)
    assert rupture.step_width(0.5 * dt) == dt and rupture.step_width(0.0) == 0.0


def test_a_struck_run_that_slides_from_its_edge_has_no_rupture_block():
    x = X.copy()
    t = np.where(x < 1e-12, 0.0, x / 1000.0)  # sliding from x1 = 0 at once, then a front at 1000 m/s
    with np.errstate(over="ignore"):
        rate = np.minimum(5.0, 1e-3 * np.exp((ROWS[:, None] - t[None, :]) / 0.05e-6))
    assert rupture.diagnose(ROWS, x, rate, SPEEDS, struck=True) is None
    assert rupture.diagnose(ROWS, x, rate, SPEEDS, struck=False)["nucleation"]["x1_m"] <= 1e-4  # not struck: a block
    nothing = rupture.diagnose(ROWS, x, np.zeros((len(ROWS), len(x))), SPEEDS)
    assert nothing["ruptured"] is False and nothing["directions"] == []


def _tmp(factory, name: str) -> Path:
    return Path(COMM.bcast(str(factory.mktemp(name)) if RANK == 0 else None, root=0))


#: the shipped peer scenes, coarse and short; rows every 0.6 µs, so that the field's t_r
#: (from the rows) and the stations' (every step, ~0.2 µs at 1 mm) are two estimates;
#: the tolerance: rate and state (log-linear), slip weakening (out of stick, by the slip:
#: within a third of the rows' interval, rupture_times; measured 0.199 µs at the
#: nucleation patch's edges, 32 and 38 mm, where the stations' step rates start from a
#: stuck step, and 1e-10 s at 28 and 42 mm)
PEER = {"rsf_aging_2d": 0.02e-6, "tpv205_2d": 0.6e-6 / 3}


@pytest.fixture(scope="module", params=sorted(PEER))
def peer_run(request, tmp_path_factory):
    out = _tmp(tmp_path_factory, request.param)
    scene = load_scene(request.param, ["mesh.dx=1e-3", "mesh.dy=1e-3", "time.end=12e-6",
                                       "output.interface_every=0.6e-6"])
    runner.run_scene(scene, out, COMM, quiet=True)
    return request.param, out


def test_peer_scene_rupture_times_match_the_stations_own_crossings(peer_run):
    name, out = peer_run
    if RANK:
        return
    summary = json.loads((out / "summary.json").read_text())
    block = summary["rupture"]
    assert block["threshold_m_s"] == 1e-3
    nuc = block["nucleation"]
    # the overstressed patch [32, 38] mm slides in the first step: its first rate holds at dt/2 (rigid kind:
    # the step's V^{1/2}, interface.h5's time_shift_s)
    assert nuc["time_s"] == 0.5 * summary["dt_s"] and 32e-3 <= nuc["x1_m"] <= 38e-3
    assert {d["direction"] for d in block["directions"]} == {"+x1", "-x1"}
    x = np.array(block["field"]["x1_m"])
    t_r = np.array([np.nan if v is None else v for v in block["field"]["time_s"]])
    last_row = 12e-6 - 0.6e-6
    compared = 0
    for st in block["stations"]:
        if st["time_s"] is None or st["time_s"] > last_row - 0.6e-6:
            continue
        i = int(np.argmin(np.abs(x - st["x1_m"])))
        assert abs(x[i] - st["x1_m"]) < 1e-9
        assert abs(t_r[i] - st["time_s"]) <= PEER[name], (name, st, t_r[i])
        compared += 1
    assert compared >= 4, block["stations"]
    # a station's crossing is never before the last step its slip (δ^{n+1} at t^{n+1}) still stood at zero
    with open_interface(out) as itf:
        histories = itf.stations()
    for st in block["stations"]:
        h = histories[st["name"]]
        still = h.time_of("slip")[h.data["slip"] == 0.0]
        if st["time_s"] is not None and len(still):
            assert st["time_s"] >= still.max() - 1e-15, (name, st["name"], st["time_s"], still.max())
    # symmetric problem about the patch (35 mm): both fronts alike
    a, b = block["directions"]
    assert a["mean_v_r_m_s"] == pytest.approx(b["mean_v_r_m_s"], rel=1e-6)
    assert 300.0 < a["mean_v_r_m_s"] < SPEEDS["c_s"]
    outward = [s for s in block["between_stations"] if not s["in_patch"] and math.isfinite(s["v_r_m_s"] or math.nan)]
    assert outward and all(0 < s["v_r_m_s"] < SPEEDS["c_l"] for s in outward)


def test_compare_reads_the_stations_at_the_times_their_rates_hold(peer_run):
    """``fricfem compare``'s rupture and peak times of a rigid run are those of the slip
    rate's own times (V^{n+½} at t^{n+½}: interface.h5's time_shift_s), as the summary's."""
    from fricfem.analysis import compare

    name, out = peer_run
    if RANK:
        return
    cmp = compare.compare(out, out)
    with open_interface(out) as itf:
        histories = itf.stations()
    summary = {s["name"]: s["time_s"] for s in json.loads((out / "summary.json").read_text())["rupture"]["stations"]}
    shifted = 0
    for row in cmp["stations"]:
        h = histories[row["name"]]
        k = int(np.argmax(h.data["slip_rate"]))
        assert row["a"]["peak_time_s"] == h.time_of("slip_rate")[k]
        shifted += h.time_of("slip_rate")[k] != h.time[k]
        expect = summary[row["name"]]
        got = row["a"]["rupture_time_s"]
        assert (expect is None and math.isnan(got)) or got == pytest.approx(expect, rel=0, abs=1e-15), (row, expect)
    assert shifted == len(cmp["stations"]) > 0  # both peer scenes are rigid: every rate holds at t^{n+½}


def test_spacetime_draws_the_rupture_time_front(peer_run, tmp_path, monkeypatch):
    """Figure data: the drawn t_r line is the summary's field, the star its nucleation."""
    name, out = peer_run
    if RANK:
        return
    from fricfem.plot import common, spacetime

    kept = {}

    def keep(fig, path, **kw):
        kept["fig"] = fig
        return common.save(fig, path, **kw)

    monkeypatch.setattr(spacetime, "save", keep)
    summary = json.loads((out / "summary.json").read_text())
    spacetime.spacetime(out, tmp_path / "spacetime.png", summary=summary)
    ax = kept["fig"].axes[0]
    lines = {ln.get_gid(): ln for ln in ax.lines if ln.get_gid()}
    field = summary["rupture"]["field"]
    front = lines[spacetime.RUPTURE_GIDS["front"]]
    drawn_x, drawn_t = np.asarray(front.get_xdata(), float), np.asarray(front.get_ydata(), float)
    t_r = np.array([np.nan if v is None else v for v in field["time_s"]], float)
    assert np.array_equal(drawn_x, np.asarray(field["x1_m"]) * 1e3)
    assert np.array_equal(np.isnan(drawn_t), np.isnan(t_r))
    assert np.allclose(drawn_t[~np.isnan(t_r)], t_r[~np.isnan(t_r)] * 1e6, rtol=0, atol=1e-12)
    nuc = summary["rupture"]["nucleation"]
    star = lines[spacetime.RUPTURE_GIDS["nucleation"]]
    assert star.get_xdata()[0] == pytest.approx(nuc["x1_m"] * 1e3) and star.get_ydata()[0] == nuc["time_s"] * 1e6
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("1 mm/s" in s for s in labels) and any(s.startswith("nucleation") for s in labels)
    assert (tmp_path / "spacetime.png").stat().st_size > 0
