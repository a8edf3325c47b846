"""`make demo` in the suite: demos/impact.py on its small setting (``--small``:
the coarse mesh, 6 µs, two field snapshots) as a separate 2-rank job, its
fields read back by pyvista (VTK's XDMF reader, the pinned pyvista), and a
read-back that fails fails the demo.

Under ``mpirun -n 2`` (1 rank works too): rank 0 starts the job and checks it.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import faults

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "demos" / "impact.py"


def _launcher() -> str:
    """The MPI launcher of this interpreter: its venv's own ``mpiexec`` if it has one
    (the PyPI wheel's MPICH, which Debian's OpenMPI ``mpirun`` refuses), else ``mpirun``."""
    own = Path(sys.executable).parent / "mpiexec"
    return str(own) if own.exists() else "mpirun"


def _demo(out: Path, *args, env=None) -> subprocess.CompletedProcess:
    """``mpirun -n 2 python demos/impact.py --small --out OUT ARGS`` from the checkout
    (the timeout only bounds a hang)."""
    return subprocess.run([_launcher(), "-n", "2", sys.executable, str(DEMO), "--small", "--out", str(out), *args],
                          cwd=ROOT, capture_output=True, text=True, env=env or faults.clean_env(), timeout=1800)


def _on_rank0(comm, fn):
    result = fn() if comm.rank == 0 else None
    return comm.bcast(result, root=0)


@pytest.mark.slow
def test_the_demo_runs_and_its_fields_read_back(comm, tmp_dir_shared):
    """The demo's default scenes (a sliding case first) on the small setting: exit 0,
    every run directory holds its outputs and figures, and demo.json's
    ``fields_read_back`` is what pyvista read: both snapshot times, the three
    functions, finite σ1 − σ2 on every cell of the coarse mesh."""
    def work():
        out = tmp_dir_shared / "demo"
        res = _demo(out)
        doc = json.loads((out / "demo.json").read_text()) if (out / "demo.json").exists() else None
        files = {label: sorted(p.name for p in (out / label).iterdir()) for label in (doc or {})}
        plots = {label: len(list((out / label / "plots").glob("*.png"))) for label in (doc or {})}
        return res.returncode, res.stderr[-3000:], doc, files, plots

    status, err, doc, files, plots = _on_rank0(comm, work)
    assert status == 0, err
    assert doc and len(doc) >= 2, doc  # the demo runs at least two scenes
    for label, r in doc.items():
        back = r["fields_read_back"]
        assert isinstance(back, dict), f"{label}: {back}"
        assert back["times_s"] == pytest.approx([3e-6, 6e-6], rel=0.05), back
        assert {"displacement", "velocity", "stress_difference"} <= set(back["arrays"]), back
        assert back["cells"] > 0 and back["max_sigma1_minus_sigma2_MPa"] > 0.0, back
        assert {"interface.h5", "summary.json", "fields.xdmf", "plots"} <= set(files[label]), files[label]
        assert plots[label] > 0, f"{label}: no figures"


@pytest.mark.slow
def test_a_failed_read_back_fails_the_demo(comm, tmp_dir_shared):
    """With a pyvista that cannot be imported (a broken module first on PYTHONPATH,
    seen by the read-back's process only: the run itself does not import pyvista),
    the demo writes why into demo.json and exits non-zero, saying so on stderr."""
    def work():
        broken = tmp_dir_shared / "broken"
        broken.mkdir()
        (broken / "pyvista.py").write_text("raise ImportError('pyvista broken on purpose by tests/test_demo.py')\n")
        env = faults.clean_env()
        env["PYTHONPATH"] = str(broken)
        out = tmp_dir_shared / "demo"
        res = _demo(out, "--scene", "case3", env=env)
        doc = json.loads((out / "demo.json").read_text())
        return res.returncode, res.stderr[-3000:], doc

    status, err, doc = _on_rank0(comm, work)
    assert status != 0
    assert "could not be read back" in err
    back = doc["case3"]["fields_read_back"]
    assert isinstance(back, str) and back.startswith("failed:") and "broken on purpose" in back, back
