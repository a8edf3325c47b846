# # Absorbing edges: reflection of a plane wave at normal incidence
#
# The reference is not fricfem's own: a plate twice as long, whose far edge the
# wave does not reach in the time of the run, gives the motion without any
# reflection; the difference at a probe between the damped plate (Lysmer-
# Kuhlemeyer dashpots on its right edge) and the long one is the reflected
# wave.  A Gaussian P or S pulse (width 6 mm) travelling towards the edge;
# plates 100 × 100 mm (and 200 × 100 mm), plane strain, the probe 16 mm from
# the edge and 30 mm below the interface, the interface bonded (law
# ``stuck``), elastic or rigid.  The same set-up as tests/test_absorbing.py,
# on two meshes.
#
# Run (a few minutes, serial or under mpirun):
#
#     .venv/bin/python benchmarks/absorbing_reflection.py [--h 2e-3 1e-3]
#
# Writes ``benchmarks/results/absorbing_reflection.{json,md}``.

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import friction
from fricfem.model import mesh
from fricfem.model.build import build
from fricfem.model.loading import ImpactPulse
from fricfem.model.material import Material
from fricfem.step import State, step

RESULTS = Path(__file__).resolve().parent / "results"
WIDTH = 6e-3  # Gaussian pulse width [m]
X0, XP = 0.07, 0.084  # pulse centre and probe [m]; the damped edge at x1 = 0.1


def probe_history(h: float, length: float, absorbing, wave: str, kind: str, comm) -> np.ndarray:
    """The probe's velocity (the pulse's component) at every step."""
    spec = mesh.MeshSpec(length=length, height=0.1, dx=h, dy=h, fine_x0=0.0, fine_x1=length, fine_height=0.1,
                         impact_b=0.02, grading=1.0, max_size=h)
    mat = Material(plane="strain")
    c = mat.c_l if wave == "P" else mat.c_s
    t_end = (2 * 0.1 - X0 - XP) / c + 3 * WIDTH / c  # the reflection has passed the probe
    model = build(mesh.build(spec, comm), mat, ImpactPulse(v_imp=0.0), friction.get_law("stuck"), np.zeros(0),
                  1e6, 1e13, 1e13, impact_tags=(), interface_kind=kind, absorbing=absorbing, dt=0.2 * h / mat.c_l)
    st = State(model, skip_quiet=False)
    x = model.num.x[model.num.owned_nodes]
    comp = 0 if wave == "P" else 1
    shape = lambda s: 1e-6 * np.exp(-(s / WIDTH) ** 2)  # noqa: E731
    st.u.array[comp::2] = shape(x[:, 0] - X0)
    s = x[:, 0] - X0 + 0.5 * c * model.dt  # v at t = -dt/2 of a pulse travelling towards +x1
    st.v.array[comp::2] = 2 * c * s / WIDTH**2 * shape(s)
    st.wake()
    probe = np.flatnonzero((np.abs(x[:, 0] - XP) < 1e-9) & (np.abs(x[:, 1] + 0.03) < 0.5 * h))[:1]
    hist = []
    while st.t < t_end:
        step(model, st, None)
        val = float(st.v.array_r[2 * probe[0] + comp]) if len(probe) else 0.0
        hist.append(comm.allreduce(val, op=MPI.SUM))
    return np.array(hist)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description="reflection of a plane wave at an absorbing edge")
    ap.add_argument("--h", nargs="+", type=float, default=[2e-3, 1e-3], help="cell sizes [m]")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    t0 = time.perf_counter()
    for h in args.h:
        for wave in ("P", "S"):
            for kind in ("elastic", "rigid"):
                damped = probe_history(h, 0.1, ("right",), wave, kind, comm)
                free = probe_history(h, 0.2, (), wave, kind, comm)
                rows.append({"h_m": h, "wave": wave, "kind": kind,
                             "reflection": float(np.abs(damped - free).max() / np.abs(free).max())})
                if comm.rank == 0:
                    print(f"h = {h * 1e3:g} mm, {wave}, {kind}: reflection {100 * rows[-1]['reflection']:.2f} % "
                          "of the incident peak", flush=True)
    doc = {"date": time.strftime("%Y-%m-%d %H:%M"), "ranks": comm.size, "seconds": time.perf_counter() - t0,
           "rows": rows}
    if comm.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "absorbing_reflection.json").write_text(json.dumps(doc, indent=1))
        L = ["# Absorbing edges: reflection at normal incidence", "",
             f"`.venv/bin/python benchmarks/absorbing_reflection.py` ({doc['date']}, {comm.size} rank(s), "
             f"{doc['seconds']:.0f} s).  A Gaussian P or S pulse (6 mm) meets the dashpots of the right edge "
             "head-on; the reflected wave is the difference at a probe between the damped plate and a plate twice "
             "as long (no reflection within the run), as a share of the incident peak.", "",
             "| h [mm] | wave | interface | reflection [% of the incident peak] |", "|---|---|---|---|"]
        L += [f"| {r['h_m'] * 1e3:g} | {r['wave']} | {r['kind']} | {100 * r['reflection']:.2f} |" for r in rows]
        (args.out / "absorbing_reflection.md").write_text("\n".join(L) + "\n")
    return doc


if __name__ == "__main__":
    main()
