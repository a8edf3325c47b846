"""A scene's typed settings (fricfem/scene/settings.py): ``scene.output`` and
``scene.watchdog`` are frozen dataclasses with one typed attribute per schema key,
read as mappings too; defaults are resolved at validation (the watchdog's spike
threshold 0 → the material's c_l) while ``scene.raw`` keeps what was written."""

import dataclasses
import pickle

import pytest

from fricfem import load_scene
from fricfem.scene import SCHEMA, OutputSettings, WatchdogSettings, validate


def test_every_output_and_watchdog_key_is_a_typed_attribute():
    sc = load_scene("case1", ["output.energy_every=7", "output.flush_every=3", "output.gauges={G=[0.02, -0.01]}"])
    assert isinstance(sc.output, OutputSettings) and isinstance(sc.watchdog, WatchdogSettings)
    assert set(sc.output) == set(SCHEMA["output"]) and set(sc.watchdog) == set(SCHEMA["watchdog"])
    assert sc.output.energy_every == 7 and type(sc.output.energy_every) is int
    assert sc.output.flush_every == 3.0 and type(sc.output.flush_every) is float  # a number key: float, as written 3
    assert sc.output.gauges == {"G": [0.02, -0.01]} and sc.output["gauges"] is sc.output.gauges
    assert dict(sc.output)["energy_every"] == 7 and sc.output.get("no_such_key", "x") == "x"
    with pytest.raises(KeyError):
        sc.output["no_such_key"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.output.energy_every = 1


def test_watchdog_threshold_resolved_to_c_l_and_the_raw_tables_kept():
    sc = load_scene("case1")
    assert sc.raw.get("watchdog", {}).get("max_slip_rate", 0.0) == 0.0
    assert sc.watchdog.max_slip_rate == sc.material.c_l > 0
    set_ = load_scene("case1", ["watchdog.max_slip_rate=5e4"])
    assert set_.watchdog.max_slip_rate == 5e4 and set_.raw["watchdog"]["max_slip_rate"] == 5e4
    again = validate(sc.raw)  # the raw tables validate to the same scene
    assert again.output == sc.output and again.watchdog == sc.watchdog


def test_settings_survive_replace_pickle_and_compare_by_value():
    sc = load_scene("case1")
    other = sc._replace(Cn=sc.Cn * 2)
    assert other.output is sc.output and other.Cn == 2 * sc.Cn
    back = pickle.loads(pickle.dumps(sc))  # scenes travel between ranks pickled
    assert back.output == sc.output and back.watchdog == sc.watchdog
    assert load_scene("case1", ["output.energy_every=9"]).output != sc.output
