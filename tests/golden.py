"""Golden outputs: fingerprints of whole runs, to prove that a change of code
leaves the physics bit-identical.

A fingerprint holds the SHA-256 of every array a run writes (interface.h5,
fields.h5) and of the summary's numbers, so equal fingerprints mean equal bits.
Only the physics counts: datasets and result numbers, not file
attributes (units, format versions) or where the mode's evidence is kept.
The energy history is the exception: it is summed with BLAS (``np.dot``),
whose order of summation depends on the processor, so it is kept as numbers
and compared to 1e-12 relative.

    mpirun -n 2 .venv/bin/python tests/golden.py record     # after a deliberate change of results
    mpirun -n 2 .venv/bin/python tests/golden.py check      # what tests/test_golden.py does

Recording overwrites ``tests/golden/*.json``; say in the commit why results changed.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

GOLDEN_DIR = Path(__file__).parent / "golden"

#: name -> (scene, overrides, ranks): "world" runs on every rank of the
#: communicator (2 under the suite), "self" on rank 0 alone.
CASES = {
    "case1_v10": ("case1", ("loading.v_imp=10.0",), "world"),
    "case3": ("case3", (), "world"),
    "rupture_sw_12us": ("rupture_sw", ("time.end=12e-6",), "world"),
    "case3_20us_1rank": ("case3", ("time.end=20e-6", "output.fields=[16e-6]"), "self"),
}

#: summary keys that are the run's results (wall times, metadata and where the
#: evidence is stored are not); the mode counts by its label
SUMMARY_KEYS = ("steps", "t_s", "dt_s", "dt_crit_s", "dofs", "interface_points", "complete", "initiation",
                "tip", "fronts", "watchdog", "ended_early")
ENERGY_RTOL = 1e-12


def _digest(a) -> str:
    a = np.ascontiguousarray(a)
    h = hashlib.sha256()
    h.update(str((a.dtype.str, a.shape)).encode())
    h.update(a.tobytes())
    return h.hexdigest()


def _run_digests(rundir: Path) -> dict:
    """Digests of everything the run-directory reader returns (fricfem.open_run):
    the interface rows, every quantity, the station histories."""
    from fricfem import open_run

    r = open_run(rundir)
    out = {"time": _digest(r.t), "x1": _digest(r.x1)}
    for name in r.names:
        out[name] = _digest(r.quantity(name))
    for st, data in r.stations.items():
        for q, v in data.items():
            out[f"stations/{st}/{q}"] = _digest(np.asarray(v))
    return out


def _field_digests(rundir: Path) -> dict:
    """Digests of every field snapshot as the field reader returns it."""
    from fricfem.output.quantities import FIELDS, FIELDS_FILE
    from fricfem.output.rundir import FieldReader

    path = Path(rundir) / FIELDS_FILE
    if not path.is_file():
        return {}
    out = {}
    for name in FIELDS:
        reader = FieldReader(path, name)
        for i, t in enumerate(reader.times):
            out[f"{name}@{t:.9e}"] = _digest(reader.values(i))
    return out


def _energy(rundir: Path) -> dict:
    from fricfem import open_run

    return {k: np.asarray(v).tolist() for k, v in open_run(rundir).energy.items()}


def fingerprint(rundir: Path) -> dict:
    """The fingerprint of a run directory (see the module docstring)."""
    rundir = Path(rundir)
    from fricfem.output.record import read_evidence

    summary = json.loads((rundir / "summary.json").read_text())
    results = {k: summary.get(k) for k in SUMMARY_KEYS}
    evidence = read_evidence(rundir)  # the per-step arrays: the tip every step, the fronts' tracks
    results.update({k: evidence[k] for k in ("tip", "fronts") if k in evidence})
    results["mode"] = (summary.get("mode") or {}).get("label")
    energy = summary.get("energy") or {}
    return {
        "interface.h5": _run_digests(rundir),
        "fields.h5": _field_digests(rundir),
        "summary": hashlib.sha256(json.dumps(results, sort_keys=True).encode()).hexdigest(),
        "summary_numbers": {"steps": summary.get("steps"), "dt_s": summary.get("dt_s"),
                            "mode": (summary.get("mode") or {}).get("label"),
                            "initiation": summary.get("initiation")},
        "energy_history": _energy(rundir),
        "energy_summary": {k: v for k, v in energy.items() if isinstance(v, (int, float))},
    }


def compare(got: dict, want: dict) -> list:
    """Differences between two fingerprints, as readable lines (empty: identical)."""
    bad = []
    for key in ("interface.h5", "fields.h5"):
        g, w = got.get(key, {}), want.get(key, {})
        for name in sorted(set(g) | set(w)):
            if g.get(name) != w.get(name):
                bad.append(f"{key}:{name} differs" if name in g and name in w else
                           f"{key}:{name} {'missing' if name in w else 'new'}")
    if got["summary"] != want["summary"]:
        bad.append(f"summary results differ: {got['summary_numbers']} vs {want['summary_numbers']}")
    for src in ("energy_history", "energy_summary"):
        g, w = got.get(src, {}), want.get(src, {})
        # an energy term added after the golden was recorded must be zero in it
        # (a new kind of sink, absent from the golden cases)
        added = {k: v for k, v in g.items() if k not in w}
        if set(w) - set(g) or any(np.any(np.asarray(v, dtype=float) != 0.0) for v in added.values()):
            bad.append(f"{src}: keys {sorted(g)} vs {sorted(w)}")
            continue
        # one scale per source: the largest energy in it (the balance error is a
        # small difference of large terms, compared on the terms' scale)
        scale = max([float(np.max(np.abs(np.asarray(v, dtype=float)))) for k, v in w.items()
                     if k != "time" and np.size(v)] + [1e-300])
        for k in w:
            a, b = np.asarray(g[k], dtype=float), np.asarray(w[k], dtype=float)
            if a.shape != b.shape or (a.size and np.max(np.abs(a - b)) > ENERGY_RTOL * scale):
                bad.append(f"{src}.{k} differs beyond {ENERGY_RTOL:g} relative")
    return bad


def run_case(name: str, out_root: Path, comm) -> Path | None:
    """Run one golden case into ``out_root/name``; the run directory on the ranks
    that ran it, None on the others (collective on ``comm``)."""
    from mpi4py import MPI

    from fricfem import scene as scene_mod
    from fricfem import runner

    scene_name, overrides, ranks = CASES[name]
    out = Path(out_root) / name
    scene = scene_mod.load(scene_name, overrides)
    if ranks == "world":
        runner.run_scene(scene, out, comm, overwrite=True, quiet=True)
        result = out
    else:
        result = None
        if comm.rank == 0:
            runner.run_scene(scene, out, MPI.COMM_SELF, overwrite=True, quiet=True)
            result = out
        comm.Barrier()
    return result


def main(argv) -> int:
    import tempfile

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    mode = argv[0] if argv else "check"
    names = argv[1:] or list(CASES)
    root = comm.bcast(tempfile.mkdtemp(prefix="fricfem-golden-") if comm.rank == 0 else None, root=0)
    status = 0
    for name in names:
        rundir = run_case(name, Path(root), comm)
        if comm.rank != 0:
            continue
        fp = fingerprint(rundir)
        path = GOLDEN_DIR / f"{name}.json"
        if mode == "record":
            GOLDEN_DIR.mkdir(exist_ok=True)
            path.write_text(json.dumps(fp, indent=1, sort_keys=True) + "\n")
            print(f"recorded {path}")
        else:
            bad = compare(fp, json.loads(path.read_text()))
            print(f"{name}: {'identical' if not bad else 'DIFFERS'}")
            for line in bad:
                print(f"  {line}")
            status = status or (1 if bad else 0)
    return comm.bcast(status, root=0)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    sys.exit(main(sys.argv[1:]))
