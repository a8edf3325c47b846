"""Bad input: every bad value, rule, argument and file is one clear error before any
heavy work (issue 10, items 6–8; issue 15, items 6 and 10).

Validation only: no test here builds a mesh (``fricfem.model.mesh.build`` is
replaced by one that fails the test).  Runs under ``mpirun -n 2``: the
command-line tests call ``fricfem.cli.main`` on every rank and check that
every rank returns 2 and that only rank 0 prints the one ``fricfem: error:``
line.
"""

from __future__ import annotations

import math
import os
import re

import pytest
from mpi4py import MPI

from fricfem import cli, load_scene
from fricfem import scene as scenes
from fricfem.scene import SceneError, cost
from fricfem.scene.load import MAX_BYTES, MAX_DEPTH

RANK = MPI.COMM_WORLD.rank


@pytest.fixture(autouse=True)
def no_mesh(monkeypatch):
    """Any mesh built during these tests fails them."""
    def refuse(*args, **kwargs):
        raise AssertionError("a mesh was built during validation")

    monkeypatch.setattr("fricfem.model.mesh.build", refuse)


def refused(overrides, *needles, ref="case1"):
    """The SceneError message for ``overrides`` (each needle must be in it); validation
    is fast: it builds no mesh (the autouse ``no_mesh``; counted, not timed)."""
    with pytest.raises(SceneError) as err:
        load_scene(ref, overrides)
    msg = str(err.value)
    assert "\n" not in msg
    for n in needles:
        assert n in msg, msg
    return msg


def command(capsys, argv):
    """(status, stderr lines) of ``fricfem ARGV`` in process, on this rank (stdout kept in ``command.out``)."""
    capsys.readouterr()
    status = cli.main(argv)  # no mesh is built (the autouse ``no_mesh``)
    captured = capsys.readouterr()
    command.out = captured.out
    return status, [line for line in captured.err.splitlines() if line.strip()]


def clear_error(capsys, argv, *needles):
    """``fricfem ARGV`` exits 2 on every rank; rank 0 prints one error line holding the needles."""
    status, lines = command(capsys, argv)
    assert MPI.COMM_WORLD.allgather(status) == [2] * MPI.COMM_WORLD.size
    if RANK == 0:
        errors = [line for line in lines if line.startswith("fricfem: error:")]
        assert len(errors) == 1 and not any("Traceback" in line for line in lines), lines
        for n in needles:
            assert n in errors[0], errors[0]
    else:
        assert lines == [], lines
    return lines


# --------------------------------------------------------------------------- physics ranges

NON_FINITE = [math.nan, math.inf, -math.inf]


@pytest.mark.parametrize("key, bad", [
    ("loading.sigma0", 0.0), ("loading.sigma0", 1e-300), ("material.E", 1e300), ("material.rho", 1e300),
    ("material.rho", 0.0), ("interface.Cn", 1e300), ("interface.Cs", 1e300), ("interface.Cn", 1e-300),
    ("mesh.length", 1e300), ("mesh.dx", 1e-300), ("material.nu", 0.5), ("interface.tau0", 1e300),
    ("watchdog.max_slip_rate", 1e300), ("watchdog.energy_factor", 1e300), ("time.stop_at_tip", 1e300),
    ("output.flush_every", 1e300), ("friction.params.mu_d", 0.0), ("friction.params.L0", 5.0),
])
def test_values_that_cannot_be_computed_are_out_of_range(key, bad):
    refused([f"{key}={bad!r}"], f"{key} = ", "must lie in")


@pytest.mark.parametrize("key", ["loading.sigma0", "material.E", "interface.Cs", "mesh.dx", "time.end",
                                 "friction.params.V0", "output.interface_every"])
def test_non_finite_values_are_refused(key):
    for bad in NON_FINITE:
        text = {math.inf: "inf", -math.inf: "-inf"}.get(bad, "nan")
        refused([f"{key}={text}"], key)


def test_every_numeric_key_has_a_finite_range():
    """No key is unbounded: every number a scene may give is bounded on both sides."""
    for section, keys in scenes.SCHEMA.items():
        for name, k in keys.items():
            if k.kind in ((int, float), int):
                assert k.low is not None and k.high is not None, f"{section}.{name}"
                assert math.isfinite(k.low) and math.isfinite(k.high), f"{section}.{name}"
    from fricfem import friction

    for law in friction.LAWS.values():
        for p in law.params:
            assert math.isfinite(p.low) and math.isfinite(p.high), (law.name, p.name)


def test_sigma0_doc_says_why_it_is_positive():
    k = scenes.SCHEMA["loading"]["sigma0"]
    assert k.low > 0 and "proportional to it" in k.doc
    assert "EACH plate" in scenes.SCHEMA["mesh"]["height"].doc


# --------------------------------------------------------------------------- rules between keys

REGION = "{{x1_min = {0}, x1_max = {1}, params = {{ mu_s = 0.8 }}}}"
PATCH = "{{x1_min = {0}, x1_max = {1}, tau0 = 1e6}}"


@pytest.mark.parametrize("overrides, needles", [
    (["friction.params.mu_s=0.3"], ("mu_s = 0.3 < friction.params.mu_d = 0.5", ">= the dynamic")),
    (["friction.params.mu_s=0", "friction.params.mu_d=0.001"], ("friction.params.mu_s = 0.0", "must be > 0")),
    (["friction.params.C=0", "friction.params.D=0"], ("C + D must be > 0",)),
    ([f"friction.regions=[{REGION.format(0.01, 0.03)}, {REGION.format(0.02, 0.04)}]"],
     ("friction.regions[1]", "overlaps friction.regions[0]")),
    ([f"friction.regions=[{REGION.format(0.01, 0.01000001)}]"], ("friction.regions[0]", "holds no interface point")),
    ([f"interface.patches=[{PATCH.format(0.01, 0.03)}, {PATCH.format(0.029, 0.04)}]"],
     ("interface.patches[1]", "overlaps interface.patches[0]")),
    ([f"interface.patches=[{PATCH.format(0.05, 0.05000001)}]"], ("interface.patches[0]", "holds no interface point")),
    (["friction.regions=[{x1_min = 0.01, x1_max = 0.02}]"], ("friction.regions[0].params: missing",)),
    (["friction.regions=[{x1_min = 0.01, x1_max = 0.02, params = {}}]"], ("friction.regions[0].params",)),
    (["interface.patches=[{x1_min = 0.01, x1_max = 0.02}]"], ("interface.patches[0].tau0: missing",)),
    (["friction.regions=[{x1_min = 0.01, x1_max = 0.02, params = { mu_s = 0.1 }}]"],
     ("friction.regions[0].params.mu_s = 0.1 < ",)),
    (["friction.law='slip_weakening'"], ("friction.params.Dc = 0.4 m", "not smaller than the plate")),
    (["time.end=1e-8", "output.fields=[]"], ("time.end = 1e-08 s is shorter than one step",)),
    (["time.dt=1e-7", "time.end=5e-8", "output.fields=[]"], ("shorter than one step time.dt",)),
    (["time.dt=1e-6"], ("time.dt = 1e-06 s exceeds the stable step",)),
    (["output.fields=[0.0]"], ("output.fields[0] = 0.0 s", "(0, 4e-05]")),
    (["output.fields=[41e-6]"], ("output.fields[0] = 4.1e-05 s", "--set output.fields=[] writes none")),
    (["output.fields=[1e-9]"], ("less than half a step",)),
    (["output.fields=[16e-6, 16e-6]"], ("output.fields[1]", "given twice")),
    (["time.dt=3e-8", "output.fields=[39.99e-6]", "time.end=39.98e-6"], ("output.fields[0]",)),
    (["time.stop_at_tip=0.2"], ("time.stop_at_tip = 0.2 m", "beyond the plate")),
    (["mesh.fine_x1=0.2"], ("the fine region must satisfy",)),
])
def test_rules_between_keys(overrides, needles):
    refused(overrides, *needles)


def test_a_fixed_step_field_time_must_round_inside_the_run():
    # 4e-5 / 3.0e-8 = 1333.3 steps -> 1333: a field at the end rounds to step 1333 (written); 39.9e-6 -> 1330
    load_scene("case1", ["time.dt=3e-8", "output.fields=[39.9e-6, 4e-5]"])
    # end 5.9e-8 holds one step of 3e-8; a field at 5.9e-8 rounds to step 2: never written
    refused(["time.dt=3e-8", "time.end=5.9e-8", "output.fields=[5.9e-8]"], "rounds to step 2", "1 … 1")


def test_a_missing_mesh_directory_is_named(tmp_path, monkeypatch):
    from fricfem.model import mesh

    monkeypatch.setattr(mesh, "MESH_DIR", tmp_path)
    with pytest.raises(ValueError, match=re.escape(f"no such mesh; allowed: (no mesh files in {tmp_path}) or a path")):
        mesh.preset("reference")


def test_touching_regions_are_allowed():
    scene = load_scene("rupture_sw", [f"friction.regions=[{REGION.format(0.0, 0.004)}, {REGION.format(0.004, 0.01)}]"])
    assert len(scene.regions) == 2


@pytest.mark.parametrize("name", ["", "/", "a/b", "../../x", "..", ".", "a\x00b", "a\nb", "x" * 65, "α"])
def test_unsafe_station_names_are_refused(tmp_path, name):
    path = tmp_path / "st.toml"
    import json

    path.write_text(f"base = 'case1'\n[output]\nstations = {{ {json.dumps(name)} = 0.01 }}\n")
    with pytest.raises(SceneError, match="station name"):
        load_scene(str(path))


def test_station_names_differ_ignoring_case():
    refused(['output.stations={ "Gauge" = 0.01, "gauge" = 0.02 }'], "same name", "ignoring case")
    scene = load_scene("case1", ['output.stations={ "g-1.5_mm" = 0.0015 }'])
    assert list(scene.output["stations"]) == ["g-1.5_mm"]


@pytest.mark.parametrize("name", ["../../x", "/abs/path", "", "a b", "x" * 129, ".."])
def test_scene_name_is_an_identifier(name):
    import json

    refused([f"name={json.dumps(name)}"], "name = ", "letters, digits")


# --------------------------------------------------------------------------- merge rules (issue 15 item 10)

def test_merge_rules(tmp_path):
    """Tables merge key by key; output.stations, and every list, replace the base's."""
    path = tmp_path / "child.toml"
    path.write_text("base = 'rupture_sw'\nname = 'child'\n[friction.params]\nmu_d = 0.5\n"
                    "[output]\nstations = { a = 0.01 }\nfields = [1e-6]\n"
                    "[interface]\npatches = [{ x1_min = 0.03, x1_max = 0.034, tau0 = 7e6 }]\n")
    scene = load_scene(str(path))
    base = load_scene("rupture_sw")
    assert scene.params["mu_d"] == 0.5 and scene.params["Dc"] == base.params["Dc"]  # merged key by key
    assert scene.output["stations"] == {"a": 0.01}  # replaced
    assert scene.output["fields"] == [1e-6]
    assert scene.regions == base.regions  # not given: inherited
    assert [p["x1_max"] for p in scene.tau0_patches] == [0.034]  # replaced
    # the name is the file's own, never the base's (its own run directory)
    assert load_scene(str(_file(tmp_path, "unnamed.toml", "base = 'case1'\n"))).name == "unnamed"
    # --set into a station table adds one station; a whole table replaces them
    assert set(load_scene("case1", ["output.stations.x20mm=0.02"]).output["stations"]) == {"x16.1mm", "x20mm"}
    assert set(load_scene("case1", ["output.stations={ y = 0.02 }"]).output["stations"]) == {"y"}


# --------------------------------------------------------------------------- --set and the command line

@pytest.mark.parametrize("item, needle", [
    ("...=1", "empty part"), (".v_imp=1", "empty part"), ("loading.=1", "empty part"), ("=1", "expected"),
    ("base=case2", "base cannot be overridden"), ("base='case2'", "base cannot be overridden"),
    ("loading.vimp=1", "loading.vimp: unknown key"), ("loading=1", "is a section"),
    ("loading.v_imp.x=1", "has no key"), ("name.x=1", "top-level key"), ("nosuch.key=1", "unknown key 'nosuch'"),
    ("friction.params.mu_s.x=1", "has no key"), ("loading.sigma0", "expected <section.key>=<value>"),
])
def test_bad_set_items(capsys, item, needle):
    with pytest.raises(SceneError, match=None) as err:
        load_scene("case1", [item])
    assert needle in str(err.value)
    clear_error(capsys, ["run", "case1", "--set", item], "--set", needle)


@pytest.mark.parametrize("argv, needle", [
    (["run", "case1", "--out", ""], "--out '': empty"),
    (["run", "case1", "--check", "--out", "x"], "not used with --check"),
    (["run", "case1", "--check", "--overwrite"], "not used with --check"),
    (["run", ""], "empty"),
    (["plot", "runs/x", "--times", ""], "--times"),
    (["plot", "runs/x", "--times", "1,nan"], "'nan' is not a time"),
    (["plot", "runs/x", "--out", ""], "--out '': empty"),
    (["mesh", "--preset", ""], "--preset '': empty"),
    (["mesh", "--preset", "coarse", "--set", "preset='fine'"], "give the mesh preset once"),
    (["mesh", "--preset", "coarse", "--write", "/nonexistent-dir/x.msh"], "does not exist"),
    (["mesh", "--preset", "coarse", "--write", "x.txt"], "ending in .msh"),
    (["mesh", "--set", "dx=-1"], "mesh.dx = -1"),
])
def test_every_argument_is_used_or_refused(capsys, argv, needle):
    clear_error(capsys, argv, needle)


@pytest.mark.parametrize("extra, needle", [
    (["--sigma0", "", "--v-imp", "2"], "--sigma0 '': empty"), (["--sigma0", "2,x", "--v-imp", "2"], "is not a number"),
    (["--sigma0", "2", "--v-imp", "2", "--grid", "default"], "--grid default: not used"),
    (["--sigma0", "2", "--v-imp", "2", "--label", ""], "--label '': empty"),
    (["--sigma0", "2", "--v-imp", "", ], "--v-imp '': empty"),
    (["--sigma0", ",".join(str(i + 1) for i in range(101)), "--v-imp", "2"], "at most 100"),
    (["--sigma0", "2", "--v-imp", "2", "--set", "base=case2"], "base cannot be overridden"),
])
def test_sweep_arguments(capsys, tmp_path, extra, needle):
    from fricfem import sweep

    capsys.readouterr()
    status = sweep.main(["case1", "--out", str(tmp_path / "sw")] + extra)
    err = capsys.readouterr().err
    assert MPI.COMM_WORLD.allgather(status) == [2] * MPI.COMM_WORLD.size
    if RANK == 0:
        assert needle in err and "Traceback" not in err, err
    assert not (tmp_path / "sw").exists()


def test_sweep_cost_guard(capsys, tmp_path):
    from fricfem import sweep

    capsys.readouterr()
    status = sweep.main(["case1", "--out", str(tmp_path / "sw"), "--sigma0", "2", "--v-imp", "2",
                         "--set", "time.end=0.5"])
    err = capsys.readouterr().err
    assert status == 2
    if RANK == 0:
        assert "above the budget" in err and "--force" in err, err


# --------------------------------------------------------------------------- scene files

def _file(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("text", ["", "   \n\t\n", "# only a comment\n\n# another\n"])
def test_empty_scene_file_is_an_error(tmp_path, capsys, text):
    path = _file(tmp_path, "empty.toml", text)
    with pytest.raises(SceneError, match="has no keys"):
        load_scene(str(path))
    clear_error(capsys, ["run", str(path)], "has no keys", str(path))


def test_scene_path_that_is_no_regular_file(tmp_path, capsys):
    d = tmp_path / "dir.toml"
    d.mkdir()
    clear_error(capsys, ["run", str(d)], "is a directory")
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    clear_error(capsys, ["run", str(fifo)], "is a FIFO")  # never opened: no hang
    clear_error(capsys, ["run", "/dev/zero"], "is a device")
    loop = tmp_path / "loop.toml"
    os.symlink(loop, loop)
    clear_error(capsys, ["run", str(loop)], "symbolic link loop")
    dangling = tmp_path / "dangling.toml"
    os.symlink(tmp_path / "nowhere.toml", dangling)
    clear_error(capsys, ["run", str(dangling)], "not found")
    clear_error(capsys, ["run", "nul\x00byte.toml"], "cannot read")


def test_huge_scene_file_is_not_read(tmp_path, capsys):
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(MAX_BYTES + 1)  # sparse: nothing to read, and nothing is read
    clear_error(capsys, ["run", str(big)], "at most 4 MB are read")


def test_non_utf8_scene_names_the_file(tmp_path, capsys):
    path = tmp_path / "latin1.toml"
    path.write_bytes("name = 'caf\xe9'\n".encode("latin-1"))
    clear_error(capsys, ["run", str(path)], str(path), "not UTF-8")


def test_deep_and_cyclic_base_chains(tmp_path, capsys):
    _file(tmp_path, "s0.toml", "base = 'case1'\nname = 's0'\n")
    for i in range(1, MAX_DEPTH + 8):
        _file(tmp_path, f"s{i}.toml", f"base = 's{i - 1}.toml'\nname = 's{i}'\n")
    assert load_scene(str(tmp_path / "s20.toml")).name == "s20"
    clear_error(capsys, ["run", str(tmp_path / f"s{MAX_DEPTH + 7}.toml")], "deeper than 32")
    _file(tmp_path, "a.toml", "base = 'b.toml'\n")
    _file(tmp_path, "b.toml", "base = 'a.toml'\n")
    clear_error(capsys, ["run", str(tmp_path / "a.toml")], "inherits from itself")


def test_deeply_nested_values_are_refused(tmp_path, capsys):
    path = _file(tmp_path, "nest.toml", "base = 'case1'\n[output]\nfields = " + "[" * 400 + "]" * 400 + "\n")
    clear_error(capsys, ["run", str(path)], "nested deeper than 16")


def test_mesh_file_values_are_checked(tmp_path):
    mesh = _file(tmp_path, "m.toml", "dx = nan\n")
    scene = _file(tmp_path, "s.toml", f"base = 'case1'\n[mesh]\npreset = '{mesh}'\n")
    with pytest.raises(SceneError, match="mesh.dx .in .*must be finite"):
        load_scene(str(scene))
    _file(tmp_path, "m.toml", "dx = 'fine'\n")
    with pytest.raises(SceneError, match="mesh.dx .in .*expected a number"):
        load_scene(str(scene))


# --------------------------------------------------------------------------- the cost guard

def test_cost_guard_refuses_without_force(capsys):
    for over in (["time.dt=1e-11", "time.end=1e-4"],  # 1e7 steps
                 ["material.plane='strain'", "material.nu=0.4999999999"],  # c_l -> inf: a tiny step
                 ["mesh.dx=5e-6", "mesh.dy=5e-6", "mesh.fine_x1=0.06"]):  # 1e7 quadrilaterals
        scene = load_scene("case1", over)
        with pytest.raises(SceneError, match="above the budget .*pass --force"):
            cost.check(scene)
        est = cost.check(scene, force=True)
        assert est.over(cost.BUDGET)
        argv = ["run", "case1", "--check"] + [a for o in over for a in ("--set", o)]
        clear_error(capsys, argv, "above the budget", "--force", "Estimate:")
        status, lines = command(capsys, argv + ["--force"])
        assert status == 0
    clear_error(capsys, ["run", "case1", "--set", "time.dt=1e-15"], "even with --force")


def test_cost_guard_hard_limit_holds_with_force():
    scene = load_scene("case1", ["time.dt=1e-15"])
    with pytest.raises(SceneError, match="even with --force"):
        cost.check(scene, force=True)
    with pytest.raises(SceneError, match="at most 5e6 are allowed without --force"):
        load_scene("case1", ["mesh.dx=1e-7", "mesh.dy=1e-7"])


def test_check_prints_the_estimate(capsys):
    status, lines = command(capsys, ["run", "case1", "--check"])
    out = command.out
    assert status == 0
    est = cost.estimate(load_scene("case1"))
    assert (est.quads, est.dofs, est.interface_points) == (17784, 72208, 912)  # README's reference mesh
    assert 781 <= est.steps <= 1.5 * 781  # the run takes 781 steps (README): never fewer estimated
    if RANK == 0:
        assert "valid" in out and "17,784 quadrilaterals" in out and "within" in out


def test_step_bracket_holds_the_built_step():
    """λmax of the built reference model (dt_crit 56.98 ns, docs/scenes.md) lies in the bracket."""
    est = cost.estimate(load_scene("case1"))
    assert est.dt_crit[0] <= 56.98e-9 <= est.dt_crit[1]
    est = cost.estimate(load_scene("rupture_sw"))
    assert est.dt_crit[0] <= 22.80e-9 <= est.dt_crit[1]


# --------------------------------------------------------------------------- field-scale lengths (issue 15 item 6)

def test_field_scale_lengths(capsys):
    sw = ["friction.law='slip_weakening'", "friction.params.mu_s=0.677", "friction.params.mu_d=0.525"]
    refused(sw, "friction.params.Dc = 0.4 m", "not smaller than the plate")  # the TPV3 default on a lab plate
    scene = load_scene("case1", sw + ["friction.params.Dc=2e-3"])  # cohesive zone ~ 1.7 m > 0.137 m
    assert any("of the plate" in w for w in scene.warnings)
    assert any("cohesive zone" in w and "longer than the plate" in w for w in scene.warnings)
    scene = load_scene("case1", sw + ["friction.params.Dc=1e-9"])  # cohesive zone ~ 1 µm < 3 cells
    assert any("unresolved" in w for w in scene.warnings)
    assert load_scene("rupture_sw").warnings == ()  # the shipped slip-weakening problem is in scale
    for name in scenes.shipped():
        assert load_scene(name).warnings == (), name
    status, lines = command(capsys, ["run", "case1", "--check"] + [a for o in sw + ["friction.params.Dc=2e-3"]
                                                                   for a in ("--set", o)])
    assert status == 0
    warnings = [line for line in lines if line.startswith("fricfem: warning:")]
    assert (len(warnings) >= 2) if RANK == 0 else warnings == []
