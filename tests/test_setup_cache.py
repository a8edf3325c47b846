"""The on-disk set-up cache (:mod:`fricfem.model.diskcache`): a run whose λmax
and rows of K come from the cache gives the bits of a run without it; a
corrupted entry or an unusable directory is ignored; the key separates models
that differ.

Run under ``mpirun -n 2``: each case runs on the 2-rank communicator and, on
each rank alone, on MPI.COMM_SELF (each rank its own cache directory then).
The suite turns the cache off (``tests/conftest.py``); each test here points
``FRICFEM_CACHE`` at its own directory.  Coarse mesh, 12 µs: ~0.3 s a run.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from mpi4py import MPI
from rankcheck import comms, count_calls, differing, h5_arrays

from fricfem import scene as scene_mod
from fricfem.model import build as build_mod
from fricfem.model import diskcache
from fricfem.model import mesh as mesh_mod
from fricfem.runner import run_scene

QUICK = ["mesh.preset='coarse'", "time.end=12e-6", "output.fields=[]", "output.stations={x5 = 0.005}",
         "loading.v_imp=20.0"]


def _scene(items=()):
    return scene_mod.load("case1", QUICK + list(items))


@pytest.fixture
def counted(monkeypatch):
    """Counts of the computations the cache saves: λmax and this rank's rows of K."""
    return count_calls(monkeypatch, {"eig": (build_mod, "max_eigenvalue"), "rows": (build_mod, "canonical_rows")})


def _run(scene, out: Path, c) -> tuple:
    """(summary, interface.h5 datasets) of a run on ``c``."""
    summary = run_scene(scene, out, c, quiet=True)
    c.barrier()
    return summary, h5_arrays(out / "interface.h5")


def _same_run(got: tuple, want: tuple, what: str) -> None:
    (s, a), (s0, a0) = got, want
    assert a0["slip_rate"].size and a0["stations/x5/slip_rate"].size
    assert s["dt_s"].hex() == s0["dt_s"].hex() and s["dt_crit_s"].hex() == s0["dt_crit_s"].hex(), what
    assert s["steps"] == s0["steps"], what
    assert differing(a, a0) == [], f"{what}: interface.h5 differs from a run without the cache"


def _where(tmp_dir_shared, where, comm) -> Path:
    return tmp_dir_shared / where / (f"rank{comm.rank}" if where == "self" else "")


def test_cached_setup_gives_the_bits_of_no_cache(tmp_dir_shared, comm, monkeypatch, counted):
    scene = _scene()
    for where, c in comms(comm):
        root = _where(tmp_dir_shared, where, comm)
        monkeypatch.setenv("FRICFEM_CACHE", "off")
        ref = _run(scene, root / "off", c)
        assert counted == {"eig": 1, "rows": 1}
        monkeypatch.setenv("FRICFEM_CACHE", str(root / "cache"))  # made by the first write
        _same_run(_run(scene, root / "miss", c), ref, f"{where}: empty cache")
        assert counted == {"eig": 2, "rows": 2}
        names = sorted(p.name.split("-")[0] for p in (root / "cache").iterdir())
        assert names == ["lam"] + ["rows"] * c.size, names
        _same_run(_run(scene, root / "hit", c), ref, f"{where}: warm cache")
        assert counted == {"eig": 2, "rows": 2}, "a warm cache computes neither λmax nor the rows"
        counted.update(eig=0, rows=0)
        c.barrier()


def _contents(folder: Path) -> dict:
    """{entry: its λmax text, or its arrays' bytes} (a zip's own time stamps left out)."""
    out = {}
    for p in sorted(folder.iterdir()):
        if p.suffix == ".json":
            out[p.name] = p.read_text()
        else:
            with np.load(p) as z:
                out[p.name] = {k: z[k].tobytes() for k in z.files}
    return out


def test_corrupted_entries_are_recomputed_and_rewritten(tmp_dir_shared, comm, monkeypatch, counted):
    scene = _scene()
    for where, c in comms(comm):
        root = _where(tmp_dir_shared, where, comm)
        cache = root / "cache"
        monkeypatch.setenv("FRICFEM_CACHE", "off")
        pm, model = build_mod.build_model(scene, c)
        mine = cache / f"rows-{diskcache.rows_key(pm.spec, scene.material, model.num, c)}.npz"  # this rank's
        del pm, model
        monkeypatch.setenv("FRICFEM_CACHE", str(cache))
        ref = _run(scene, root / "first", c)
        assert mine.is_file()
        good = _contents(cache)
        counted.update(eig=0, rows=0)
        # truncated entries (rank 0 cuts every file in half)
        c.barrier()
        if c.rank == 0:
            for p in cache.iterdir():
                data = p.read_bytes()
                p.write_bytes(data[: len(data) // 2])
        c.barrier()
        _same_run(_run(scene, root / "cut", c), ref, f"{where}: truncated entries")
        assert counted == {"eig": 1, "rows": 1}, "a truncated entry is a miss"
        assert _contents(cache) == good, "the entries are written anew"
        # a λmax entry that is not JSON, and rows whose arrays do not match their digest
        lam = next(cache.glob("lam-*.json"))
        c.barrier()
        if c.rank == 0:
            lam.write_text("{not json")
        with np.load(mine) as z:
            arrays = dict(z)
        arrays["vals"][0, 0] += 1.0
        with open(mine, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        c.barrier()
        _same_run(_run(scene, root / "garbled", c), ref, f"{where}: garbled entries")
        assert counted == {"eig": 2, "rows": 2}, "a garbled entry is a miss"
        assert _contents(cache) == good, "the entries are written anew"
        counted.update(eig=0, rows=0)
        c.barrier()


@pytest.mark.parametrize("how", ["file_in_the_way", "read_only", "missing", "off"])
def test_an_unusable_cache_never_fails_a_run(tmp_dir_shared, comm, monkeypatch, how):
    scene = _scene()
    root = tmp_dir_shared
    monkeypatch.setenv("FRICFEM_CACHE", "off")
    ref = _run(scene, root / "ref", comm)
    if how == "file_in_the_way":  # the cache path is a regular file: no directory can be made
        if comm.rank == 0:
            (root / "blocker").write_text("not a directory")
        comm.barrier()
        cache = root / "blocker" / "cache"
    elif how == "read_only":  # every write refused (as for a read-only directory, even to root)
        cache = root / "ro"
        if comm.rank == 0:
            cache.mkdir(mode=0o555)
        comm.barrier()

        def refuse(*a, **k):
            raise PermissionError(13, "Permission denied")

        monkeypatch.setattr(diskcache, "tempfile", SimpleNamespace(mkstemp=refuse))
    else:
        cache = root / "not" / "yet" / "there"
    monkeypatch.setenv("FRICFEM_CACHE", "off" if how == "off" else str(cache))
    for k in range(2):
        _same_run(_run(scene, root / f"run{k}", comm), ref, how)
    written = sorted(p.name.split("-")[0] for p in cache.iterdir()) if cache.is_dir() else []
    assert written == (["lam"] + ["rows"] * comm.size if how == "missing" else []), (how, written)


def test_key_separates_models(tmp_dir_shared, comm, monkeypatch, counted):
    monkeypatch.setenv("FRICFEM_CACHE", str(tmp_dir_shared / "cache"))
    base = build_mod.build_model(_scene(), comm)[1]
    assert counted == {"eig": 1, "rows": 1}
    again = build_mod.build_model(_scene(["loading.sigma0=2e6", "friction.params.mu_d=0.45"]), comm)[1]
    assert counted == {"eig": 1, "rows": 1} and again.dt_crit == base.dt_crit  # same model: a hit
    # stiffer springs: the same rows of K, another λmax (a hit would give a step too large to be stable)
    stiff = build_mod.build_model(_scene(["interface.Cn=3e12", "interface.Cs=1e12"]), comm)[1]
    assert counted == {"eig": 2, "rows": 1} and stiff.dt_crit < base.dt_crit
    # another mesh: neither is shared
    other = build_mod.build_model(_scene(["mesh.dx=0.0025"]), comm)[1]
    assert counted == {"eig": 3, "rows": 2} and other.dt_crit != base.dt_crit
    # the keys themselves: the mesh definition, the material, the rank count and the springs
    pm, model = build_mod.build_model(_scene(), comm)
    material = model.material
    key = diskcache.rows_key(pm.spec, material, model.num, comm)
    assert diskcache.rows_key(mesh_mod.preset("reference"), material, model.num, comm) != key
    assert diskcache.rows_key(pm.spec, _scene(["material.E=5e9"]).material, model.num, comm) != key
    assert diskcache.rows_key(pm.spec, material, model.num, comm) == key
    args = (model.interface, "elastic", ("impact_lower",), False, ())
    lam = diskcache.lam_key(pm.spec, material, model.num, comm, *args)
    iface = SimpleNamespace(initial=model.interface.initial._replace(Cn=model.interface.initial.Cn * (1 + 1e-15)))
    assert diskcache.lam_key(pm.spec, material, model.num, comm, iface, *args[1:]) != lam
    assert diskcache.lam_key(pm.spec, material, model.num, comm, *args[:-1], ("right",)) != lam
    if comm.size > 1:  # one rank alone: its own partition and reductions
        assert diskcache.rows_key(pm.spec, material, model.num, MPI.COMM_SELF) != key


def test_cache_location(monkeypatch):
    monkeypatch.delenv("FRICFEM_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "/some/where")
    assert diskcache.cache_dir() == Path("/some/where/fricfem")
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert diskcache.cache_dir() == Path("~/.cache/fricfem").expanduser()
    with tempfile.TemporaryDirectory() as d:
        monkeypatch.setenv("FRICFEM_CACHE", d)
        assert diskcache.cache_dir() == Path(d)
    for off in ("off", "", "OFF"):
        monkeypatch.setenv("FRICFEM_CACHE", off)
        assert diskcache.cache_dir() is None


def test_a_warm_run_never_assembles_k(tmp_dir_shared, comm, monkeypatch):
    """The fused rows step the run and λmax comes from the cache, so a warm run
    never assembles K as a PETSc matrix (its vectors take K's layout without it);
    the matrix, assembled when asked for, has the layout of those vectors."""
    from fricfem.model import assembly

    n = count_calls(monkeypatch, {"K": (assembly, "petsc_matrix")})
    monkeypatch.setenv("FRICFEM_CACHE", str(tmp_dir_shared / "cache"))
    scene = _scene()
    run_scene(scene, tmp_dir_shared / "cold", comm, quiet=True)
    assert n == {"K": 1}, "the power iteration of an empty cache multiplies by K"
    run_scene(scene, tmp_dir_shared / "warm", comm, quiet=True)
    assert n == {"K": 1}, "a warm run assembled K"
    _, model = build_mod.build_model(scene, comm)
    x = model.K.createVecRight()
    assert n == {"K": 1}
    x.array[:] = np.random.default_rng(comm.rank).standard_normal(x.getLocalSize())
    y = model.K.mat.createVecRight()
    assert n == {"K": 2}
    assert (x.getSizes(), x.getType()) == (y.getSizes(), y.getType())
    model.K.mult(x, y)  # forwarded to the matrix
    assert np.isfinite(y.array).all() and x.dot(y) > 0  # K is positive semi-definite; a random x is not in its null space
