"""One round of a mode map (:mod:`fricfem.sweep`): rank 0 plans the points and
finds those not yet complete (a complete point computed with other inputs is
refused unless ``--overwrite``), then the batch runner (:mod:`fricfem.batch`)
runs them on its groups of ranks."""

from __future__ import annotations

from .. import batch
from ..output.rundir import read_summary
from ..scene import SceneError
from .planning import plan


def _diff(a, b, prefix=""):
    """First differing key path between two nested dicts (for the stale-point message)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                return _diff(a.get(k), b.get(k), f"{prefix}.{k}" if prefix else k)
    return f"{prefix}: {a!r} (stored) vs {b!r} (now)"


def _todo(spec: dict, select=None) -> tuple:
    """Rank 0: (maps, points, points to run), or a SceneError (bad input, stale points).
    ``spec["planned"]``: (maps, every point) planned already (the cost check), else planned here."""
    out = spec["out"]
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: exists and is not a directory")
    if spec.get("planned"):
        maps, points = spec["planned"]
        if select is not None:
            chosen = {m: set(ij) for m, ij in select.items()}
            points = [p for p in points if p.ij in chosen.get(p.map, ())]
    else:
        maps, points = plan(spec["base"], spec["sigma0"], spec["v_imp"], spec["sets"], spec["preset"],
                            spec["variants"], out, select)
    todo, stale = [], []
    for p in points:
        st = batch.status(p.job)
        if st == "stale":
            stale.append((p, _diff(batch.stored(p.job)["identity"], p.job.ident())))
        if st == "todo" or (st == "stale" and spec["overwrite"]) or \
                (st == "done" and spec.get("rerun_stopped") and read_summary(p.dir).get("watchdog")):
            todo.append(p)
    if stale and not spec["overwrite"]:
        p, why = stale[0]
        raise SceneError(f"{p.dir}: complete run with other inputs ({why}); {len(stale)} point(s) "
                         f"differ. Use another --out, or --overwrite to recompute them")
    for mp in maps.values():
        (mp["dir"] / "points").mkdir(parents=True, exist_ok=True)
    return maps, points, todo


def on_root(comm, fn, what: str):
    """``fn()`` on rank 0, its value on every rank; an error there raised on every rank
    (a SceneError as such, anything else as RuntimeError ``what: ...``)."""
    value = problem = None
    if comm.rank == 0:
        try:
            value = fn()
        except SceneError as err:
            problem = ("scene", str(err))
        except Exception as err:  # reported on every rank: no rank is left waiting
            problem = ("other", f"{what}: {type(err).__name__}: {err}")
    problem = comm.bcast(problem, root=0)
    if problem:
        raise (SceneError if problem[0] == "scene" else RuntimeError)(problem[1])
    return comm.bcast(value, root=0)


def run_round(pool, spec: dict, log, select=None, note: str = "") -> tuple:
    """Plan (rank 0), then run the points not yet complete on the pool (collective):
    ``(maps, points, todo, results)``; results on rank 0 only."""
    maps, points, todo = on_root(pool.comm, lambda: _todo(spec, select), "planning the map failed")
    if pool.comm.rank == 0:
        log(f"{note}{len(points)} point(s) in {len(maps)} map(s): {len(points) - len(todo)} complete, "
            f"{len(todo)} to run on {pool.comm.size} rank(s) ({pool.groups} group(s) of {pool.k})")
    results = pool.run([p.job for p in todo], log=log)
    return maps, points, todo, results
