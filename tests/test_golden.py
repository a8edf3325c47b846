"""Whole runs against their golden fingerprints (tests/golden.py): a change of
code that is meant to leave results alone must leave them bit-identical, on
every dolfinx (0.5.2, 0.9, the 0.11 wheel); golden.py's tolerance mode (within
golden.TOLERANCE of each quantity's scale) only when FRICFEM_GOLDEN asks for it."""

import json

import numpy as np
import pytest

import golden


@pytest.mark.slow
@pytest.mark.parametrize("name", list(golden.CASES))
def test_run_matches_golden(name, comm, tmp_dir_shared):
    rundir = golden.run_case(name, tmp_dir_shared, comm)
    bad = None
    if comm.rank == 0:
        want = json.loads((golden.GOLDEN_DIR / f"{name}.json").read_text())
        bad = golden.compare(golden.fingerprint(rundir), want, golden.default_mode())
    bad = comm.bcast(bad, root=0)
    assert not bad, f"{name}: results changed:\n" + "\n".join(bad)


def _fingerprint(arrays: dict, results: dict) -> dict:
    """A fingerprint as golden.fingerprint makes it, of given datasets and summary results."""
    import hashlib

    dt_crit = results.get("dt_crit_s")  # kept apart from the summary's digest, as golden.fingerprint does
    results = {k: v for k, v in results.items() if k != "dt_crit_s"}
    return {"interface.h5": {k: golden._digest(v) for k, v in arrays.items()}, "fields.h5": {},
            "dt_crit_s": dt_crit,
            "summary": hashlib.sha256(json.dumps(results, sort_keys=True).encode()).hexdigest(),
            "summary_numbers": {}, "energy_history": {}, "energy_summary": {},
            "scale_numbers": {"interface.h5": {k: golden.scale_numbers(v) for k, v in arrays.items()},
                              "fields.h5": {}, "summary": golden._result_numbers(results)}}


def _case():
    """Datasets and results shaped like a run's: a shear traction of scale 1.85e5 Pa with
    NaN rows (a live file's layout), a slip of 1e-6 m, the open flags, a summary."""
    rng = np.random.default_rng(7)
    ts = 1.85e5 * np.cumsum(rng.standard_normal((40, 300)), axis=1) / 30.0
    ts[35:] = np.nan
    arrays = {"shear_traction": ts, "slip": 1e-6 * rng.random((40, 300)), "open": (rng.random((40, 300)) < 0.1)
              .astype(np.int8)}
    results = {"dt_crit_s": 5.69799918667237e-08, "steps": 781, "mode": "pulse", "complete": True,
               "tip": {"last_x1_m": 0.0563, "v_tip_max_m_s": 2120.9}}
    return arrays, results


@pytest.mark.parametrize("rel, tolerance_passes", [(1e-12, True), (1e-6, False)])
def test_tolerance_mode_passes_round_off_and_nothing_more(rel, tolerance_passes):
    """A dataset moved by ``rel`` of its scale (each value by up to rel·max|a|, as
    dolfinx 0.10's round-off moves the shear traction by 1.5e-11 of 1.85e5), the
    summary's tip speed by ``rel`` and its dt_crit_s by rel/10: exact mode fails
    both times; tolerance mode (golden.TOLERANCE = 1e-9) passes 1e-12 and fails
    1e-6, naming the dataset and the summary key.  dt_crit_s is held to
    golden.DT_CRIT_RTOL = 1e-12 in both modes: 1e-13 passes, 1e-7 fails."""
    arrays, results = _case()
    want = _fingerprint(arrays, results)
    assert golden.compare(want, want, "exact") == [] and golden.compare(want, want, "tolerance") == []
    rng = np.random.default_rng(3)
    ts = arrays["shear_traction"]
    moved = dict(arrays, shear_traction=ts + rel * np.nanmax(np.abs(ts)) * rng.uniform(-1, 1, ts.shape))
    tip = dict(results["tip"], v_tip_max_m_s=results["tip"]["v_tip_max_m_s"] * (1 + rel))
    got = _fingerprint(moved, dict(results, tip=tip, dt_crit_s=results["dt_crit_s"] * (1 + rel / 10)))
    exact = golden.compare(got, want, "exact")
    assert any("shear_traction differs" in b for b in exact) and any("summary" in b for b in exact), exact
    assert any("dt_crit_s differs" in b for b in exact) != tolerance_passes, exact
    bad = golden.compare(got, want, "tolerance")
    if tolerance_passes:
        assert bad == [], bad
    else:
        assert any("shear_traction differs beyond 1e-09" in b for b in bad), bad
        assert any("summary results differ beyond 1e-09 in ['tip']" in b for b in bad), bad
        assert any("dt_crit_s differs beyond 1e-12" in b for b in bad), bad
        assert not any("slip" in b or "open" in b for b in bad), bad  # the datasets left alone still pass


def test_tolerance_mode_keeps_shapes_counts_and_flags_exact():
    """Tolerance mode forgives round-off only: a row more, a NaN more, a changed
    integer flag or a changed mode label fail it."""
    arrays, results = _case()
    want = _fingerprint(arrays, results)
    ts = arrays["shear_traction"]
    opened = arrays["open"].copy()
    opened[0, 0] ^= 1
    for got, needle in [
        (_fingerprint(dict(arrays, shear_traction=np.vstack([ts, ts[:1]])), results), "shear_traction differs"),
        (_fingerprint(dict(arrays, shear_traction=np.where(np.arange(300) == 5, np.nan, ts)), results),
         "shear_traction differs"),
        (_fingerprint(dict(arrays, open=opened), results), "open differs"),
        (_fingerprint(arrays, dict(results, mode="crack-like")), "summary results differ beyond 1e-09 in ['mode']"),
        (_fingerprint(arrays, dict(results, steps=782)), "summary results differ beyond 1e-09 in ['steps']"),
    ]:
        bad = golden.compare(got, want, "tolerance")
        assert any(needle in b for b in bad), (needle, bad)


def test_the_mode_is_exact_on_every_dolfinx_unless_forced(monkeypatch):
    """exact on every dolfinx (0.5.2, 0.9, 0.10, 0.11: the same bits since the
    interface's Gauss rule is fricfem's own, tests/test_stack_bits.py);
    FRICFEM_GOLDEN forces either; anything else is refused."""
    import dolfinx

    monkeypatch.delenv(golden.MODE_ENV, raising=False)
    for version in ("0.5.2", "0.9.0", "0.10.0", "0.11.0.dev0"):
        monkeypatch.setattr(dolfinx, "__version__", version)
        assert golden.default_mode() == "exact", version
    monkeypatch.setenv(golden.MODE_ENV, "tolerance")
    assert golden.default_mode() == "tolerance"
    monkeypatch.setenv(golden.MODE_ENV, "exact")
    assert golden.default_mode() == "exact"
    monkeypatch.setenv(golden.MODE_ENV, "loose")
    with pytest.raises(SystemExit, match="must be 'exact' or 'tolerance'"):
        golden.default_mode()
