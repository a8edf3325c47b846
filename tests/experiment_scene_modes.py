"""What fricfem gives for each shipped scene of the experiment and of the sliding
modes (``experiment_*``, ``mode_*``), as shipped: the sliding mode, when and
where sliding starts (:func:`scene_modes.outcome`, the paper scenes' record).
Their descriptions are checked against this record
(tests/test_scene_descriptions.py).

    mpirun -n 2 .venv/bin/python tests/experiment_scene_modes.py   # rewrites tests/golden/experiment_scene_modes.json

Record again after a change of results, and update the descriptions it
contradicts (the test says which).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from scene_modes import outcome  # noqa: E402

RECORD = Path(__file__).parent / "golden" / "experiment_scene_modes.json"


def names() -> list:
    """The shipped experiment and mode scenes."""
    from fricfem.scene import shipped

    return sorted(n for n in shipped() if n.startswith(("experiment_", "mode_")))


def main() -> int:
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(comm.bcast(tmp if comm.rank == 0 else None, root=0))
        got = {name: outcome(name, tmp, comm) for name in names()}
    if comm.rank == 0:
        doc = {"command": "mpirun -n 2 .venv/bin/python tests/experiment_scene_modes.py", "ranks": comm.size,
               "note": "each shipped experiment and mode scene as shipped (its mesh, end time), output.fields = []",
               "scenes": got}
        RECORD.write_text(json.dumps(doc, indent=1) + "\n")
        for n, g in got.items():
            print(f"{n:36s} {g['mode']:11s} from {g['sliding_from_s']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
