# # Shear impact on two pre-compressed plates — the paper's Case I set-up
#
# Two Homalite plates (137 mm × 75 mm each) are pressed together by a uniform
# compression Σ0 and the lower plate is struck on its edge x1 = 0 over
# −25 mm ≤ x2 ≤ 0 with a trapezoidal velocity pulse (rise 10 µs, plateau
# V_imp).  The interface x2 = 0 is the Povirk–Needleman elastic interface with
# the paper's rate- and state-dependent friction (Table 1).  This demo runs the
# paper's Case I (Σ0 = 6 MPa, V_imp = 2 m/s) on the reference mesh
# (0.30 mm × 0.20 mm cells near the interface) to 40 µs and writes
#
# - `fields.xdmf/.h5`: displacement, velocity and σ1 − σ2 (prestress included)
#   at 16, 22, 32 and 40 µs — open it in ParaView;
# - `interface.png`: Δu̇_slip, |T_s|, T_n and μ_app along the interface at 22
#   and 32 µs (the paper's Fig. 8a kind);
# - `isochromatics.png`: fringes sin²(π N), N = (σ1 − σ2) h / f_σ, at 32 µs
#   (the paper's Fig. 9 kind);
# - `summary.json`: sizes, step, timings and what the interface did.
#
# Run: `mpirun -n 2 .venv/bin/python demos/impact.py [--v-imp 10] [--out DIR]`.
# The XDMF file is read back with pyvista (VTK's reader, independent of dolfinx) at the end.

import argparse
import os
import json
import logging
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
from fricfem import friction, gather, mesh, plots, solver
from fricfem.io import FieldWriter
from fricfem.loading import ImpactPulse
from fricfem.material import Material

logging.getLogger().setLevel(logging.WARNING)
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--sigma0", type=float, default=6.0, help="Σ0 [MPa]")
parser.add_argument("--v-imp", type=float, default=2.0, help="V_imp [m/s]")
parser.add_argument("--t-end", type=float, default=40.0, help="end time [µs]")
parser.add_argument("--preset", default="reference")
parser.add_argument("--out", default="demos/output/impact")
args = parser.parse_args()
comm = MPI.COMM_WORLD
out = Path(args.out)
if comm.rank == 0:
    out.mkdir(parents=True, exist_ok=True)
comm.Barrier()
t0 = time.perf_counter()

# ## Model
# Mesh, Homalite in plane stress, the impact pulse, the friction law with the
# Table 1 parameters, and C_n = 0.3 MPa/µm, C_s = 0.1 MPa/µm (SPEC §3).
pm = mesh.build(mesh.preset(args.preset), comm)
material = Material()
law = friction.get_law("povirk_needleman")
params = friction.pack(law, friction.validate(law, {}))
sigma0 = args.sigma0 * 1e6
model = solver.build(pm, material, ImpactPulse(v_imp=args.v_imp), law, params, sigma0, Cn=3e11, Cs=1e11)
state = solver.State(model)
writer = FieldWriter(out / "fields.xdmf", model.V, material, sigma0)
t_setup = time.perf_counter() - t0

# ## Time loop
# Fields at the snapshot times, interface profiles at 22 and 32 µs, and the
# first time/place of frictional slip.
snapshots = [16e-6, 22e-6, 32e-6, args.t_end * 1e-6]
profiles = {}
first_slip = None
energy = None
x1 = model.interface.geometry.x1
t1 = time.perf_counter()
for st, e in solver.evolve(model, state, args.t_end * 1e-6, energy_every=100):
    energy = e or energy
    sliding = model.interface.points.slip_rate > 0
    if first_slip is None and comm.allreduce(bool(sliding.any()), op=MPI.LOR):
        first_slip = (st.t, comm.allreduce(float(x1[sliding].min(initial=np.inf)), op=MPI.MIN))
    if snapshots and st.t >= snapshots[0] - 0.5 * model.dt:
        snapshots.pop(0)
        writer.write(st)
        if abs(st.t - 22e-6) < model.dt or abs(st.t - 32e-6) < model.dt:
            profiles[st.t] = gather.interface_profile(model.interface)
        if abs(st.t - 32e-6) < model.dt:
            xy, sdiff = gather.cell_triangles(writer.s)
            if comm.rank == 0:
                plots.isochromatics(xy, sdiff, out / "isochromatics.png",
                                    title=f"σ1 − σ2 fringes at {st.t * 1e6:.0f} µs",
                                    window=(0.0, 0.08, -0.03, 0.03))
t_loop = time.perf_counter() - t1
writer.close()

# ## Report
summary = {
    "sigma0_MPa": args.sigma0, "v_imp_m_s": args.v_imp, "ranks": comm.size,
    "dofs": 2 * pm.mesh.topology.index_map(0).size_global, "dt_s": model.dt, "steps": state.n,
    "wall_s": {"setup": t_setup, "time_loop": t_loop},
    "us_per_step": 1e6 * t_loop / max(state.n, 1),
    "first_slip": None if first_slip is None else {"time_s": first_slip[0], "x1_m": first_slip[1]},
    "energy": energy,
}
if comm.rank == 0:
    plots.interface_distributions(profiles, out / "interface.png",
                                  title=f"Σ0 = {args.sigma0:g} MPa, V_imp = {args.v_imp:g} m/s")
    import pyvista  # read the fields back with VTK's XDMF reader, independent of dolfinx

    reader = pyvista.get_reader(str(out / "fields.xdmf"))
    reader.set_active_time_value(reader.time_values[-1])
    blocks = reader.read()
    u = blocks[blocks.keys().index("displacement")].point_data["displacement"]
    summary["xdmf_readback"] = {"times_s": list(reader.time_values), "blocks": list(blocks.keys()),
                                "max_u1_m": float(np.abs(u[:, 0]).max())}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))
