"""The memory estimate of the cost guard (fricfem/scene/cost.py, MEMORY): a scene whose
estimated peak exceeds the memory available on the node is refused, with one line naming
the estimate and what is available, before any mesh is built; ``--force`` lets it run.

The fit itself is measured by benchmarks/memory.py (the numbers sit next to
:data:`fricfem.scene.cost.MEMORY`); here the estimate is checked against the peak of a
real set-up in a fresh process.  Runs under ``mpirun -n 2``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mpi4py import MPI

from fricfem import cli, load_scene
from fricfem.scene import SceneError, cost

RANK = MPI.COMM_WORLD.rank
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def no_mesh(monkeypatch):
    """Any mesh built during the test fails it."""
    def refuse(*args, **kwargs):
        raise AssertionError("a mesh was built before the memory guard refused the scene")

    monkeypatch.setattr("fricfem.model.mesh.build", refuse)


def test_over_the_available_memory_is_refused_before_the_mesh(no_mesh):
    scene = load_scene("rsf_aging_2d")  # 89.6k quadrilaterals: about 1.1 GB of grid, 0.97 GB for 2 ranks
    est = cost.estimate(scene, 2)
    assert 2.0e9 < est.memory_bytes < 3.0e9
    with pytest.raises(SceneError) as err:
        cost.check(scene, ranks=(2, 2), available=1.0e9)
    msg = str(err.value)
    assert "\n" not in msg
    assert f"{est.memory_bytes / 1e9:.3g} GB of memory estimated for the 2 rank(s)" in msg
    assert "above the 1 GB available (MemAvailable)" in msg and "--force" in msg
    assert cost.check(scene, force=True, ranks=(2, 2), available=1.0e9).memory_bytes == est.memory_bytes
    # the node's share: 2 of 4 ranks here need half the estimate of 4
    half = cost.estimate(scene, 4).memory_bytes / 2
    cost.check(scene, ranks=(4, 2), available=half * 1.001)
    with pytest.raises(SceneError):
        cost.check(scene, ranks=(4, 2), available=half * 0.999)


def test_check_states_the_memory_estimate(capsys):
    capsys.readouterr()
    assert cli.main(["run", "rsf_aging_2d", "--check"]) == 0
    out = capsys.readouterr().out
    if RANK == 0:
        est = cost.estimate(load_scene("rsf_aging_2d"), MPI.COMM_WORLD.size)
        assert f"memory: about {est.memory_bytes / 1e9:.3g} GB" in out and "(MemAvailable)" in out, out


def test_the_command_refuses_a_scene_larger_than_this_machine(capsys, no_mesh, tmp_path):
    """``fricfem run`` (not only --check) says no in one line; no run directory is made."""
    free = cost.available_bytes()
    assert free is not None and free > 0
    # quadrilaterals enough to need more than twice the memory this node has (still within HARD):
    # two 70 × 40 mm plates of h × h cells
    quads = 2.4 * free / cost.MEMORY["quad"]
    if quads > cost.BUDGET["quads"]:  # a node this large: the budget of quadrilaterals refuses first
        pytest.skip(f"{free / 1e9:.3g} GB available: no scene within the budget exceeds it")
    h = (2 * 0.07 * 0.04 / quads) ** 0.5
    out = tmp_path / "never"
    argv = ["run", "rsf_aging_2d", "--set", f"mesh.dx={h:.3e}", "--set", f"mesh.dy={h:.3e}",
            "--set", "mesh.fine_height=0.04", "--out", str(out)]
    capsys.readouterr()
    status = cli.main(argv)
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert status == 2
    assert not out.exists()
    if RANK == 0:
        assert len(err) == 1, err
        assert "GB of memory estimated" in err[0] and "available (MemAvailable)" in err[0], err[0]
    else:
        assert err == []


def test_the_estimate_covers_a_measured_set_up(tmp_path):
    """A fresh process's peak (VmHWM) through set-up and a short loop, summed over 2
    ranks, lies below the estimate and within 30 % of its quadrilateral part."""
    if RANK == 0:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PMI_"))}
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1")
        rows = tmp_path / "memory.jsonl"
        subprocess.run(["mpirun", "-n", "2", "--oversubscribe", sys.executable, str(ROOT / "benchmarks" / "memory.py"),
                        "--h", "2.5e-4", "--band", "0.024", "--kind", "rigid", "--end", "1e-6",
                        "--out", str(rows)], cwd=ROOT, env=env, check=True, capture_output=True, timeout=1800)
        row = json.loads(rows.read_text().splitlines()[-1])
        scene = load_scene("rsf_aging_2d", ["mesh.dx=2.5e-4", "mesh.dy=2.5e-4", "mesh.fine_height=0.024",
                                            "interface.kind='rigid'", "time.end=1e-6"])
        est = cost.estimate(scene, 2)
        assert est.quads == row["quads"]
        peak = row["loop_peak_bytes"]
        assert peak < est.memory_bytes, (peak, est.memory_bytes)
        grid = peak - 2 * cost.MEMORY["rank"]
        assert abs(grid - cost.MEMORY["quad"] * est.quads) < 0.3 * cost.MEMORY["quad"] * est.quads, (grid, est)
    MPI.COMM_WORLD.barrier()
