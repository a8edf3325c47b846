# # What impact velocity do the paper's initiation times require?
#
# Until the first point slides, the interface sticks (β ≤ 1 ⇒ Δu̇_slip = 0)
# and the problem is linear: the shear traction is V_imp times the response to
# a unit impact, |T_s|(x1, t) = V_imp τ(x1, t).  During stick the
# Prakash–Clifton states do not move (θ̇1 = θ̇2 = 0 without slip), so the
# strength stays g(θ0(t)) Σ0 with θ0 aging as θ0(0) + B t, whatever T_n does.
# Sliding therefore starts at the first t where
#
#     V_imp · max_x1 τ(x1, t) = g(θ0(t)) Σ0,
#
# so each initiation time the paper states fixes the impact velocity it needs:
# V_req = g Σ0 / max τ.  This script computes τ with the elastic ("stuck")
# interface on the reference mesh, for the two interface stiffnesses the
# paper uses, and prints V_req / V_paper for Cases I, II, IV and V.  The same
# factor for all cases would mean a uniform rescaling of the loading could
# reconcile them; very different factors mean it cannot.  (The direction of
# the edge velocity does not matter here: a pull flips the sign of T_s only.)
#
# Run: `mpirun -n 2 .venv/bin/python demos/initiation_bound.py [--preset reference]`
# Writes `demos/output/initiation_bound/initiation_bound.json` and `.png`.

import argparse
import json
import logging
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fricfem import config, friction, run, solver
from fricfem.friction import povirk_needleman as pn

logging.getLogger().setLevel(logging.WARNING)
ap = argparse.ArgumentParser()
ap.add_argument("--preset", default="reference")
ap.add_argument("--out", default="demos/output/initiation_bound")
a = ap.parse_args()
comm = MPI.COMM_WORLD

# Paper: (Σ0 [Pa], V_imp [m/s], initiation time [s], C_n, C_s factor).
CASES = {"case1": (6e6, 2.0, 16e-6, 1.0), "case2": (30e6, 2.0, 28e-6, 1.0),
         "case4": (0.9e6, 10.0, 14e-6, 0.1), "case5": (40e6, 2.0, 31e-6, 1.0)}

# ## τ(t) = max over the interface of |T_s| per m/s of impact velocity
tau = {}
for k in sorted({c[3] for c in CASES.values()}):
    scene = config.load("case1", ["loading.v_imp=1.0", "friction.law='stuck'", "friction.params={}",
                                  f"interface.Cn={3e11 * k}", f"interface.Cs={1e11 * k}",
                                  f"mesh.preset='{a.preset}'"])
    _, model = run.build_model(scene, comm)
    state = solver.State(model)
    rows = []
    for st, _ in solver.evolve(model, state, 45e-6):
        if st.n % 5 == 0:
            rows.append((st.t, comm.allreduce(float(np.abs(model.interface.points.Ts).max(initial=0.0)),
                                              op=MPI.MAX)))
    tau[k] = np.array(rows)

# ## Strength during stick and the required impact velocity
law = friction.get_law("povirk_needleman")
params = friction.pack(law, friction.validate(law, {}))
theta0_init = params[pn.THETA0_INIT] * params[pn.L0] / params[pn.V1]


def strength_factor(t):
    return pn.strength_factor(params, theta0_init + params[pn.B] * t)


result = {}
for name, (sigma0, v, t_init, k) in CASES.items():
    t, ts = tau[k][:, 0], tau[k][:, 1]
    per_v = float(np.interp(t_init, t, ts))
    v_req = strength_factor(t_init) * sigma0 / per_v
    result[name] = {"sigma0_Pa": sigma0, "v_imp_paper_m_s": v, "t_init_paper_s": t_init,
                    "stiffness_factor": k, "max_Ts_per_m_s_Pa": per_v,
                    "strength_Pa": strength_factor(t_init) * sigma0, "v_required_m_s": v_req,
                    "factor": v_req / v}
if comm.rank == 0:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "initiation_bound.json").write_text(json.dumps(result, indent=2))
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, arr in tau.items():
        ax.plot(arr[:, 0] * 1e6, arr[:, 1] / 1e6, label=f"max |T_s| per m/s, C × {k:g}")
    for name, r in result.items():
        ax.plot(r["t_init_paper_s"] * 1e6, r["strength_Pa"] / r["v_imp_paper_m_s"] / 1e6, "o")
        ax.annotate(f"{name}: ×{r['factor']:.2f}", (r["t_init_paper_s"] * 1e6, r["strength_Pa"] / r["v_imp_paper_m_s"] / 1e6),
                    textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xlabel("t [µs]")
    ax.set_ylabel("MPa per (m/s)")
    ax.set_title("strength / V_paper at the paper's initiation times (dots)\nvs the shear traction a unit impact gives")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "initiation_bound.png", dpi=110)
    for name, r in result.items():
        print(f"{name}: starts at {r['t_init_paper_s'] * 1e6:.0f} µs in the paper; a unit impact gives "
              f"{r['max_Ts_per_m_s_Pa'] / 1e6:.3f} MPa per m/s then; strength {r['strength_Pa'] / 1e6:.2f} MPa "
              f"-> V_imp {r['v_required_m_s']:.2f} m/s = {r['factor']:.2f} × the paper's")
