"""Scene descriptions say what a scene is and what fricfem gives with it — never a
sliding mode fricfem's own run does not give.

The record is tests/golden/scene_modes.json (tests/scene_modes.py: every paper
scene run as shipped) and, for the experiment and mode scenes (``experiment_*``,
``mode_*``), tests/golden/experiment_scene_modes.json
(tests/experiment_scene_modes.py).  The rules:

* a description (what ``fricfem scenes`` prints) of any shipped scene names a
  sliding mode only in its result clause, ``fricfem (<mesh> mesh): no sliding
  by <T> us`` or ``fricfem (<mesh> mesh): <label>, sliding from <t> us``, and
  that clause must be the record's: its mesh, mode label and times;
* a paper scene's description states the paper's Sigma0 and V_imp (equal to
  the scene's) and points to REPRODUCTION.md;
* its header comments name a mode only in a sentence that starts with
  "The paper" (what the paper reports) or in a result clause as above;
* the record agrees with REPRODUCTION.md §4's table where both give a mode;
* an experiment or mode scene's description says what it is (its loading: the
  projectile speed or V_imp, and Sigma0, equal to the scene's), points to
  REPRODUCTION.md and ends with fricfem's result clause; a mode scene's header
  says how it was found.
"""

import json
import re
from pathlib import Path

import pytest

from fricfem.scene import load, shipped

ROOT = Path(__file__).resolve().parents[1]
PAPER_RECORD = json.loads((ROOT / "tests" / "golden" / "scene_modes.json").read_text())["scenes"]
EXPERIMENT_RECORD = json.loads((ROOT / "tests" / "golden" / "experiment_scene_modes.json").read_text())["scenes"]
RECORD = {**PAPER_RECORD, **EXPERIMENT_RECORD}

#: words that name or imply a sliding mode (or its absence)
MODE_WORDS = re.compile(r"\b(?:crack|pulse|train|mixed|coalesc|supersonic|slid|stick|stuck)\w*", re.I)
#: fricfem's result clause
RESULT = re.compile(r"fricfem \((?P<mesh>\w+) mesh\): (?:no sliding by (?P<end>[\d.]+) us"
                    r"|(?P<label>crack-like|pulse-train|pulse|mixed), sliding from (?P<start>[\d.]+) us)")


def check_text(text: str, name: str, record: dict, *, paper_sentences: bool = False) -> list:
    """Problems with ``text`` (a description, or a scene's header comments when
    ``paper_sentences``) against the ``record`` of scene ``name``."""
    problems = []
    rest = text
    for m in RESULT.finditer(text):
        got = record.get(name)
        if got is None:
            problems.append(f"{name}: states a result but tests/golden/scene_modes.json has no record of it")
            continue
        if m["mesh"] != got["mesh"]:
            problems.append(f"{name}: result on the {m['mesh']} mesh, recorded on the {got['mesh']} mesh")
        if m["end"] is not None:
            if got["mode"] != "none":
                problems.append(f"{name}: says no sliding, the record says {got['mode']}")
            elif abs(float(m["end"]) - got["t_end_s"] * 1e6) > 0.05:
                problems.append(f"{name}: says no sliding by {m['end']} us, the run ends at "
                                f"{got['t_end_s'] * 1e6:g} us")
        else:
            if m["label"] != got["mode"]:
                problems.append(f"{name}: says {m['label']}, the record says {got['mode']}")
            elif got["sliding_from_s"] is None or abs(float(m["start"]) - got["sliding_from_s"] * 1e6) > 0.05:
                problems.append(f"{name}: says sliding from {m['start']} us, recorded {got['sliding_from_s']}")
        rest = rest.replace(m[0], " ")
    for sentence in re.split(r"(?<=[.;])\s+", rest):
        if paper_sentences and sentence.strip().startswith("The paper"):
            continue
        words = MODE_WORDS.findall(sentence)
        if words:
            problems.append(f"{name}: {words} outside fricfem's result clause: {sentence.strip()!r}")
    return problems


def header(name: str) -> str:
    """The comment lines before the first key of a shipped scene, joined."""
    lines = []
    for line in shipped()[name].read_text().splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return " ".join(lines)


@pytest.mark.parametrize("name", sorted(shipped()))
def test_description_names_only_recorded_modes(name):
    assert check_text(load(name).description, name, RECORD) == []


@pytest.mark.parametrize("name", sorted(PAPER_RECORD))
def test_paper_scene_description_and_comments(name):
    scene = load(name)
    d = scene.description
    assert RESULT.search(d), f"{name}: no result clause 'fricfem (<mesh> mesh): ...' in {d!r}"
    assert "REPRODUCTION.md" in d
    sigma0 = re.search(r"Sigma0 = ([\d.]+) MPa", d)
    v_imp = re.search(r"V_imp = ([\d.]+) m/s", d)
    assert sigma0 and float(sigma0[1]) * 1e6 == pytest.approx(scene.sigma0)
    assert v_imp and float(v_imp[1]) == pytest.approx(scene.pulse.v_imp)
    assert check_text(header(name), name, RECORD, paper_sentences=True) == []


def test_every_experiment_and_mode_scene_is_recorded():
    assert sorted(EXPERIMENT_RECORD) == sorted(n for n in shipped() if n.startswith(("experiment_", "mode_")))
    assert all(r["complete"] for r in EXPERIMENT_RECORD.values())


@pytest.mark.parametrize("name", sorted(EXPERIMENT_RECORD))
def test_experiment_and_mode_scene_descriptions(name):
    """What the scene is (its loading, equal to the scene's) and what fricfem gives."""
    scene = load(name)
    d = scene.description
    clause = RESULT.search(d)
    assert clause and d.endswith(clause[0]), f"{name}: no closing result clause in {d!r}"
    assert "REPRODUCTION.md" in d
    sigma0 = re.search(r"Sigma0 = ([\d.]+) MPa", d)
    assert sigma0 and float(sigma0[1]) * 1e6 == pytest.approx(scene.sigma0)
    if scene.experiment is not None:
        speed = re.search(r"(?:projectile at ([\d.]+) m/s|([\d.]+) m/s projectile)", d)
        assert speed and float(speed[1] or speed[2]) == pytest.approx(scene.experiment.projectile_speed)
    else:
        v_imp = re.search(r"V_imp = ([\d.]+) m/s", d)
        assert v_imp and float(v_imp[1]) == pytest.approx(scene.pulse.v_imp)
    if name.startswith(("experiment_mode_", "mode_")):
        assert "How it was found" in header(name), f"{name}: the header does not say how it was found"
    else:
        assert check_text(header(name), name, RECORD, paper_sentences=True) == []


def test_the_check_catches_the_old_descriptions():
    """The descriptions the issue found wrong fail the check (it can fail)."""
    none = {"case1": {"mode": "none", "mesh": "reference", "t_end_s": 40e-6, "sliding_from_s": None}}
    assert check_text("Case I: crack-like mode, Sigma0 = 6 MPa, V_imp = 2 m/s", "case1", none)
    assert check_text("Case I: Sigma0 = 6 MPa; fricfem (reference mesh): crack-like, sliding from 9.3 us",
                      "case1", none)
    assert check_text("Case I: fricfem (reference mesh): no sliding by 40 us; pulses later", "case1", none)
    assert check_text("Case I: fricfem (coarse mesh): no sliding by 40 us", "case1", none)
    assert check_text("Case I: fricfem (reference mesh): no sliding by 30 us", "case1", none)
    assert not check_text("Case I: Sigma0 = 6 MPa; fricfem (reference mesh): no sliding by 40 us", "case1", none)
    assert not check_text("The paper: crack-like sliding from 16 us.", "case1", none, paper_sentences=True)
    assert check_text("The paper: crack-like. Here it slides too.", "case1", none, paper_sentences=True)


def test_record_agrees_with_reproduction_md():
    """REPRODUCTION.md §4 gives fricfem's mode for each case and line point: the same
    runs, so the same labels (a stale record, or a stale table, fails here)."""
    text = (ROOT / "REPRODUCTION.md").read_text()
    rows = re.findall(r"^\| (case\d|lineA|lineB) \| (?:(\w+): )?([\w -]+?) \| ([\w-]+) \| [✓✗] \|", text, re.M)
    seen = 0
    for group, point, claim, got in rows:
        name = point or group
        if name in RECORD and got in ("none", "crack-like", "pulse", "pulse-train", "mixed"):
            assert RECORD[name]["mode"] == got, f"{name}: REPRODUCTION.md says {got}, the record {RECORD[name]['mode']}"
            seen += 1
    assert seen >= 12


@pytest.mark.slow
@pytest.mark.parametrize("name", ["case1", "case4"])
def test_record_is_what_the_code_gives(name, comm, tmp_dir_shared):
    """Two paper scenes rerun as shipped give the recorded mode and start of sliding."""
    import sys

    sys.path.insert(0, str(ROOT / "tests"))
    from scene_modes import outcome

    got = outcome(name, tmp_dir_shared, comm)
    want = RECORD[name]
    assert got["mode"] == want["mode"]
    assert (got["sliding_from_s"] is None) == (want["sliding_from_s"] is None)
    if want["sliding_from_s"] is not None:
        assert got["sliding_from_s"] == pytest.approx(want["sliding_from_s"], abs=0.1e-6)


def test_gallery_shows_recorded_modes():
    """docs/gallery.md: one section per mode fricfem produces; each section's mode is the
    record's for the scene its command runs, its numbers file agrees (with the
    evidence behind the paper's names for the mixed modes), its figures are there;
    the train of pulses, never found, has its search and no run."""
    text = (ROOT / "docs" / "gallery.md").read_text()
    numbers = {**json.loads((ROOT / "docs" / "figures" / "gallery" / "gallery.json").read_text()),
               **json.loads((ROOT / "docs" / "figures" / "gallery" / "modes.json").read_text())}
    heading = {"No sliding": "none", "Crack-like": "crack-like", "Pulse": "pulse", "Mixed": "mixed",
               "A pulse followed by a crack": "mixed", "Pulses coalescing into a crack": "mixed",
               "Supersonic trailing front": "mixed"}
    shown = {}
    for section in re.split(r"^## ", text, flags=re.M)[1:]:
        title = section.split(" — ")[0]
        run = re.search(r"fricfem run (\w+) ", section)
        if title == "Train of pulses":
            assert run is None and "not found" in section and "fricfem sweep" in section
            continue
        if run is None:
            continue
        name = run[1]
        assert RECORD[name]["mode"] == heading[title] == numbers[name]["mode"], name
        assert numbers[name]["description"] == load(name).description
        shown[title] = name
    assert sorted(shown) == sorted(heading)
    assert "pulse phase" in numbers[shown["A pulse followed by a crack"]]["reason"]
    assert numbers[shown["Pulses coalescing into a crack"]]["coalescences"] > 0
    fronts = numbers[shown["Supersonic trailing front"]]["second_front"]["fronts"]
    assert fronts and fronts[0]["mean_speed_m_s"] > load("experiment_42").material.c_l
    for link in re.findall(r"\]\((figures/gallery/[\w.]+\.png)\)", text):
        assert (ROOT / "docs" / link).stat().st_size > 5_000, link
