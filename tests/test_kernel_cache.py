"""Every kernel a run uses loads from numba's disk cache in the next process.

A fresh ``NUMBA_CACHE_DIR`` is shared by two processes that each run the same
tiny models (coarse Case I, a few steps): every registered law on the elastic
interface and, when it has the verb, on the rigid one, plus a user's law
registered from the script (as docs/api.md shows).  The first process fills
the cache; in the second, numba must compile nothing of fricfem's or of the
user's law (``numba:compile`` events, numba's compile-instead-of-load
notification), the per-law kernels must have been loaded (their dispatchers'
cache hits), and stderr must hold no NumbaWarning.  A user's law numba cannot
key (a closure) runs too, compiled, without a warning.

Under ``mpirun -n 2`` each rank takes half of the models, with its own cache
directory (the subprocesses are serial programs).
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest
from rankcheck import serial_env

CHILD = textwrap.dedent('''
    import json, sys, warnings
    from numba.core import event

    compiled = []

    class Compiles(event.Listener):  # numba:compile fires only when a dispatcher compiles (not on a cache load)
        def on_start(self, ev):
            pass

        def on_end(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f"{f.__module__}.{f.__qualname__}")

    event.register("numba:compile", Compiles())

    import numba
    import numpy as np
    import fricfem
    from fricfem.friction import LAWS, Law, Param, frictional_work
    from fricfem.kernels import interface as ki
    from fricfem.kernels.cache import _sources_hash
    from fricfem.scene.validate import SLIP_DISTANCES

    sources = _sources_hash()  # what fricfem.kernels.cache checked the cache against at import

    @numba.njit(cache=True)
    def coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
        trial = Ts + Cs * vs * dt
        strength = p[0] * Tn1
        if abs(trial) <= strength:
            return trial, 0.0, 0.0, 0.0, 1
        dslip = (abs(trial) - strength) / Cs
        Ts1 = strength if trial > 0 else -strength
        return Ts1, dslip / dt, dslip, frictional_work(Ts, Ts1, dslip), 1

    @numba.njit(cache=True)
    def coulomb_rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
        strength = p[0] * Tn1
        if abs(T_stick) <= strength:
            return T_stick, 0.0, 0.0, 0.0, 1
        v = (abs(T_stick) - strength) / Z
        return (strength if T_stick > 0 else -strength), v, v * dt, strength * v * dt, 1

    @numba.njit(cache=True)
    def coulomb_mu(p, v):
        return p[0]

    def closure_law(mu):  # numba cannot key what a closure holds: compiled in each process
        @numba.njit
        def advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
            trial = Ts + Cs * vs * dt
            strength = mu * Tn1
            if abs(trial) <= strength:
                return trial, 0.0, 0.0, 0.0, 1
            dslip = (abs(trial) - strength) / Cs
            Ts1 = strength if trial > 0 else -strength
            return Ts1, dslip / dt, dslip, frictional_work(Ts, Ts1, dslip), 1
        return advance

    none = lambda p, Tn0, Ts0: np.zeros(0)
    mu = (Param("mu", 0.55, "", 0.0, 5.0, "friction coefficient"),)
    fricfem.register_law(Law(name="user_coulomb", doc="Coulomb", params=mu, state=(), advance=coulomb_advance,
                             steady_mu=coulomb_mu, initial_state=none, rigid=coulomb_rigid))
    fricfem.register_law(Law(name="user_closure", doc="Coulomb (closure)", params=mu, state=(),
                             advance=closure_law(0.5), steady_mu=coulomb_mu, initial_state=none))

    out, cases = sys.argv[1], json.loads(sys.argv[2])
    kernels = {}
    for i, (law, kind) in enumerate(cases):
        # a field-scale slip distance (slip weakening's Dc = 0.4 m) scaled to the specimen
        scaled = [f"friction.params.{p.name}=1e-5" for p in LAWS[law].params
                  if p.name in SLIP_DISTANCES and p.default >= 0.1]
        scene = fricfem.load_scene("case1", ["mesh.preset='coarse'", "loading.v_imp=10", "time.end=1.5e-6",
                                             f"friction.law='{law}'", f"interface.kind='{kind}'",
                                             "output.fields=[1.0e-6]", "output.diagnostics=false", *scaled])
        fricfem.run(scene, out=f"{out}/run{i}", overwrite=True)
        k = (ki.kernel_for if kind == "elastic" else ki.rigid_kernel_for)(LAWS[law])
        kernels[f"{law}/{kind}"] = {"hits": sum(k.stats.cache_hits.values()),
                                    "misses": sum(k.stats.cache_misses.values()),
                                    "cacheable": k._cache.__class__.__name__ != "NullCache"}
    print(json.dumps({"compiled": compiled, "kernels": kernels, "sources": [sources, _sources_hash()]}))
''')


def _cases(comm):
    """(law, kind) for every registered law (both kinds when it has ``rigid``) and
    the two user laws the child registers; this rank's share."""
    from fricfem.friction import LAWS

    cases = [(name, "elastic") for name in sorted(LAWS)] + [("user_coulomb", "elastic"), ("user_closure", "elastic")]
    cases += [(name, "rigid") for name in sorted(LAWS) if LAWS[name].rigid is not None] + [("user_coulomb", "rigid")]
    return cases[comm.rank::comm.size]


def _run_twice(tmp, cases):
    """The child twice with one fresh NUMBA_CACHE_DIR; each run's (stdout json, stderr).
    Again (once) when fricfem's numba sources changed between the two (an edit
    while the test ran: fricfem.kernels.cache then rightly clears the cache)."""
    for again in range(2):
        root = tmp / f"try{again}"
        root.mkdir(parents=True, exist_ok=True)
        script = root / "user_law_runs.py"
        script.write_text(CHILD)
        env = serial_env() | {"NUMBA_CACHE_DIR": str(root / "numba"), "FRICFEM_CACHE": "off", "OMP_NUM_THREADS": "1"}
        out = []
        for attempt in ("cold", "warm"):
            res = subprocess.run([sys.executable, str(script), str(root / attempt), json.dumps(cases)], env=env,
                                 capture_output=True, text=True, timeout=1800)
            assert res.returncode == 0, f"{attempt} process failed:\n{res.stderr[-4000:]}"
            out.append((json.loads(res.stdout.strip().splitlines()[-1]), res.stderr))
        if len({*out[0][0]["sources"], *out[1][0]["sources"]}) == 1:
            return out
    pytest.skip("fricfem's numba sources were edited while the test ran, twice")


def test_second_process_compiles_no_kernel(tmp_dir_shared, comm):
    """Every law × interface kind: the kernels a run uses are compiled in the
    first process only; the second loads them all from the cache, silently."""
    cases = _cases(comm)
    (cold, cold_err), (warm, stderr) = _run_twice(tmp_dir_shared / f"rank{comm.rank}", cases)
    ours = [name for name in warm["compiled"] if name.startswith(("fricfem.", "__main__.coulomb"))]
    # the closure law's advance and its kernel (an untagged copy) are compiled again, by design
    expected = {name for name in ours if "closure_law" in name}
    if ("user_closure", "elastic") in cases:
        expected.add("fricfem.kernels.interface.advance_points")
    assert set(ours) == expected, f"compiled in the second process: {sorted(set(ours) - expected)}"
    for err in (cold_err, stderr):  # neither the first process nor the second warns
        assert "NumbaWarning" not in err and "Cannot cache" not in err, err[-4000:]
    for case, k in warm["kernels"].items():
        if case.startswith("user_closure"):
            assert not k["cacheable"] and k["misses"] == 1, (case, k)  # compiled, silently
        else:
            assert k["cacheable"] and k["hits"] == 1 and k["misses"] == 0, (case, k)
            assert cold["kernels"][case]["misses"] == 1, (case, cold["kernels"][case])  # the cold run compiled it
    assert len(warm["kernels"]) == len(cases)
