"""Bad-input corpus: every scene key × {wrong type, NaN, +inf, −inf, negative, zero,
huge}, the rules between keys, scene files and command-line arguments — each run
as ``fricfem run`` (or ``mesh`` / ``plot`` / ``sweep``) through the command line
in a subprocess with a timeout, serially, one rank.

Each outcome is one of

* ``clear``: exit 2, exactly one ``fricfem…: error:`` line on stderr naming the
  key (or the file, or the argument), no traceback, no run directory made;
* ``accepted``: exit 0 for a case declared acceptable on purpose (its reason is
  in the table), and the short run it starts completes;
* ``other``: anything else — a traceback, a hang (timeout), another exit
  status, an undeclared acceptance, an error that does not name the key.

Accepted cases run for real but short: the coarse mesh, ``time.end = 2 µs``, no
field snapshots.  Then the cost estimate is checked against real runs of the
coarse, reference and rupture_band meshes (their ``summary.json``).

    .venv/bin/python benchmarks/bad_input.py          # ~15 min; results/bad_input.{md,json}
    .venv/bin/python benchmarks/bad_input.py --only cli,file   # a subset, not written
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FRICFEM = ROOT / ".venv" / "bin" / "fricfem"
RESULTS = ROOT / "benchmarks" / "results"
TIMEOUT = 60.0
#: every case starts from this: small and quick if it is accepted and runs
SHORT = ["--set", "mesh.preset='coarse'", "--set", "time.end=2e-6", "--set", "output.fields=[]"]

VARIANTS = ("wrong type", "NaN", "+inf", "-inf", "negative", "zero", "huge")
NUM_TEXT = {"NaN": "nan", "+inf": "inf", "-inf": "-inf", "negative": "-1.0", "zero": "0.0", "huge": "1e300"}

#: (key, variant) -> why the value is accepted (and then run).
ACCEPTED = {
    ("loading.v_imp", "zero"): "no impact: the edge is free (a rupture problem, as rupture_sw)",
    ("material.nu", "zero"): "a Poisson's ratio of 0 is a material (cork)",
    ("interface.tau0", "zero"): "no initial shear traction (the paper's)",
    ("interface.tau0", "negative"): "an initial shear traction of either sign",
    ("time.dt", "zero"): "0 means the step from time.dt_safety",
    ("time.stop_at_tip", "zero"): "0 means never stop at the tip",
    ("watchdog.max_slip_rate", "zero"): "0 means the material's c_l",
    ("output.energy_every", "zero"): "0 means no energy evaluation",
    ("mesh.fine_x0", "zero"): "the fine region starts at the struck edge (every preset)",
    ("friction.params.C", "zero"): "θ2 carries all of T_n (C + D > 0 is the rule)",
    ("friction.params.D", "zero"): "θ1 carries all of T_n (C + D > 0 is the rule)",
    ("sw.friction.params.mu_d", "zero"): "slip weakening to no friction after Dc (μs > 0 keeps a strength)",
    ("rs.friction.params.f0", "zero"): "the regularised rate-and-state friction stays >= 0",
    ("rss.friction.params.f0", "zero"): "the regularised rate-and-state friction stays >= 0",
    ("rss.friction.params.f_w", "zero"): "strong rate weakening to no friction (TPV103-like)",
}

#: laws whose parameters are swept, with the --set items that select them
LAWS = {
    "": ("povirk_needleman", []),
    "sw.": ("slip_weakening", ["--set", "friction.law='slip_weakening'", "--set", "friction.params.Dc=1e-5"]),
    "rs.": ("rate_state_aging", ["--set", "friction.law='rate_state_aging'"]),
    "rss.": ("rate_state_slip", ["--set", "friction.law='rate_state_slip'"]),
}


def _wrong(kind) -> str:
    """A value of the wrong type for a key of ``kind`` (TOML text)."""
    if kind in ((int, float), int) or kind is float:
        return "'x'"
    if kind is bool:
        return "'yes'"
    return "1.5"


def key_cases() -> list:
    from fricfem import friction
    from fricfem.scene import SCHEMA

    cases = []
    for section, keys in SCHEMA.items():
        for name, k in keys.items():
            if name == "base":
                continue  # not settable with --set: the file cases cover it
            key = f"{section}.{name}" if section else name
            numeric = k.kind in ((int, float), int)
            for v in VARIANTS:
                text = _wrong(k.kind) if v == "wrong type" else NUM_TEXT[v]
                if k.kind is int and v in ("negative", "zero", "huge"):
                    text = {"negative": "-1", "zero": "0", "huge": str(10**30)}[v]
                cases.append({"category": "key" if numeric else "key (not a number)", "id": f"{key} {v}",
                              "argv": ["run", "case1", *SHORT, "--set", f"{key}={text}"], "needle": key,
                              "accept": ACCEPTED.get((key, v))})
    for prefix, (law, select) in LAWS.items():
        for p in friction.get_law(law).params:
            key = f"friction.params.{p.name}"
            for v in VARIANTS:
                text = "'x'" if v == "wrong type" else NUM_TEXT[v]
                cases.append({"category": f"law {law}", "id": f"{prefix}{key} {v}",
                              "argv": ["run", "case1", *SHORT, *select, "--set", f"{key}={text}"], "needle": key,
                              "accept": ACCEPTED.get((prefix + key, v))})
    return cases


def rule_cases() -> list:
    region = "{{x1_min = {0}, x1_max = {1}, params = {{ mu_s = 0.8 }}}}"
    patch = "{{x1_min = {0}, x1_max = {1}, tau0 = 1e6}}"
    rows = [
        ("mu_s < mu_d", ["friction.params.mu_s=0.3"], "friction.params.mu_s"),
        ("mu_s = 0", ["friction.params.mu_s=0", "friction.params.mu_d=0.001"], "friction.params.mu_s"),
        ("C = D = 0", ["friction.params.C=0", "friction.params.D=0"], "C + D"),
        ("overlapping regions", [f"friction.regions=[{region.format(0.01, 0.03)}, {region.format(0.02, 0.04)}]"],
         "friction.regions[1]"),
        ("region without a point", [f"friction.regions=[{region.format(0.01, 0.0101)}]"], "friction.regions[0]"),
        ("region without params", ["friction.regions=[{x1_min = 0.01, x1_max = 0.03}]"], "friction.regions[0]"),
        ("region mu_s < mu_d", ["friction.regions=[{x1_min = 0.01, x1_max = 0.03, params = { mu_s = 0.1 }}]"],
         "friction.regions[0].params.mu_s"),
        ("overlapping patches", [f"interface.patches=[{patch.format(0.01, 0.03)}, {patch.format(0.02, 0.04)}]"],
         "interface.patches[1]"),
        ("patch without a point", [f"interface.patches=[{patch.format(0.05, 0.0501)}]"], "interface.patches[0]"),
        ("patch without tau0", ["interface.patches=[{x1_min = 0.01, x1_max = 0.03}]"], "interface.patches[0]"),
        *[(f"station name {label}", [f"output.stations={{ {json.dumps(name)} = 0.01 }}"], "station name")
          for label, name in (("''", ""), ("'/'", "/"), ("'../../x'", "../../x"), ("with NUL", "a\x00b"),
                              ("with newline", "a\nb"), ("of 10000 characters", "x" * 10000))],
        ("station names equal ignoring case", ['output.stations={ "G" = 0.01, "g" = 0.02 }'], "output.stations.g"),
        ("station off the plate", ["output.stations={ far = 0.5 }"], "output.stations.far"),
        *[(f"scene name {name!r}", [f"name={json.dumps(name)}"], "name = ") for name in ("../../x", "/abs", "a b")],
        *[(f"field time {label}", [f"output.fields={times}"], f"output.fields[{times.count(',')}]")
          for label, times in (("0", "[0.0]"), ("after the end", "[3e-6]"), ("twice", "[1e-6, 1e-6]"),
                               ("under half a step", "[1e-9]"), ("within a step of another", "[1e-6, 1.00001e-6]"))],
        ("fixed step: field past the last step", ["time.dt=3e-8", "time.end=5.9e-8", "output.fields=[5.9e-8]"],
         "output.fields[0]"),
        ("end shorter than one step", ["time.end=1e-8"], "time.end"),
        ("end shorter than time.dt", ["time.dt=1e-7", "time.end=5e-8"], "time.end"),
        ("time.dt above the stable step", ["time.dt=1e-6"], "time.dt"),
        ("stop_at_tip beyond the plate", ["time.stop_at_tip=0.2"], "time.stop_at_tip"),
        ("t_hold_end < t_rise", ["loading.t_hold_end=1e-6"], "loading.t_hold_end"),
        ("fine region beyond the plate", ["mesh.fine_x1=0.2"], "mesh.fine_x1"),
        ("dx larger than the fine region", ["mesh.dx=0.1"], "mesh.dx"),
        ("field-scale Dc (TPV3 default)", ["friction.law='slip_weakening'"], "friction.params.Dc"),
        ("field-scale L0", ["friction.params.L0=0.5"], "friction.params.L0"),
        ("cost: 1e7 steps", ["time.dt=1e-11", "time.end=1e-4"], "--force"),
        ("cost: plane strain nu -> 0.5", ["time.end=4e-5", "material.plane='strain'", "material.nu=0.4999999999"],
         "--force"),
        ("cost: 1e7 quadrilaterals", ["mesh.preset='reference'", "mesh.dx=5e-6", "mesh.dy=5e-6"], "--force"),
        ("cost: time.dt = 1e-15 (even with --force)", ["time.dt=1e-15"], "even with --force"),
        ("mesh: 1e10 quadrilaterals", ["mesh.dx=1e-7", "mesh.dy=1e-7"], "mesh:"),
        ("impact_b a sliver above the fine band", ["mesh.impact_b=0.0020000001"], "--force"),
        ("profile with one knot", ["friction.profiles={ L0 = [[0.0, 2e-5]] }"], "friction.profiles.L0"),
        ("profile knots unsorted", ["friction.profiles={ L0 = [[0.02, 2e-5], [0.01, 2e-5]] }"],
         "friction.profiles.L0[1][0]"),
        ("profile knot beyond the plate", ["friction.profiles={ L0 = [[0.0, 2e-5], [0.5, 2e-5]] }"],
         "friction.profiles.L0[1][0]"),
        ("profile value out of range", ["friction.profiles={ mu_d = [[0.0, 0.5], [0.1, 50.0]] }"],
         "friction.profiles.mu_d[1][1]"),
        ("profile value NaN", ["friction.profiles={ mu_d = [[0.0, 0.5], [0.1, nan]] }"], "friction.profiles.mu_d[1][1]"),
        ("profile knot not a pair", ["friction.profiles={ mu_d = [[0.0, 0.5], 0.1] }"], "friction.profiles.mu_d[1]"),
        ("profile of an unknown parameter", ["friction.profiles={ q = [[0.0, 1.0], [0.1, 1.0]] }"],
         "friction.profiles.q"),
        ("profile breaking C + D > 0 at a knot", ["friction.params.D=0",
                                                  "friction.profiles={ C = [[0.0, 0.5], [0.1, 0.0]] }"],
         "friction.profiles at x1"),
        ("profile and region on one parameter", ["friction.regions=[{x1_min = 0.01, x1_max = 0.03, params = "
                                                 "{ mu_s = 0.8 }}]", "friction.profiles={ mu_s = [[0.0, 0.8], "
                                                 "[0.1, 0.8]] }"], "friction.profiles.mu_s"),
        ("initial_state not a choice", ["friction.initial_state='peer'"], "friction.initial_state"),
    ]
    cases = [{"category": "rule", "id": i, "argv": ["run", "case1", *SHORT] + [a for s in sets for a in ("--set", s)],
              "needle": needle, "accept": None} for i, sets, needle in rows]
    accepted = [
        ("touching regions", ["friction.regions=[{x1_min = 0.0, x1_max = 0.02, params = { mu_s = 0.8 }}, "
                              "{x1_min = 0.02, x1_max = 0.04, params = { mu_s = 0.9 }}]"],
         "regions may touch: no point lies on both"),
        ("field time at the end", ["output.fields=[1e-6, 2e-6]"],
         "a time in (0, end] is written at its nearest step (checked: every snapshot is in fields.xdmf)"),
        ("safe station names", ['output.stations={ "g-1.5_mm" = 0.0015, "G2" = 0.002 }'],
         "letters, digits, '_', '-', '.'"),
        ("cohesive zone longer than the plate (warning)",
         ["friction.law='slip_weakening'", "friction.params.Dc=2e-3"], "a warning, not an error: docs/scenes.md"),
    ]
    cases += [{"category": "rule", "id": i, "argv": ["run", "case1", *SHORT] + [a for s in sets for a in ("--set", s)],
               "needle": "", "accept": why} for i, sets, why in accepted]
    return cases


def cli_cases(tmp: Path) -> list:
    rows = [
        ("--set ...=1", ["run", "case1", "--set", "...=1"], "--set"),
        ("--set .v_imp=1", ["run", "case1", "--set", ".v_imp=1"], "--set"),
        ("--set loading.=1", ["run", "case1", "--set", "loading.=1"], "--set"),
        ("--set =1", ["run", "case1", "--set", "=1"], "--set"),
        ("--set base=case2", ["run", "case1", "--set", "base=case2"], "base cannot be overridden"),
        ("--set loading.sigma0 (no value)", ["run", "case1", "--set", "loading.sigma0"], "--set"),
        ("--set loading.sigma0= (empty value)", ["run", "case1", "--set", "loading.sigma0="], "loading.sigma0"),
        ("--set unknown section", ["run", "case1", "--set", "nosuch.key=1"], "--set"),
        ("--set into a number", ["run", "case1", "--set", "loading.v_imp.x=1"], "--set"),
        ("--out ''", ["run", "case1", "--out", ""], "--out"),
        ("--check --out", ["run", "case1", "--check", "--out", str(tmp / "x")], "--out"),
        ("--check --overwrite", ["run", "case1", "--check", "--overwrite"], "--overwrite"),
        ("run ''", ["run", ""], "scene ''"),
        ("unknown option", ["run", "case1", "--bogus"], "--bogus"),
        ("mesh --write into a missing folder", ["mesh", "--preset", "coarse", "--write", str(tmp / "no" / "m.msh")],
         "--write"),
        ("mesh --write not .msh", ["mesh", "--preset", "coarse", "--write", str(tmp / "m.txt")], "--write"),
        ("mesh --preset ''", ["mesh", "--preset", ""], "--preset"),
        ("mesh --preset and --set preset", ["mesh", "--preset", "coarse", "--set", "preset='fine'"], "--preset"),
        ("mesh --set dx=nan", ["mesh", "--set", "dx=nan"], "mesh.dx"),
        ("mesh above the budget", ["mesh", "--set", "dx=5e-6", "--set", "dy=5e-6"], "--force"),
        ("plot --times ''", ["plot", str(tmp), "--times", ""], "--times"),
        ("plot --times nan", ["plot", str(tmp), "--times", "1,nan"], "--times"),
        ("plot --out ''", ["plot", str(tmp), "--out", ""], "--out"),
        ("sweep --sigma0 ''", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "", "--v-imp", "2"],
         "--sigma0"),
        ("sweep --v-imp ''", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp", ""],
         "--v-imp"),
        ("sweep --sigma0 nan", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "nan", "--v-imp", "2"],
         "--sigma0"),
        ("sweep --grid with both axes", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp",
                                         "2", "--grid", "default"], "--grid"),
        ("sweep --label ''", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp", "2",
                              "--label", ""], "--label"),
        ("sweep --out ''", ["sweep", "case1", "--out", "", "--sigma0", "2", "--v-imp", "2"], "--out"),
        ("sweep --set of a swept key", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp", "2",
                                        "--set", "loading.v_imp=3"], "loading.v_imp"),
        ("sweep above the budget", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp", "2",
                                    "--set", "time.end=0.5"], "--force"),
        ("sweep --ranks-per-scene 0", ["sweep", "case1", "--out", str(tmp / "sw"), "--sigma0", "2", "--v-imp",
                                       "2", "--ranks-per-scene", "0"], "--ranks-per-scene"),
    ]
    return [{"category": "cli", "id": i, "argv": argv, "needle": needle, "accept": None} for i, argv, needle in rows]


def fs_cases(tmp: Path) -> list:
    """The run directory on a file system that refuses it, and ``fricfem plot`` on a
    corrupt run (issue 10, item 8): each one line naming the path."""
    f = tmp / "fs"
    f.mkdir()
    (f / "file").write_text("x")
    os.symlink(f / "nowhere", f / "dangling")
    (f / "target").mkdir()
    os.symlink(f / "target", f / "link")
    (f / "occupied" / "interface.h5").mkdir(parents=True)
    (f / "corrupt").mkdir()
    (f / "corrupt" / "interface.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 8)
    rows = [
        ("--out under a regular file", ["run", "case1", *SHORT, "--out", str(f / "file" / "run")], "file/run"),
        ("--out name too long", ["run", "case1", *SHORT, "--out", str(f / ("x" * 300))], "File name too long"),
        ("--out a dangling symlink", ["run", "case1", *SHORT, "--out", str(f / "dangling")], "dangling"),
        ("--out a symlink to a directory", ["run", "case1", *SHORT, "--out", str(f / "link")], "symbolic link"),
        ("interface.h5 is a directory", ["run", "case1", *SHORT, "--out", str(f / "occupied"), "--overwrite"],
         "interface.h5"),
        ("scene name with ..", ["run", "case1", *SHORT, "--set", "name='../../x'"], "name"),
        ("scene name absolute", ["run", "case1", *SHORT, "--set", "name='/tmp/x'"], "name"),
        ("plot a corrupt interface.h5", ["plot", str(f / "corrupt")], "interface.h5"),
    ]
    ro = f / "ro"
    ro.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)],
                      capture_output=True).returncode == 0:  # root only
        rows.append(("--out on a read-only file system", ["run", "case1", *SHORT, "--out", str(ro / "run")],
                     "Read-only file system"))
    return [{"category": "file system", "id": i, "argv": argv, "needle": needle, "accept": None}
            for i, argv, needle in rows]


def _tiny_disk(path: Path, free: int) -> bool:
    """A 3 MB tmpfs at ``path`` (root only) filled until ``free`` bytes are left."""
    path.mkdir(parents=True)
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(path)], capture_output=True).returncode:
        return False
    st = os.statvfs(path)
    with open(path / "filler", "wb") as fh:
        os.posix_fallocate(fh.fileno(), 0, st.f_bavail * st.f_frsize - free)
    return True


def fault_cases(tmp: Path) -> list:
    """Faults around a run (issue 24): a nearly full disk (interface.h5's layout; no
    room for a copy of it), set-up cache entries that are FIFOs or forged, a divergence with
    the watchdog off.  (SIGINT, user laws and readers: tests/test_faults_run.py.)"""
    f = tmp / "faults"
    f.mkdir()
    cases = []
    for i, (label, free, needle, accept) in enumerate((
            ("a nearly full disk (40 kB free)", 40_000, "No space left on device", None),
            ("room for interface.h5, not for a copy of it", 250_000, "",
             "a run that reaches its end needs no copy of its file (its row counts are laid out with it)"))):
        if _tiny_disk(f / f"disk{i}", free):
            cases.append({"category": "fault (run)", "id": label, "argv": ["run", "case1", *SHORT, "--out",
                                                                             str(f / f"disk{i}" / "run")],
                          "needle": needle, "accept": accept})
    warm = f / "cache"  # a set-up cache of SHORT's model, then copies of it made hostile
    env = {**os.environ, "FRICFEM_CACHE": str(warm), "OMP_NUM_THREADS": "1"}
    subprocess.run([str(FRICFEM), "run", "case1", *SHORT, "--out", str(f / "warm"), "--quiet"], env=env,
                   capture_output=True, timeout=900, cwd=tmp)
    fifo, forged = f / "cache_fifo", f / "cache_forged"
    shutil.copytree(warm, fifo)
    shutil.copytree(warm, forged)
    for p in fifo.iterdir():  # every entry a FIFO nobody writes
        p.unlink()
        os.mkfifo(p)
    for p in forged.glob("lam-*.json"):  # λmax × 0.6 under its own key
        entry = json.loads(p.read_text())
        entry["lam"] = (0.6 * float.fromhex(entry["lam"])).hex()
        p.write_text(json.dumps(entry))
    cases += [
        {"category": "fault (run)", "id": "set-up cache entries are FIFOs", "argv": ["run", "case1", *SHORT],
         "needle": "", "env": {"FRICFEM_CACHE": str(fifo)},
         "accept": "an entry that is not a regular file is a miss (never opened for a blocking read), named on "
                   "stderr, computed anew"},
        {"category": "fault (run)", "id": "a forged set-up cache entry (λmax × 0.6)",
         "argv": ["run", "case1", *SHORT],
         "needle": "", "env": {"FRICFEM_CACHE": str(forged)},
         "accept": "an entry whose checksum does not match its key and value is a miss, named on stderr, computed "
                   "anew (the run's bits are those without the cache: tests/test_faults_run.py)"},
        {"category": "fault (run)", "id": "watchdog.enabled = false, dt 1.3 × the stable step",
         "argv": ["run", "case1", *SHORT, "--set", "time.end=30e-6", "--set", "time.dt=3.84e-7",
                  "--set", "time.allow_unstable_dt=true", "--set", "watchdog.enabled=false"],
         "needle": "the run diverged", "status": 1, "timeout": 900, "accept": None},
    ]
    return cases


def file_cases(tmp: Path) -> list:
    """Scene files made in ``tmp``; each case runs ``fricfem run FILE``."""
    f = tmp / "files"
    f.mkdir()

    def write(name, data):
        p = f / name
        (p.write_bytes if isinstance(data, bytes) else p.write_text)(data)
        return p

    rows = [
        ("empty file", write("empty.toml", ""), "no keys"),
        ("whitespace only", write("ws.toml", "  \n\t \n"), "no keys"),
        ("comments only", write("comments.toml", "# a\n\n# b\n"), "no keys"),
        ("not TOML", write("bad.toml", "[loading\nsigma0 = 1\n"), "not valid TOML"),
        ("non-UTF-8", write("latin1.toml", "name = 'caf\xe9'\n".encode("latin-1")), "latin1.toml"),
        ("NUL byte", write("nul.toml", b"name = 'a'\x00\n"), "nul.toml"),
        ("base = 3", write("b3.toml", "base = 3\n"), "base = 3"),
        ("base missing file", write("bmiss.toml", "base = 'nowhere.toml'\n"), "nowhere.toml"),
        ("unknown section", write("unk.toml", "base = 'case1'\n[loadings]\nsigma0 = 1e6\n"), "loadings"),
        ("deep nesting", write("nest.toml", "base = 'case1'\n[output]\nfields = " + "[" * 500 + "]" * 500 + "\n"),
         "nested"),
    ]
    os.mkfifo(f / "fifo_mesh.toml")
    mesh_rows = [
        (label, write(f"scene_{i}.toml", f"base = 'case1'\n[mesh]\npreset = '{mesh}'\n"), needle)
        for i, (label, mesh, needle) in enumerate((
            ("mesh file with nan", write("m1.toml", "dx = nan"), "mesh.dx"),
            ("mesh file unknown key", write("m2.toml", "dz = 1"), "dz"),
            ("mesh file is a FIFO", f / "fifo_mesh.toml", "FIFO")))
    ]
    (f / "dir.toml").mkdir()
    rows.append(("a directory", f / "dir.toml", "is a directory"))
    os.mkfifo(f / "fifo.toml")
    rows.append(("a FIFO", f / "fifo.toml", "is a FIFO"))
    rows.append(("/dev/zero", Path("/dev/zero"), "is a device"))
    os.symlink(f / "loop.toml", f / "loop.toml")
    rows.append(("a symlink loop", f / "loop.toml", "symbolic link loop"))
    os.symlink(f / "nowhere.toml", f / "dangling.toml")
    rows.append(("a dangling symlink", f / "dangling.toml", "not found"))
    big = f / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(64 << 20)
    rows.append(("a 64 MB file (sparse)", big, "at most 4 MB"))
    write("s0.toml", "base = 'case1'\nname = 's0'\n")
    for i in range(1, 3001):
        write(f"s{i}.toml", f"base = 's{i - 1}.toml'\nname = 's{i}'\n")
    rows.append(("a base chain 3000 files deep", f / "s3000.toml", "deeper than 32"))
    write("a.toml", "base = 'b.toml'\n")
    write("b.toml", "base = 'a.toml'\n")
    rows.append(("a base cycle", f / "a.toml", "inherits from itself"))
    rows.append(("a missing file", f / "missing.toml", "not found"))
    rows.append(("a path too long", "/tmp/" + "x" * 5000 + ".toml", "cannot read"))
    cases = [{"category": "file", "id": i, "argv": ["run", str(p), *SHORT], "needle": needle, "accept": None}
             for i, p, needle in rows]
    cases += [{"category": "file", "id": i, "argv": ["run", str(p), *SHORT[2:]], "needle": needle, "accept": None}
              for i, p, needle in mesh_rows]  # the file's own mesh preset, not the coarse one
    ok = write("ok.toml", "base = 'case1'\nname = 'from_a_file'\n")
    cases.append({"category": "file", "id": "a valid file", "argv": ["run", str(ok), *SHORT], "needle": "",
                  "accept": "a well-formed scene file"})
    bare = write("bempty.toml", "base = ''\nname = 'defaults'\n")
    cases.append({"category": "file", "id": "base = '' (the default: no base)", "argv": ["run", str(bare), *SHORT],
                  "needle": "", "accept": "base = '' is the key's default: a scene of the documented defaults"})
    return cases


def run_case(case: dict, tmp: Path) -> dict:
    out = tmp / "out" / str(abs(hash(case["id"])))
    argv = list(case["argv"])
    if argv[0] == "run" and "--check" not in argv:
        argv += ["--out", str(out), "--overwrite", "--quiet"] if "--out" not in argv else []
    env = {**os.environ, "OMP_NUM_THREADS": "1", **case.get("env", {})}
    for k in list(env):
        if k.startswith(("OMPI_COMM", "PMIX_", "PMI_")):
            env.pop(k)
    t0 = time.perf_counter()
    cmd = (["mpirun", "-n", str(case["ranks"]), "--oversubscribe"] if case.get("ranks") else []) + [str(FRICFEM), *argv]
    if case.get("ranks"):  # a job of its own: no variable of this process's MPI job
        env = {k: v for k, v in env.items() if not k.startswith(("OMPI_", "OPAL_")) or "ALLOW_RUN_AS_ROOT" in k}
        if os.geteuid() == 0:
            env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    try:
        if case.get("pipe"):  # stdout into `head -1`, which leaves early; the command's own status
            res = subprocess.run(f"{' '.join(map(shlex.quote, cmd))} | head -1 >/dev/null; exit ${{PIPESTATUS[0]}}",
                                 shell=True, executable="/bin/bash", capture_output=True, text=True, env=env,
                                 cwd=tmp, timeout=case.get("timeout", TIMEOUT), errors="replace")
        else:
            res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp,
                                 timeout=case.get("timeout", TIMEOUT), errors="replace")
        status, err = res.returncode, res.stderr
        if case.get("pipe") and status == 141:  # SIGPIPE's status: the standard quiet end
            status = 0
    except subprocess.TimeoutExpired as exc:
        status, err = "timeout", (exc.stderr or b"").decode(errors="replace") if isinstance(exc.stderr, bytes) \
            else (exc.stderr or "")
    seconds = time.perf_counter() - t0
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if case.get("ranks"):  # mpirun's own report of a rank's exit status, between lines of dashes
        dashes = [k for k, ln in enumerate(lines) if set(ln.strip()) == {"-"}]
        lines = [ln for k, ln in enumerate(lines) if not (dashes and dashes[0] <= k <= dashes[-1])]
    errors = [ln for ln in lines if ln.startswith("fricfem") and ": error:" in ln]
    traceback = any("Traceback" in ln for ln in lines)
    rundir = out.exists() and any(out.iterdir())
    outcome, why = "other", ""
    if status == "timeout":
        why = "hang (timeout)"
    elif traceback:
        why = "traceback"
    elif case.get("status") is not None:  # a run that must end, not complete, saying why (a fault, not a key)
        if status != case["status"]:
            why = f"exit {status}, not {case['status']}"
        elif not any(case["needle"] in ln for ln in lines if ln.startswith("fricfem")):
            why = f"no line names {case['needle']!r}"
        else:
            outcome = "clear"
    elif status == 2:
        stray = [ln for ln in lines if not (ln.startswith(("fricfem", "usage:", " ")) or ln in errors)]
        if case["accept"]:
            why = "refused a case meant to be accepted"
        elif len(errors) != 1:
            why = f"{len(errors)} error lines"
        elif case["needle"] not in errors[0]:
            why = f"error does not name {case['needle']!r}"
        elif rundir:
            why = "a run directory was made"
        elif stray:
            why = f"other output: {stray[0][:80]}"
        else:
            outcome = "clear"
    elif status == 0:
        fields = [a.partition("=")[2] for a in argv if a.startswith("output.fields=")][-1:]
        asked = len(json.loads(fields[0])) if fields and argv[0] == "run" and "--check" not in argv else 0
        written = (out / "fields.xdmf").read_text().count("<Time ") if asked and (out / "fields.xdmf").exists() \
            else 0  # one grid per snapshot
        if not case["accept"]:
            why = "accepted without a reason"
        elif written < asked:
            why = f"{written} of {asked} field snapshots written (fields.xdmf)"
        elif case.get("warning") and not any(case["warning"] in ln for ln in lines if ln.startswith("fricfem")):
            why = f"accepted wrongly: no warning {case['warning']!r}"
        elif case.get("pipe") and lines:
            why = f"raw error: {lines[0][:80]}"
        else:
            outcome = "accepted"
    else:
        why = f"exit {status}"
    if case.get("verify") and outcome != "other":  # what the case's files say (data loss, work done for nothing)
        problem = case["verify"]()
        if problem:
            outcome, why = "other", problem
    short = [a if len(a) <= 200 else f"{a[:180]}… ({len(a)} characters)" for a in argv]
    return {"category": case["category"], "id": case["id"], "argv": short, "outcome": outcome, "why": why,
            "fault": fault(status, why, outcome),
            "accept": case["accept"], "status": status, "seconds": round(seconds, 3),
            "error": errors[0] if errors else None,
            "warnings": [ln for ln in lines if "warning:" in ln][:3],
            "stderr_tail": lines[-12:] if outcome == "other" else []}


def fault(status, why: str, outcome: str) -> str | None:
    """What kind of failure an ``other`` outcome is: crash, hang, data loss, accepted wrongly, raw error."""
    if outcome != "other":
        return None
    if status == "timeout":
        return "hang"
    if why == "traceback" or (isinstance(status, int) and status < 0):
        return "crash"
    if why.startswith("data loss"):
        return "data loss"
    if why.startswith(("accepted", "refused a case")):
        return "accepted wrongly"
    return "raw error"


#: the quick sweep the sweep cases start from: one point on the coarse mesh to 2 µs
SWEEP = ["--preset", "coarse", "--set", "time.end=2e-6", "--quiet"]
ONE = ["--sigma0", "6", "--v-imp", "2", *SWEEP]


def _points(out: Path) -> list:
    """The points with a finished run under a sweep directory."""
    pts = out / "points"
    return sorted(d.name for d in pts.iterdir() if (d / "summary.json").is_file()) if pts.is_dir() else []


def _quiet(argv: list) -> None:
    subprocess.run([str(FRICFEM), *argv], capture_output=True, text=True, timeout=900,
                   env={**os.environ, "OMP_NUM_THREADS": "1"})


def sweep_cases(tmp: Path) -> list:
    """Issue 24's hostile sweeps, plot and command-line output: a damaged job.json, directories where
    the sweep writes files, a read-only --out, an endless --label, one rank failing under 2 ranks, two
    sweeps into one directory, swept keys spelt another way, a run with many frames, a closed pipe.
    A case that needs a state makes it first (a finished sweep, a paused sweep, a run)."""
    w = tmp / "sweeps"
    w.mkdir()
    cases = []

    def case(i, argv, needle="", accept=None, **extra):
        cases.append({"category": "sweep (issue 24)", "id": i, "argv": argv, "needle": needle, "accept": accept,
                      **extra})

    done = w / "damaged"  # a finished one-point sweep whose job.json is then [] (AttributeError while planning)
    _quiet(["sweep", "case1", *ONE, "--out", str(done)])
    if (done / "points" / "s6_v2").is_dir():
        (done / "points" / "s6_v2" / "job.json").write_text("[]")

    def rewritten():
        try:
            ok = isinstance(json.loads((done / "points" / "s6_v2" / "job.json").read_text()), dict)
        except (OSError, ValueError):
            ok = False
        return None if ok else "data loss: the point's job.json was not rewritten"

    case("sweep: job.json holding []", ["sweep", "case1", *ONE, "--out", str(done)],
         accept="a damaged record counts as none: the point runs again", verify=rewritten)
    for name in ("modemap.json", "modemap.png", "sweep.log"):
        out = w / name.replace(".", "_")
        (out / name).mkdir(parents=True)
        case(f"sweep: {name} is a directory", ["sweep", "case1", *ONE, "--out", str(out)], name,
             verify=lambda out=out: f"data loss: {len(_points(out))} point(s) computed, then refused" if _points(out)
             else None)
    out = w / "log2"
    (out / "sweep.log").mkdir(parents=True)
    case("sweep under 2 ranks: sweep.log is a directory (rank 1 waited forever)",
         ["sweep", "case1", *ONE, "--out", str(out)], "sweep.log", ranks=2, timeout=180)
    ro = w / "ro"
    ro.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)],
                      capture_output=True).returncode == 0:  # root only
        case("sweep: --out on a read-only file system", ["sweep", "case1", *ONE, "--out", str(ro / "map")],
             "Read-only file system")
    case("sweep: --label of 20,000 characters", ["sweep", "case1", *ONE, "--out", str(w / "label"),
                                                 "--label", "x" * 20_000], "--label")
    case("sweep: --label with broken mathtext", ["sweep", "case1", *ONE, "--out", str(w / "label2"),
                                                 "--label", "$\\frac{1}{$"], "--label")
    case("sweep: --set 'loading . sigma0=5'", ["sweep", "case1", *ONE, "--out", str(w / "x1"),
                                               "--set", "loading . sigma0=5"], "loading.sigma0")
    case("sweep: --set output.frames=[1e-6]", ["sweep", "case1", *ONE, "--out", str(w / "x2"),
                                               "--set", "output.frames=[1e-6]"], "output.frames")

    # two sweeps into one directory: the first paused while it holds the directory; the second must stop
    two = w / "two"
    two_argv = ["sweep", "case1", "--sigma0", "6,30", "--v-imp", "2", *SWEEP, "--out", str(two)]
    first = {}

    def pause():
        proc = subprocess.Popen([str(FRICFEM), *two_argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
        deadline = time.monotonic() + 300  # bounds a wait for the lock, an event
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                if isinstance(json.loads((two / ".fricfem.lock").read_text()), dict):
                    break
            except (OSError, ValueError):
                pass
            time.sleep(0.05)
        proc.send_signal(signal.SIGSTOP)
        first["proc"] = proc

    def resume():
        proc = first["proc"]
        proc.send_signal(signal.SIGCONT)
        proc.communicate(timeout=900)
        try:
            doc = json.loads((two / "modemap.json").read_text())
        except (OSError, ValueError):
            doc = {}
        if proc.returncode != 0 or sorted(doc.get("computed", [])) != ["s30_v2", "s6_v2"] or \
                len(doc.get("calls", [])) != 1:
            return f"data loss: the first sweep (exit {proc.returncode}) did not finish its points alone"
        return None

    case("sweep: a second sweep into a running sweep's directory", two_argv, "another fricfem run is writing there",
         prepare=pause, verify=resume)

    # plot: a run with 100 camera frames draws at most 24 isochromatic figures, naming what it skipped
    many = w / "frames"
    _quiet(["run", "case1", "--set", "mesh.preset='coarse'", "--set", "output.fields=[]", "--set",
            "output.frames={start=0.4e-6, interval=0.4e-6, count=100}", "--out", str(many), "--quiet"])

    def capped():
        n = len(list((many / "plots").glob("isochromatics_*us.png")))
        return None if 0 < n <= 24 else f"accepted wrongly: {n} isochromatic figures for 100 frames"

    case("plot: a run with 100 camera frames", ["plot", str(many)],
         accept="draws 24 evenly spaced and names the rest (--max-figures 0: all)", warning="drew 24 evenly spaced",
         verify=capped, timeout=900)
    case("scenes into a closed pipe (| head -1)", ["scenes"], accept="the reader left: quiet, status 0 or 141",
         pipe=True)
    return cases


def scene_cases() -> list:
    """Issue 24's scenes accepted wrongly: an experiment given the edge pulse's keys, unit slips (warned with
    the likely value, not refused), a cost estimate blind to the experiment's steel."""
    from fricfem import load_scene
    from fricfem.scene import cost

    rows = [
        ("experiment: loading.kind='projectile'", ["run", "experiment_42", *SHORT, "--set",
                                                   "loading.kind='projectile'"], "loading.kind", None, None),
        ("experiment: loading.impedance=1e10", ["run", "experiment_42", *SHORT, "--set", "loading.impedance=1e10"],
         "loading.impedance", None, None),
        ("unit slip: loading.sigma0=10 (meant MPa)", ["run", "case1", *SHORT, "--set", "loading.sigma0=10",
                                                      "--check"], "", "warned, not refused",
         "did you mean 10 MPa = 1e7?"),
        ("unit slip: loading.v_imp=0.02 (meant km/s)", ["run", "case1", *SHORT, "--set", "loading.v_imp=0.02",
                                                        "--check"], "", "warned, not refused",
         "did you mean 0.02 km/s = 20?"),
    ]
    cases = [{"category": "scene (issue 24)", "id": i, "argv": argv, "needle": needle, "accept": accept,
              "warning": warning} for i, argv, needle, accept, warning in rows]
    # the steel: the coarse experiment with experiment.steel_dx = 1e-5 built 201,874 dofs and stepped 1.6 ns
    # (its summary.json); the estimate may not be below what that run takes
    sets = ["mesh.preset='coarse'", "experiment.steel_dx=1e-5"]

    def steel():
        sc = load_scene("experiment_42", sets)
        est, real = cost.estimate(sc).dof_steps, 201874 * math.floor(sc.t_end / 1.6e-9)
        return None if est >= real else f"accepted wrongly: estimate {est:.3g} dof·steps < the run's {real:.3g}"

    cases.append({"category": "scene (issue 24)", "id": "--check of experiment.steel_dx=1e-5 (coarse)",
                  "argv": ["run", "experiment_42", *[a for s in sets for a in ("--set", s)], "--check"],
                  "needle": "", "accept": "within the budget, the steel counted", "verify": steel})
    return cases


def calibrate(tmp: Path) -> list:
    """The cost estimate against real runs (summary.json): sizes, stable step, steps."""
    from fricfem import load_scene
    from fricfem.scene import cost

    rows = []
    for label, ref, sets in (("coarse", "case1", ["mesh.preset='coarse'"]), ("reference", "case1", []),
                             ("rupture_band", "rupture_sw", []),
                             ("coarse, C x 100", "case1",
                              ["mesh.preset='coarse'", "interface.Cn=3e13", "interface.Cs=1e13"]),
                             ("coarse, plane strain, nu 0.49", "case1",
                              ["mesh.preset='coarse'", "material.plane='strain'", "material.nu=0.49"])):
        scene = load_scene(ref, sets)
        est = cost.estimate(scene)
        short = sets + ["time.end=1e-6", "output.fields=[]"]
        out = tmp / "calib" / label.replace(" ", "_").replace(",", "")
        cmd = [str(FRICFEM), "run", ref, "--out", str(out), "--overwrite", "--quiet"] + \
            [a for s in short for a in ("--set", s)]
        subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp)
        s = json.loads((out / "summary.json").read_text())
        steps = math.floor(scene.t_end / s["dt_s"] + 1e-9)
        rows.append({
            "mesh": label, "scene": ref, "sets": sets, "quads_est": est.quads, "dofs_est": est.dofs, "dofs": s["dofs"],
            "points_est": est.interface_points, "points": s["interface_points"],
            "dt_crit_bracket_s": list(est.dt_crit), "dt_crit_s": s["dt_crit_s"],
            "inside": est.dt_crit[0] <= s["dt_crit_s"] <= est.dt_crit[1],
            "steps_est": est.steps, "steps": steps, "steps_ratio": est.steps / steps,
        })
    return rows


def report(results: list, calib: list, wall: float) -> str:
    cats = sorted({r["category"] for r in results})
    n = len(results)
    count = {o: sum(r["outcome"] == o for r in results) for o in ("clear", "accepted", "other")}
    refused = [r["seconds"] for r in results if r["outcome"] == "clear"]
    lines = [
        "# Bad-input corpus (`benchmarks/bad_input.py`)",
        "",
        f"{n} cases, each `fricfem` in a subprocess (one rank, timeout {TIMEOUT:g} s), serially; "
        f"wall {wall / 60:.1f} min. Accepted cases run for real on the coarse mesh to 2 µs.",
        "",
        f"**Totals: {count['clear']} clear errors, {count['accepted']} accepted on purpose, {count['other']} other** "
        f"({100 * (count['clear'] + count['accepted']) / n:.1f} % clear or deliberately accepted; "
        f"{sum(r['why'] == 'traceback' for r in results)} tracebacks, "
        f"{sum(r['status'] == 'timeout' for r in results)} hangs).",
        "",
        f"Time to each rejection (process start to exit, Python start-up and imports included): median "
        f"{statistics.median(refused):.2f} s, max {max(refused):.2f} s, "
        f"{sum(t < 2.0 for t in refused)}/{len(refused)} under 2 s; no run directory was made for any of them "
        f"(validation runs before the mesh).",
        "",
        "| category | cases | clear | accepted | other | crashes | hangs | data loss | accepted wrongly |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cats:
        rs = [r for r in results if r["category"] == c]
        faults = [r.get("fault") for r in rs]
        lines.append(f"| {c} | {len(rs)} | {sum(r['outcome'] == 'clear' for r in rs)} | "
                     f"{sum(r['outcome'] == 'accepted' for r in rs)} | {sum(r['outcome'] == 'other' for r in rs)} | "
                     + " | ".join(str(faults.count(k)) for k in ("crash", "hang", "data loss", "accepted wrongly"))
                     + " |")
    lines += ["", "## Accepted on purpose", "", "| case | why |", "|---|---|"]
    lines += [f"| {r['id']} | {r['accept']} |" for r in results if r["outcome"] == "accepted"]
    others = [r for r in results if r["outcome"] == "other"]
    lines += ["", "## Other", ""]
    lines += [f"- {r['id']}: {r['why']} {r['stderr_tail'][-1:] if r['stderr_tail'] else ''}"
              for r in others] or ["none"]
    lines += ["", "## A sample of the errors", ""]
    seen = set()
    for r in results:
        if r["outcome"] == "clear" and r["category"] not in seen:
            seen.add(r["category"])
            lines.append(f"- `{r['id']}`: `{r['error'][:220]}`")
    lines += ["", "## The cost estimate against real runs", "",
              "Each mesh run to 1 µs; its `summary.json` gives the built sizes and the stable step "
              "2/√λmax; the estimate comes from the scene alone (`fricfem run --check`). Steps: to the "
              "scene's own end time.", "",
              "| mesh | dofs est / built | points est / built | stable step bracket (ns) | built (ns) | inside | "
              "steps est / real |", "|---|---|---|---|---|---|---|"]
    for c in calib:
        lo, hi = (x * 1e9 for x in c["dt_crit_bracket_s"])
        lines.append(f"| {c['mesh']} | {c['dofs_est']:,.0f} / {c['dofs']:,} | {c['points_est']:,.0f} / "
                     f"{c['points']:,} | {lo:.2f} … {hi:.2f} | {c['dt_crit_s'] * 1e9:.2f} | "
                     f"{'yes' if c['inside'] else 'NO'} | {c['steps_est']:,.0f} / {c['steps']:,} "
                     f"({c['steps_ratio']:.2f}×) |")
    return "\n".join(lines) + "\n"


def _write_json(path: Path, doc: dict) -> None:
    """One case per line (the corpus is long); the common --set items of SHORT left out of each."""
    for r in doc["cases"]:
        r["argv"] = [a for i, a in enumerate(r["argv"]) if not (a in SHORT and (a == "--set" and i + 1 < len(
            r["argv"]) and r["argv"][i + 1] in SHORT or a != "--set"))]
    lines = [json.dumps(r, ensure_ascii=False) for r in doc["cases"]]
    head = {k: v for k, v in doc.items() if k != "cases"}
    path.write_text(json.dumps(head, indent=1)[:-2] + ',\n "cases": [\n' + ",\n".join(lines) + "\n]}\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated categories prefixes (key, law, rule, cli, file, file system, "
                                   "fault, scene, sweep); not written")
    ap.add_argument("--no-calibration", action="store_true")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="fricfem-bad-input-"))
    t0 = time.perf_counter()
    try:
        cases = key_cases() + rule_cases() + cli_cases(tmp) + file_cases(tmp) + fs_cases(tmp)
        if not args.only or any("fault (run)".startswith(p) for p in args.only.split(",")):
            cases += fault_cases(tmp)
        cases += scene_cases()
        if not args.only or any("sweep (issue 24)".startswith(p) for p in args.only.split(",")):
            cases += sweep_cases(tmp)  # these make their states first (a finished sweep, a run)
        if args.only:
            cases = [c for c in cases if any(c["category"].startswith(p) for p in args.only.split(","))]
        results = []
        for i, case in enumerate(cases):
            if case.get("prepare"):
                case["prepare"]()
            r = run_case(case, tmp)
            results.append(r)
            mark = {"clear": ".", "accepted": "a"}.get(r["outcome"], "X")
            print(f"{i + 1:4d}/{len(cases)} {mark} {r['seconds']:5.2f} s  {r['id'][:70]}"
                  + (f"  <- {r['why']}" if mark == "X" else ""), flush=True)
        calib = [] if (args.only or args.no_calibration) else calibrate(tmp)
        wall = time.perf_counter() - t0
        text = report(results, calib, wall)
        print(text)
        if not args.only:
            RESULTS.mkdir(parents=True, exist_ok=True)
            (RESULTS / "bad_input.md").write_text(text)
            _write_json(RESULTS / "bad_input.json", {"wall_s": wall, "short": SHORT, "cases": results,
                                                     "calibration": calib})
        return 0 if all(r["outcome"] != "other" for r in results) else 1
    finally:
        subprocess.run(["umount", "-l", str(tmp / "fs" / "ro")], capture_output=True)
        subprocess.run(["umount", "-l", str(tmp / "sweeps" / "ro")], capture_output=True)
        for disk in (tmp / "faults").glob("disk*"):
            subprocess.run(["umount", "-l", str(disk)], capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
