"""Model reuse across scenes (:mod:`fricfem.model.reuse`): a scene run on a model
reused from another scene of the same mesh and interface gives the same bits
as the scene run on a model built afresh, and reuse skips the mesh, the
assembly and λmax.

Run under ``mpirun -n 2``: each case runs on the 2-rank communicator and, on
each rank alone, on MPI.COMM_SELF (so both 1 and 2 ranks are covered); under a
plain ``pytest`` both are one rank.  Coarse mesh, 12 µs: ~0.3 s a run.
"""

from __future__ import annotations

import pytest
from mpi4py import MPI
from rankcheck import comms, count_calls, differing, h5_arrays

from fricfem import scene as scene_mod
from fricfem.model import build as build_mod
from fricfem.model.reuse import ModelCache, model_key
from fricfem.runner import run_scene

QUICK = ["mesh.preset='coarse'", "time.end=12e-6", "output.fields=[]", "output.stations={x5 = 0.005}"]

#: (first scene, second scene) of one model key: Σ0, V_imp and friction differ
CASES = {
    "elastic": (["loading.sigma0=6e6", "loading.v_imp=20.0"],
                ["loading.sigma0=2e6", "loading.v_imp=40.0", "friction.params.mu_d=0.45"]),
    "traction": (["loading.kind='traction'", "loading.v_imp=20.0"],
                 ["loading.kind='traction'", "loading.v_imp=35.0", "loading.sigma0=3e6"]),
    "rigid": (["interface.kind='rigid'", "loading.v_imp=20.0"],
              ["interface.kind='rigid'", "loading.v_imp=40.0", "loading.sigma0=2e6"]),
}


def _scene(items):
    return scene_mod.load("case1", QUICK + list(items))


@pytest.mark.parametrize("case", sorted(CASES))
def test_reused_model_gives_the_bits_of_a_fresh_one(tmp_dir_shared, comm, case):
    first, second = (_scene(items) for items in CASES[case])
    assert model_key(first) == model_key(second)
    for where, c in comms(comm):
        root = tmp_dir_shared / where / (f"rank{comm.rank}" if where == "self" else "")
        fresh = {name: run_scene(sc, root / f"fresh_{name}", c, quiet=True)
                 for name, sc in (("a", first), ("b", second))}
        cache = ModelCache()
        reused = {}
        for name, sc in (("a", first), ("b", second), ("a2", first)):  # a, then b and a again on a's model
            reused[name] = run_scene(sc, root / f"reused_{name}", c, quiet=True, build=cache.build)
        assert (cache.misses, cache.hits) == (1, 2)
        c.barrier()
        for name, ref in (("a", "a"), ("b", "b"), ("a2", "a")):
            got = h5_arrays(root / f"reused_{name}" / "interface.h5")
            want = h5_arrays(root / f"fresh_{ref}" / "interface.h5")
            assert want["slip_rate"].size and want["stations/x5/slip_rate"].size
            assert differing(got, want) == [], f"{case} on {where}: {name} differs from a fresh run"
            assert reused[name]["steps"] == fresh[ref]["steps"] and reused[name]["dt_s"] == fresh[ref]["dt_s"]
            assert reused[name].get("mode") == fresh[ref].get("mode")
        # the two scenes differ (else the comparison above proves nothing)
        assert differing(h5_arrays(root / "fresh_a" / "interface.h5"), h5_arrays(root / "fresh_b" / "interface.h5"))
        c.barrier()


def test_reuse_skips_mesh_assembly_and_eigenvalue(comm, monkeypatch):
    calls = count_calls(monkeypatch, {"mesh": (build_mod.mesh_mod, "build"), "eig": (build_mod, "max_eigenvalue")})
    a, b = _scene(CASES["elastic"][0]), _scene(CASES["elastic"][1])
    stiff = _scene(CASES["elastic"][0] + ["interface.Cn=3e12", "interface.Cs=1e12"])
    cache = ModelCache(size=2)
    pm_a, ma = cache.build(a, comm)
    pm_b, mb = cache.build(b, comm)
    assert calls == {"mesh": 1, "eig": 1}
    assert pm_b is pm_a and mb.K is ma.K and mb.dt == ma.dt and mb.dt_crit == ma.dt_crit
    assert mb.interface is not ma.interface and mb.bulk is not ma.bulk and mb.bulk.rows is ma.bulk.rows
    assert mb.interface.initial.Tn0[0] == 2e6 and ma.interface.initial.Tn0[0] == 6e6
    assert mb.bulk.pulse.v_imp == 40.0 and ma.bulk.pulse.v_imp == 20.0  # each its own load
    # another interface stiffness is another model (λmax includes the springs): built in full
    _, ms = cache.build(stiff, comm)
    assert calls == {"mesh": 2, "eig": 2} and ms.dt < ma.dt
    assert len(cache) == 2 and (cache.misses, cache.hits) == (2, 1)
    # another communicator: nothing is shared
    if comm.size > 1:
        cache.build(a, MPI.COMM_SELF)
        assert cache.misses == 3 and len(cache) == 1


def test_model_key_separates_what_defines_a_model():
    base = _scene([])
    same = ["loading.sigma0=2e6", "loading.v_imp=7.0", "friction.params.mu_d=0.45", "interface.tau0=1e5",
            "time.end=10e-6", "output.interface_every=4e-7", "name='other'"]
    assert model_key(_scene(same)) == model_key(base)
    for item in ("material.E=5e9", "mesh.dx=0.0025", "interface.Cn=3e12", "interface.kind='rigid'",
                 "loading.kind='traction'", "loading.symmetric=true", "time.dt_safety=0.8",
                 "mesh.absorbing=['right']", "loading.v_imp=0.0"):
        assert model_key(_scene([item])) != model_key(base), item
    # a key the reuse does not know is model-defining (safe): the raw tables are part of the key
    raw = dict(base.raw, experiment={"thickness": 0.01})
    assert model_key(base._replace(raw=raw)) != model_key(base)


def test_a_dropped_model_is_collected_after_a_batch_froze_it(monkeypatch):
    """A batch freezes what survives each job (gc.freeze, fricfem.batch._free); a
    model the cache drops later must still go with the next collection."""
    import gc
    import weakref

    from fricfem.model import reuse

    class Model:  # held in a reference cycle, as the PETSc-holding objects of a model are
        def __init__(self):
            self.me = self

    monkeypatch.setattr(reuse, "build_model", lambda scene, comm, like=None: Model())
    monkeypatch.setattr(reuse, "model_key", lambda scene: scene)
    cache = reuse.ModelCache(size=1)
    first = weakref.ref(cache.build("a", None))
    gc.collect()
    gc.freeze()  # as after a job
    try:
        cache.build("b", None)  # drops the model of "a"
        gc.collect()
        assert first() is None
    finally:
        gc.unfreeze()
