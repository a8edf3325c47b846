"""What fricfem gives for each shipped paper scene, as shipped (its own mesh and
end time): the sliding mode, when and where sliding starts.  The scene
descriptions and header comments are checked against this record
(tests/test_scene_descriptions.py), and the record against a fresh run of two
scenes (slow tests there).

    mpirun -n 2 .venv/bin/python tests/scene_modes.py record   # rewrites tests/golden/scene_modes.json
    mpirun -n 2 .venv/bin/python tests/scene_modes.py check    # compares without writing

Record again after a change of results, and update the descriptions it
contradicts (the test says which).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

RECORD = Path(__file__).parent / "golden" / "scene_modes.json"

#: The shipped scenes that set up the paper's computations (its Cases I–V, the
#: symmetric loading of Fig. 7a, lines A and B of Figs. 20 and 21).
PAPER = ("case1", "case2", "case3", "case4", "case5", "symmetric", "lineA_v2", "lineA_v7", "lineA_v10",
         "lineA_v20", "lineA_v40", "lineB_s6", "lineB_s10", "lineB_s16", "lineB_s30")


def outcome(name: str, out: Path, comm) -> dict:
    """Run shipped scene ``name`` as shipped (no figures, no fields) and say what it gave."""
    from fricfem import load_scene, runner

    scene = load_scene(name, ["output.fields=[]"])
    s = runner.run_scene(scene, out / name, comm, quiet=True)
    init = s.get("initiation")
    return {
        "mode": (s.get("mode") or {}).get("label"),
        "sliding_from_s": None if init is None else init["time_s"],
        "sliding_from_x1_m": None if init is None else init["x1_m"],
        "t_end_s": scene.t_end, "mesh": scene.raw.get("mesh", {}).get("preset", "reference"),
        "steps": s["steps"], "complete": s["complete"],
    }


def record_all(comm) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = comm.bcast(tmp if comm.rank == 0 else None, root=0)
        return {name: outcome(name, Path(tmp), comm) for name in PAPER}


def main(argv) -> int:
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    mode = argv[1] if len(argv) > 1 else "check"
    got = record_all(comm)
    if comm.rank != 0:
        return 0
    doc = {"command": "mpirun -n 2 .venv/bin/python tests/scene_modes.py record", "ranks": comm.size,
           "note": "each shipped paper scene as shipped (its mesh, end time), output.fields = []", "scenes": got}
    if mode == "record":
        RECORD.write_text(json.dumps(doc, indent=1) + "\n")
        print(f"wrote {RECORD}")
        return 0
    old = json.loads(RECORD.read_text())["scenes"]
    bad = [n for n in PAPER if old.get(n, {}).get("mode") != got[n]["mode"]]
    for n in PAPER:
        print(f"{n:10s} {got[n]['mode']:11s} recorded {old.get(n, {}).get('mode')}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
