"""Golden outputs: fingerprints of whole runs, to prove that a change of code
leaves the physics bit-identical.

A fingerprint holds the SHA-256 of every array a run writes (interface.h5,
fields.h5) and of the summary's numbers, so equal fingerprints mean equal bits.
Only the physics counts: datasets and result numbers, not file
attributes (units, format versions) or where the mode's evidence is kept.
Nothing a fingerprint holds passes through BLAS or LAPACK: λmax (and so
``dt_crit_s``), the energies and the field stress are summed or solved in an
order of fricfem's own (``fricfem.kernels.reduce``,
``fricfem.output.gauges.inverse_2x2``), so the same bits come out under
reference BLAS or OpenBLAS on any processor (tests/test_blas.py runs this check
under each).  The energy history is kept as numbers: bit-exact in exact mode
(:data:`ENERGY_RTOL` = 0; it was 1e-12 while its dot products went through
BLAS), within 1e-9 of its scale (the largest energy) in tolerance mode.

Two modes of comparison:

* ``exact`` (the default on every stack: dolfinx 0.5.2, 0.9 and the 0.11 wheel
  give the same datasets, bit for bit): every SHA-256 digest must match.
  Never loosened.  One summary number is kept apart: ``dt_crit_s`` = 2/√λmax,
  compared within :data:`DT_CRIT_RTOL` = 1e-12 relative.  Its power iteration
  starts from a vector made with ``np.sin`` of the grid coordinates
  (``fricfem.model.assembly._coordinate_noise``), and numpy 1.24 (Debian 12)
  and numpy >= 2.2 (Debian 13, the 0.11 wheel) round sin differently in its last
  bits: 5e-15 relative on case3_20us_1rank (PETSc's K·x is the same bits on
  PETSc 3.18, 3.22 and 3.25 given the same x).  The step itself, ``dt_s``
  (dt_crit × dt_safety rounded down to 3 digits), and so every dataset, stay
  bit-exact.
* ``tolerance`` (asked for only, ``FRICFEM_GOLDEN=tolerance``: for a stack
  that rounds differently somewhere fricfem cannot reach; docs/install.md): a dataset whose digest differs passes if its
  shape, its count of non-finite values and its *scale numbers* agree within
  :data:`TOLERANCE` = 1e-9 relative to the dataset's scale s = max |a|: s
  itself, the root mean square / s and :data:`N_PROJECTIONS` projections
  Σ r_i a_i / (s n) on fixed-seed random r_i in [-1, 1] (each moves by at most
  the largest |Δa_i| / s, so round-off within 1e-9 of s always passes; a
  change of 1e-6 of s in a whole dataset never does).  The summary's results
  are compared the same way, key by key (numbers within 1e-9 of each key's
  scale; strings, flags and counts exactly); the energies within 1e-9.

The mode is ``exact`` unless ``FRICFEM_GOLDEN=tolerance`` (or ``--tolerance``
after ``check``) asks for the other.  Tolerance mode was the default from
dolfinx 0.10 on while the 0.11 wheel's goldens differed (13 of 37 datasets of
the coarse Case I, e.g. the shear traction by 1.5e-11 of 1.85e5): the cause was
the interface's Gauss weights, taken from numpy's ``leggauss``, which numpy 2.3
rounds 2 ulp away from numpy <= 2.2; fricfem now holds them as a fixed table
(``fricfem.model.interface``, tests/test_stack_bits.py) and the wheel gives the
goldens' bits.

    mpirun -n 2 .venv/bin/python tests/golden.py record     # after a deliberate change of results
    mpirun -n 2 .venv/bin/python tests/golden.py check      # what tests/test_golden.py does
    mpirun -n 2 .venv/bin/python tests/golden.py check case3 --tolerance

Recording overwrites ``tests/golden/*.json``; say in the commit why results changed.
"""

from __future__ import annotations

import hashlib
import json
import os
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
SUMMARY_KEYS = ("steps", "t_s", "dt_s", "dofs", "interface_points", "complete", "initiation",
                "tip", "fronts", "watchdog", "ended_early")
#: the relative tolerance on dt_crit_s in both modes (λmax's start vector through np.sin: see the module docstring)
DT_CRIT_RTOL = 1e-12
#: exact mode: the energies' tolerance relative to their scale (0: bit-exact; their sums are fricfem's own)
ENERGY_RTOL = 0.0
#: tolerance mode: the relative tolerance on each dataset's scale numbers (see the module docstring)
TOLERANCE = 1e-9
#: tolerance mode: the number of fixed-seed random projections kept per dataset
N_PROJECTIONS = 4
#: the environment variable that forces a mode ("exact" or "tolerance")
MODE_ENV = "FRICFEM_GOLDEN"


def default_mode() -> str:
    """``exact`` or ``tolerance``: :data:`MODE_ENV` if set, else ``exact`` (on
    every dolfinx: 0.5.2, 0.9 and 0.11 give the goldens' bits)."""
    forced = os.environ.get(MODE_ENV, "").strip().lower()
    if forced:
        if forced not in ("exact", "tolerance"):
            raise SystemExit(f"{MODE_ENV} = {forced!r}: must be 'exact' or 'tolerance'")
        return forced
    return "exact"


def scale_numbers(a) -> dict:
    """The numbers tolerance mode compares for one array (see the module docstring):
    shape, count of non-finite values, scale s = max |a| over the finite values,
    rms / s and :data:`N_PROJECTIONS` projections Σ r_i a_i / (s n)."""
    shape = list(np.shape(a))
    a = np.asarray(a, dtype=np.float64).ravel()
    finite = np.isfinite(a)
    v = np.where(finite, a, 0.0)
    n = max(len(v), 1)
    s = float(np.max(np.abs(v))) if len(v) else 0.0
    d = s if s > 0.0 else 1.0
    rng = np.random.default_rng(20261128)
    proj = [float(np.sum(rng.uniform(-1.0, 1.0, len(v)) * v) / (d * n)) for _ in range(N_PROJECTIONS)]
    return {"shape": shape, "nonfinite": int(len(a) - finite.sum()), "scale": s,
            "rms": float(np.sqrt(np.sum((v / d) ** 2) / n)), "proj": proj}


def _numbers_close(g: dict, w: dict) -> bool:
    """Tolerance mode: two :func:`scale_numbers` agree (see the module docstring)."""
    if g["shape"] != w["shape"] or g["nonfinite"] != w["nonfinite"]:
        return False
    s = max(abs(g["scale"]), abs(w["scale"]))
    if abs(g["scale"] - w["scale"]) > TOLERANCE * s:
        return False
    return all(abs(x - y) <= TOLERANCE for x, y in zip([g["rms"], *g["proj"]], [w["rms"], *w["proj"]]))


def _leaves(obj, numbers: list, others: list) -> None:
    """Split a JSON value into its numbers (in order) and everything else (flags,
    strings, None, the structure's keys and lengths)."""
    if isinstance(obj, dict):
        for k in sorted(obj):
            others.append(k)
            _leaves(obj[k], numbers, others)
    elif isinstance(obj, (list, tuple)):
        others.append(len(obj))
        for v in obj:
            _leaves(v, numbers, others)
    elif isinstance(obj, float) or (isinstance(obj, int) and not isinstance(obj, bool)):
        numbers.append(float(obj))
        others.append(type(obj).__name__)
    else:
        others.append(obj)


def _result_numbers(results: dict) -> dict:
    """Per summary key: the scale numbers of its numbers and a digest of the rest."""
    out = {}
    for k in sorted(results):
        numbers, others = [], []
        _leaves(results[k], numbers, others)
        out[k] = {"numbers": scale_numbers(numbers),
                  "rest": hashlib.sha256(json.dumps(others).encode()).hexdigest()}
    return out


def _digest(a) -> str:
    a = np.ascontiguousarray(a)
    h = hashlib.sha256()
    h.update(str((a.dtype.str, a.shape)).encode())
    h.update(a.tobytes())
    return h.hexdigest()


def _run_arrays(rundir: Path) -> dict:
    """Everything the run-directory reader returns (fricfem.open_run): the
    interface rows, every quantity, the station histories."""
    from fricfem import open_run

    r = open_run(rundir)
    out = {"time": r.t, "x1": r.x1}
    for name in r.names:
        out[name] = r.quantity(name)
    for st, data in r.stations.items():
        for q, v in data.items():
            out[f"stations/{st}/{q}"] = np.asarray(v)
    return out


def _field_arrays(rundir: Path) -> dict:
    """Every field snapshot as the field reader returns it."""
    from fricfem.output.quantities import FIELDS, FIELDS_FILE
    from fricfem.output.rundir import FieldReader

    path = Path(rundir) / FIELDS_FILE
    if not path.is_file():
        return {}
    out = {}
    for name in FIELDS:
        reader = FieldReader(path, name)
        for i, t in enumerate(reader.times):
            out[f"{name}@{t:.9e}"] = reader.values(i)
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
    run, fields = _run_arrays(rundir), _field_arrays(rundir)
    return {
        "interface.h5": {k: _digest(v) for k, v in run.items()},
        "fields.h5": {k: _digest(v) for k, v in fields.items()},
        "summary": hashlib.sha256(json.dumps(results, sort_keys=True).encode()).hexdigest(),
        # what tolerance mode compares where a digest differs (see the module docstring)
        "scale_numbers": {"interface.h5": {k: scale_numbers(v) for k, v in run.items()},
                          "fields.h5": {k: scale_numbers(v) for k, v in fields.items()},
                          "summary": _result_numbers(results)},
        "dt_crit_s": summary.get("dt_crit_s"),
        "summary_numbers": {"steps": summary.get("steps"), "dt_s": summary.get("dt_s"),
                            "mode": (summary.get("mode") or {}).get("label"),
                            "initiation": summary.get("initiation")},
        "energy_history": _energy(rundir),
        "energy_summary": {k: v for k, v in energy.items() if isinstance(v, (int, float))},
    }


def compare(got: dict, want: dict, mode: str = "exact") -> list:
    """Differences between two fingerprints, as readable lines (empty: identical,
    or in ``mode="tolerance"`` within :data:`TOLERANCE`; see the module docstring)."""
    if mode not in ("exact", "tolerance"):
        raise ValueError(f"mode {mode!r}: 'exact' or 'tolerance'")
    tol = mode == "tolerance"
    gnum, wnum = got.get("scale_numbers", {}), want.get("scale_numbers", {})
    if tol and not wnum:
        return ["the golden has no scale numbers for tolerance mode: record it again (tests/golden.py record)"]
    bad = []
    for key in ("interface.h5", "fields.h5"):
        g, w = got.get(key, {}), want.get(key, {})
        for name in sorted(set(g) | set(w)):
            if g.get(name) != w.get(name):
                if name in g and name in w:
                    if not (tol and _numbers_close(gnum[key][name], wnum[key][name])):
                        bad.append(f"{key}:{name} differs" + (f" beyond {TOLERANCE:g} of its scale" if tol else ""))
                else:
                    bad.append(f"{key}:{name} {'missing' if name in w else 'new'}")
    if got["summary"] != want["summary"]:
        far = sorted(k for k in set(gnum.get("summary", {})) | set(wnum.get("summary", {}))
                     if k not in gnum.get("summary", {}) or k not in wnum.get("summary", {})
                     or gnum["summary"][k]["rest"] != wnum["summary"][k]["rest"]
                     or not _numbers_close(gnum["summary"][k]["numbers"], wnum["summary"][k]["numbers"]))
        if not tol or far:
            bad.append(f"summary results differ{f' beyond {TOLERANCE:g} in {far}' if tol else ''}: "
                       f"{got['summary_numbers']} vs {want['summary_numbers']}")
    g, w = got.get("dt_crit_s"), want.get("dt_crit_s")
    if g is None or w is None or abs(g - w) > DT_CRIT_RTOL * abs(w):
        bad.append(f"dt_crit_s differs beyond {DT_CRIT_RTOL:g}: {g!r} vs {w!r}")
    energy_rtol = TOLERANCE if tol else ENERGY_RTOL
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
            if a.shape != b.shape or (a.size and not np.max(np.abs(a - b)) <= energy_rtol * scale):
                bad.append(f"{src}.{k} differs" + (f" beyond {energy_rtol:g} relative" if energy_rtol else ""))
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


def blas_in_use() -> dict:
    """The BLAS and LAPACK this process has loaded (from /proc/self/maps: the
    libraries the dynamic linker picked, e.g. by LD_LIBRARY_PATH, for numpy
    and for PETSc once a run has loaded it) and, for OpenBLAS, the processor
    kernel it runs (``openblas_get_corename``, which OPENBLAS_CORETYPE sets).
    Imports nothing but numpy (PETSc is initialised by dolfinx, on every rank
    alike: importing petsc4py first on one rank only corrupts the job)."""
    import ctypes

    import numpy  # noqa: F401  (loads the BLAS the process will use)

    libs = set()
    try:
        with open("/proc/self/maps") as fh:
            for line in fh:
                path = line.split()[-1] if len(line.split()) >= 6 else ""
                name = os.path.basename(path)
                if name.startswith(("libblas", "liblapack", "libopenblas")):
                    libs.add(os.path.realpath(path))
    except OSError:
        pass
    core = None
    for path in sorted(libs):
        try:
            fn = ctypes.CDLL(path).openblas_get_corename
        except (OSError, AttributeError):
            continue
        fn.restype = ctypes.c_char_p
        core = fn().decode()
        break
    return {"libraries": sorted(libs), "openblas_core": core}


def main(argv) -> int:
    import tempfile

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    flags = [a for a in argv if a.startswith("--")]
    argv = [a for a in argv if not a.startswith("--")]
    mode = argv[0] if argv else "check"
    names = argv[1:] or list(CASES)
    unknown = [f for f in flags if f not in ("--tolerance", "--exact")] + [n for n in names if n not in CASES]
    if mode not in ("check", "record") or unknown:
        raise SystemExit(f"usage: golden.py [check|record] [{'|'.join(CASES)} ...] [--tolerance|--exact]"
                         f"{f' (not {unknown})' if unknown else ''}")
    how = "tolerance" if "--tolerance" in flags else "exact" if "--exact" in flags else default_mode()
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
            bad = compare(fp, json.loads(path.read_text()), how)
            print(f"{name}: {'DIFFERS' if bad else 'identical' if how == 'exact' else 'within tolerance'}")
            for line in bad:
                print(f"  {line}")
            status = status or (1 if bad else 0)
    if comm.rank == 0:  # after the runs: the libraries numpy and PETSc actually used
        print(f"blas: {json.dumps(blas_in_use())}; compare: {how}", flush=True)
    return comm.bcast(status, root=0)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    sys.exit(main(sys.argv[1:]))
