"""fricfem's bulk discretisation against a manufactured solution: measured L2
orders in the cell size and the time step, plane stress and plane strain.

    mpirun -n 2 .venv/bin/python benchmarks/mms.py            # the full ladders, ~2 min
    mpirun -n 2 .venv/bin/python benchmarks/mms.py --quick    # shorter ladders

Writes ``benchmarks/results/mms.{json,md,png}`` (``--out`` changes the
directory) and prints the tables.  ``tests/test_mms.py`` runs short ladders
of the same code; docs/verification_bulk.md states the method and the results.

What is verified is fricfem's own discretisation, through its own pieces: the
two-plate mesh (:func:`fricfem.model.mesh.build`, crossed triangles, uniform:
grading 1, the fine region the whole plate, n × n cells a plate of 12 mm × 8
mm, so dx/dy = 1.5 as in the reference mesh), its numbering, stiffness and
row-sum lumped mass (:mod:`fricfem.model.assembly`, plane stress or strain
through :class:`fricfem.model.material.Material`), its stable step
(:func:`fricfem.model.assembly.max_eigenvalue`) and its production step, the
fused one-pass sweep (:class:`fricfem.step.fused.FusedBulk`).  No interface:
the two plates are two independent bodies whose every edge, the interface
faces included, carries the manufactured boundary condition.  The step has no
body force, but it is linear, so the load enters after it:

    v^{n+½} = v^{n−½} − dt M⁻¹ (K u^n − f^n),  u^{n+1} = u^n + dt v^{n+½}
            = FusedBulk(u^n, v^{n−½})  +  (dt M⁻¹ f^n,  dt² M⁻¹ f^n)

(``--stepper plain`` takes the step as ``K.mult`` and numpy instead; the two
agree to round-off, which the tests check.)

The manufactured displacement is u*(x, t) = Σ_k g_k(t) U_k(x), two terms with
g_k = cos(ω_k t + φ_k) and U_k products of sines and cosines in both
components (:func:`spatial_modes`), non-zero on every edge.  As g_k'' =
−ω_k² g_k, the body force b = ρ ü* − ∇·σ(u*) = Σ_k g_k(t) B_k(x) with
B_k = −ρ ω_k² U_k − ∇·σ(U_k) (ufl differentiates U_k), and the load vector is
f^n = Σ_k g_k(t^n) F_k, F_k = ∫ B_k·N dx + ∫_∂Ω σ(U_k) n·N ds assembled once
(quadrature degree 8): a step adds two axpys.  Boundary conditions (``--bc``):

* ``traction``: the exact traction σ(u*) n on every edge (the ds term of
  F_k), every boundary row free, as fricfem's outer edges (which carry zero
  traction) and its interface rows (which carry the interface forces);
* ``dirichlet``: u* prescribed at every boundary dof the way fricfem
  prescribes its struck edge: u^{n+1} = u*(t^{n+1}) and
  v^{n+½} = (u*(t^{n+1}) − u*(t^n))/dt;
* ``struck``: u1 prescribed so on the edge x1 = 0 of both plates, as fricfem's
  struck edge; u2 there and the other edges under the exact traction.

Start: ``projected`` (the default) u^0 = P u*(0) and, as central
differences start, v^{−½} = P v*(0) − (dt/2) M⁻¹(f^0 − K u^0), P the elliptic
projection (K + κM) P w = a(w, N) +
κ M I_h w at the free dofs, P w = I_h w at the prescribed ones (κ = ω_1², a
shift that makes the traction problem non-singular; MUMPS).  ``interpolated``:
the nodal interpolant I_h in place of P.  A crossed-triangle centre node is joined
only to the four corners of its quadrilateral, so its row of K can form only
the isotropic ∂11 + ∂22 of second derivatives (and ∂12), not the elasticity
operator: the nodal equations are off by O(1) at centre nodes and, with the
opposite sign, at corners (zero mass-weighted mean).  Galerkin absorbs this
(u converges at h²), but I_h u*(0) then sits O(h²) off the discrete solution
in an oscillation between the two node families, O(h) in energy, which
central differences carry undamped: the velocity error of an interpolated
start is O(h) asymptotically.  ``naive``: projected, but v^{−½} = P v*(0),
an O(dt) error in the start that costs the second order.

Errors: ||u_h − u*||_L2 at t = T/4, T/2, 3T/4, T over the largest ||u*||_L2 of
those times, and the same for the velocity at the half steps before them
(v^{n+½} against v*(t^{n+1} − dt/2)), quadrature degree 6.  The h ladder keeps dt/h fixed (``--safety`` of the
coarsest mesh's stable step, 0.9 as fricfem's default; every level then takes
the same fraction of its own stable step, as the stable step scales with h);
orders from consecutive levels.  The dt ladder runs on one mesh
(``--dt-cells``) from 0.9 of the stable step down by halves; its error against
u* levels off at the spatial error, so the temporal error is also measured
alone, against a run with a step 8 times smaller than the smallest one on the
same mesh (the semi-discrete solution, whose own temporal error then biases the
last order by < 0.01).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from fricfem import compat
from fricfem.model import assembly
from fricfem.model import mesh as mesh_mod
from fricfem.model.build import Impact
from fricfem.model.loading import ImpactPulse
from fricfem.model.material import Material
from fricfem.model.numbering import numbering
from fricfem.step.fused import FusedBulk, block_rows
from fricfem.step.state import State

#: Each plate [m]: 12 mm × 8 mm, so that n × n cells have the reference mesh's aspect dx/dy = 1.5.
LENGTH, HEIGHT = 12e-3, 8e-3
#: Amplitude of the manufactured displacement [m] (the problem is linear: errors are relative).
AMP = 1e-6
#: g_k(t) = cos(ω_k t + φ_k): periods 6 µs and 3.5 µs, against the plates' slowest
#: elastic periods of ~10 µs, so that inertia and stiffness both weigh in b.
OMEGA = (2.0 * math.pi / 6e-6, 2.0 * math.pi / 3.5e-6)
PHASE = (0.3, -1.1)
#: End time [s] and the checkpoints (fractions of it) where errors are measured.
T_END = 6e-6
CHECKPOINTS = (0.25, 0.5, 0.75, 1.0)
QUAD = {"quadrature_degree": 8}  # the load vectors and projections (assembled once)
QUAD_ERR = {"quadrature_degree": 6}  # the errors (every checkpoint)
BCS = ("traction", "dirichlet", "struck")
STARTS = ("projected", "interpolated", "naive")
PLANES = ("stress", "strain")


def spatial_modes(x) -> list:
    """U_k(x) (ufl, of the SpatialCoordinate ``x``; x2 from −HEIGHT to HEIGHT):
    non-polynomial in both components, non-zero on every edge, every component
    depends on x1 and x2."""
    xi, eta = x[0] / LENGTH, x[1] / HEIGHT
    pi, sin, cos = math.pi, ufl.sin, ufl.cos
    u1 = ufl.as_vector((sin(1.3 * pi * xi + 0.4) * cos(0.9 * pi * eta + 0.2),
                        0.6 * cos(1.1 * pi * xi - 0.3) * sin(1.2 * pi * eta + 0.5)))
    u2 = ufl.as_vector((0.5 * cos(0.8 * pi * xi + 0.7) * sin(1.4 * pi * eta - 0.6),
                        sin(1.2 * pi * xi - 0.2) * cos(0.7 * pi * eta + 0.9)))
    return [AMP * u1, AMP * u2]


def g(t: float) -> np.ndarray:
    """g_k(t)."""
    return np.cos(np.multiply(OMEGA, t) + PHASE)


def dg(t: float) -> np.ndarray:
    """g_k'(t)."""
    return -np.multiply(OMEGA, np.sin(np.multiply(OMEGA, t) + PHASE))


def plate_spec(n: int) -> mesh_mod.MeshSpec:
    """Two uniform plates of n × n quadrilaterals each (4 n² crossed triangles a plate)."""
    return mesh_mod.MeshSpec(length=LENGTH, height=HEIGHT, dx=LENGTH / n, dy=HEIGHT / n, fine_x0=0.0,
                             fine_x1=LENGTH, fine_height=HEIGHT, impact_b=HEIGHT, grading=1.0,
                             max_size=max(LENGTH, HEIGHT))


class _NoInterface:
    """Stands for the interface in :func:`fricfem.model.assembly.max_eigenvalue` (no springs)."""

    @staticmethod
    def add_spring_action(x, y):
        pass


class Plates:
    """Everything assembled once for one mesh and one plane state: fricfem's K,
    lumped mass, λmax and block rows; the load vectors F_k, the nodal values
    of U_k, the prescribed dofs and projected starts of each boundary
    treatment, the error forms.  Collective."""

    def __init__(self, n: int, plane: str, comm):
        self.n, self.plane, self.comm = n, plane, comm
        self.material = Material(plane=plane)
        pm = mesh_mod.build(plate_spec(n), comm)
        self.msh = msh = pm.mesh
        self.V = V = assembly.function_space(msh)
        # fricfem's operators, as fricfem.model.build.build makes them
        self.num = assembly_num = numbering(pm, V)
        rows = assembly.canonical_rows(assembly_num, self.material)
        self.K = assembly.petsc_matrix(assembly_num, rows, comm)
        self.rows = block_rows(assembly_num, rows)
        self.mass = assembly.canonical_mass(assembly_num, self.material.rho)
        self.lam_max = assembly.max_eigenvalue(self.K, self.mass, _NoInterface(), assembly_num)
        self.dt_crit = 2.0 / math.sqrt(self.lam_max)
        self.n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self.dofs = 2 * V.dofmap.index_map.size_global

        x = ufl.SpatialCoordinate(msh)
        self.modes = modes = spatial_modes(x)
        mu, lmbda, rho = self.material.mu, self.material.lmbda, self.material.rho

        def sigma(w):
            eps = ufl.sym(ufl.grad(w))
            return 2.0 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(2)

        w = ufl.TestFunction(V)
        nrm = ufl.FacetNormal(msh)
        dx, ds = ufl.dx(metadata=QUAD), ufl.ds(metadata=QUAD)
        F, S, U = [], [], []
        for om, Uk in zip(OMEGA, modes):
            body = -rho * om**2 * Uk - ufl.div(sigma(Uk))  # B_k: b = Σ g_k B_k
            F.append(self._assemble(ufl.inner(body, w) * dx + ufl.inner(sigma(Uk) * nrm, w) * ds))
            S.append(self._assemble(ufl.inner(sigma(Uk), ufl.sym(ufl.grad(w))) * dx))  # a(U_k, N)
            fn = fem.Function(V)
            fn.interpolate(fem.Expression(Uk, compat.interpolation_points(V)))
            U.append(fn.x.array[: self.n_owned].copy())
        self.F, self.S, self.U = np.array(F), np.array(S), np.array(U)  # [k, owned dofs]

        # errors: ||w − Σ c_k U_k||² and ||Σ c_k U_k||², w a P1 field, c_k constants
        self.w = fem.Function(V)
        self.c = [fem.Constant(msh, PETSc.ScalarType(0.0)) for _ in modes]
        exact = sum((c * Uk for c, Uk in zip(self.c[1:], modes[1:])), self.c[0] * modes[0])
        dx = ufl.dx(metadata=QUAD_ERR)
        self._err = fem.form(ufl.inner(self.w - exact, self.w - exact) * dx)
        self._ref = fem.form(ufl.inner(exact, exact) * dx)
        self._prescribed, self._projected = {}, {}

    def _assemble(self, form) -> np.ndarray:
        vec = fem_petsc.assemble_vector(fem.form(form))
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return vec.array[: self.n_owned].copy()

    def prescribed(self, bc: str) -> np.ndarray:
        """Owned local dofs where u* is prescribed for the boundary treatment ``bc``."""
        if bc not in self._prescribed:
            import dolfinx.mesh as dmesh

            fdim = self.msh.topology.dim - 1
            if bc == "traction":
                dofs = np.zeros(0, dtype=np.int64)
            else:
                if bc == "dirichlet":  # every edge of both plates, the interface faces included
                    facets = dmesh.locate_entities_boundary(self.msh, fdim, lambda x: np.full(x.shape[1], True))
                    comps = (0, 1)
                elif bc == "struck":
                    facets = dmesh.locate_entities_boundary(self.msh, fdim, lambda x: np.isclose(x[0], 0.0))
                    comps = (0,)
                else:
                    raise ValueError(f"mms: unknown boundary treatment {bc!r}; allowed: {', '.join(BCS)}")
                dofs = np.concatenate([fem.locate_dofs_topological(self.V.sub(c), fdim, facets) for c in comps])
                dofs = np.unique(dofs[dofs < self.n_owned]).astype(np.int64)
            self._prescribed[bc] = dofs
        return self._prescribed[bc]

    def projected(self, bc: str) -> np.ndarray:
        """P U_k [k, owned dofs], the elliptic projections that start the integration:
        (K + κ M) P U_k = a(U_k, N) + κ M I_h U_k at the free dofs, P U_k = I_h U_k
        at the prescribed ones, κ = ω_1² (MUMPS)."""
        if bc not in self._projected:
            kappa = OMEGA[0] ** 2
            A = self.K.duplicate(copy=True)
            x, b = A.createVecRight(), A.createVecRight()
            x.array[:] = kappa * self.mass
            A.setDiagonal(x, addv=PETSc.InsertMode.ADD_VALUES)
            fixed = self.prescribed(bc)
            free = np.ones(self.n_owned, dtype=bool)
            free[fixed] = False
            rhs = []
            for Sk, Uk in zip(self.S, self.U):  # the prescribed values' columns go to the right-hand side
                x.array[:] = 0.0
                x.array[fixed] = Uk[fixed]
                A.mult(x, b)
                rhs.append(np.where(free, Sk + kappa * self.mass * Uk - b.array_r, Uk))
            A.zeroRowsColumns((A.getOwnershipRange()[0] + fixed).astype(PETSc.IntType), 1.0)
            ksp = PETSc.KSP().create(self.comm)
            ksp.setOperators(A)
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            ksp.getPC().setFactorSolverType("mumps")
            out = []
            for r in rhs:  # one factorisation, a solve per mode
                b.array[:] = r
                ksp.solve(b, x)
                out.append(x.array.copy())
            ksp.destroy()
            A.destroy()
            self._projected[bc] = np.array(out)
        return self._projected[bc]

    def start(self, bc: str, start: str, dt: float) -> tuple:
        """(u^0, v^{−½}) at the owned dofs for the start ``start`` (module docstring):
        u^0 = W u*(0), v^{−½} = W v*(0) − (dt/2) M⁻¹(f^0 − K u^0), W = P or I_h;
        ``naive``: v^{−½} = P v*(0)."""
        if start not in STARTS:
            raise ValueError(f"mms: unknown start {start!r}; allowed: {', '.join(STARTS)}")
        W = self.U if start == "interpolated" else self.projected(bc)
        u0, v0 = g(0.0) @ W, dg(0.0) @ W
        if start == "naive":
            return u0, v0
        x, ku = self.K.createVecRight(), self.K.createVecRight()
        x.array[:] = u0
        self.K.mult(x, ku)
        return u0, v0 - 0.5 * dt * (g(0.0) @ self.F - ku.array_r) / self.mass

    def start_mismatch(self, bc: str) -> dict:
        """How far the interpolated start lies from the projected one, (I_h − P) u*(0),
        relative to P u*(0): in the lumped-mass (L2) norm and in the energy norm."""
        W = self.projected(bc)
        p0, d = g(0.0) @ W, g(0.0) @ (self.U - W)
        x, y = self.K.createVecRight(), self.K.createVecRight()
        loc = []
        for z in (d, p0):
            x.array[:] = z
            self.K.mult(x, y)
            loc += [z @ (self.mass * z), z @ y.array_r]
        dm, de, pm, pe = self.comm.allreduce(np.array(loc), op=MPI.SUM)
        return {"l2": math.sqrt(dm / pm), "energy": math.sqrt(de / pe)}

    def nodal_residual(self) -> dict:
        """The nodal equations' residual for the interpolant at t = 0,
        τ = M⁻¹(f^0 − K I_h u*(0)) − I_h ü*(0), by node family: its largest |τ|
        at interior corner nodes, interior centre nodes and boundary nodes over
        max |ü*|, and its mass-weighted mean over the interior over that of |τ|."""
        x = self.V.tabulate_dof_coordinates()[: self.n_owned // 2, :2]
        dx, dy = LENGTH / self.n, HEIGHT / self.n
        corner = np.repeat((np.abs(x[:, 0] / dx - np.round(x[:, 0] / dx)) < 1e-6)
                           & (np.abs(x[:, 1] / dy - np.round(x[:, 1] / dy)) < 1e-6), 2)
        boundary = np.zeros(self.n_owned, dtype=bool)
        boundary[self.prescribed("dirichlet")] = True
        u, ku = self.K.createVecRight(), self.K.createVecRight()
        u.array[:] = g(0.0) @ self.U
        self.K.mult(u, ku)
        acc = (-np.square(OMEGA) * g(0.0)) @ self.U
        tau = (g(0.0) @ self.F - ku.array_r) / self.mass - acc
        comm = self.comm

        def largest(mask):
            return comm.allreduce(float(np.abs(tau[mask]).max(initial=0.0)), op=MPI.MAX)

        scale = comm.allreduce(float(np.abs(acc).max(initial=0.0)), op=MPI.MAX)
        inner = ~boundary
        mean = comm.allreduce(np.array([(self.mass * tau)[inner].sum(), (self.mass * np.abs(tau))[inner].sum()]),
                              op=MPI.SUM)
        return {"corner": largest(corner & inner) / scale, "centre": largest(~corner & inner) / scale,
                "boundary": largest(boundary) / scale, "mass_weighted_mean": mean[0] / mean[1]}

    def error(self, values: np.ndarray, coef) -> tuple:
        """(||w − Σ coef_k U_k||, ||Σ coef_k U_k||) in L2, w the P1 field of the owned dof values ``values``."""
        self.w.x.array[: self.n_owned] = values
        self.w.x.scatter_forward()
        for c, val in zip(self.c, coef):
            c.value = val
        loc = np.array([fem.assemble_scalar(self._err), fem.assemble_scalar(self._ref)])
        return tuple(math.sqrt(x) for x in self.comm.allreduce(loc, op=MPI.SUM))


class _Fused:
    """fricfem's production step (FusedBulk: no interface, no struck edge, every row awake)."""

    def __init__(self, plates: Plates, dt: float):
        impact = Impact(np.zeros(0, dtype=np.int32), np.zeros(0), ImpactPulse())
        bulk = FusedBulk(plates.rows, dt / plates.mass, dt, None, impact, plates.K.createVecRight(), plates.comm)
        # fricfem's State needs only these four of a Model
        self.state = State(SimpleNamespace(K=plates.K, impact=impact, bulk=bulk, interface=None), skip_quiet=False)
        self.bulk = bulk

    def arrays(self) -> tuple:
        return self.state.u.array, self.state.v.array

    def advance(self, t: float) -> None:
        """u ← u^{n+1}, v ← v^{n+½}, both without the load."""
        st = self.state
        st.t = t
        self.bulk.advance(st)
        st.u, st.u_next = st.u_next, st.u


class _Plain:
    """The same step as ``K.mult`` and numpy."""

    def __init__(self, plates: Plates, dt: float):
        self.K, self.dt, self.minv = plates.K, dt, 1.0 / plates.mass
        self.u, self.v, self.ku = (plates.K.createVecRight() for _ in range(3))

    def arrays(self) -> tuple:
        return self.u.array, self.v.array

    def advance(self, t: float) -> None:
        self.K.mult(self.u, self.ku)
        v = self.v.array
        v -= self.dt * self.minv * self.ku.array_r
        self.u.array[:] += self.dt * v


STEPPERS = {"fused": _Fused, "plain": _Plain}


def solve(plates: Plates, steps: int, bc: str = "traction", start: str = "projected", stepper: str = "fused",
          t_end: float = T_END, keep: bool = False) -> dict:
    """Integrate the manufactured problem over ``steps`` steps of ``t_end / steps``;
    the relative L2 errors of u and v at the checkpoints.  Collective.
    ``keep``: also return the owned dof values of u at the end (``"u_end"``)."""
    dt = t_end / steps
    marks = {round(f * steps) for f in CHECKPOINTS}
    if any(abs(round(f * steps) - f * steps) > 1e-9 for f in CHECKPOINTS):
        raise ValueError(f"mms: {steps} steps do not land on the checkpoints {CHECKPOINTS}")
    step = STEPPERS[stepper](plates, dt)
    u, v = step.arrays()
    u[:], v[:] = plates.start(bc, start, dt)
    fixed = plates.prescribed(bc)
    Ufix = plates.U[:, fixed]
    load = dt / plates.mass * plates.F  # dt M⁻¹ F_k [k, owned dofs]
    err_u, err_v, times = [], [], []
    t0 = time.perf_counter()
    for n in range(steps):
        t = n * dt
        step.advance(t)
        u, v = step.arrays()  # the fused step swaps its buffers
        f = g(t) @ load
        v += f
        u += dt * f
        if len(fixed):  # as fricfem's struck edge: exact u^{n+1}, the half-step velocity from it
            u_new, u_old = g(t + dt) @ Ufix, g(t) @ Ufix
            u[fixed] = u_new
            v[fixed] = (u_new - u_old) / dt
        if n + 1 in marks:
            tc = (n + 1) * dt
            times.append(tc)
            err_u.append(plates.error(u, g(tc)))
            err_v.append(plates.error(v, dg(tc - 0.5 * dt)))
    seconds = plates.comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    # relative to the largest norm of the exact field over the checkpoints
    err_u = [e / max(n for _, n in err_u) for e, _ in err_u]
    err_v = [e / max(n for _, n in err_v) for e, _ in err_v]
    out = {"steps": steps, "dt": dt, "dt_over_crit": dt / plates.dt_crit, "times": times, "err_u": err_u,
           "err_v": err_v, "err_u_end": err_u[-1], "err_v_end": err_v[-1], "err_u_max": max(err_u),
           "err_v_max": max(err_v), "loop_s": seconds}
    if keep:
        out["u_end"] = u.copy()
    return out


def orders(sizes, errs) -> list:
    """Observed orders between consecutive levels: log(e_i/e_{i+1}) / log(s_i/s_{i+1})."""
    return [math.log(e0 / e1) / math.log(s0 / s1) if e0 > 0 and e1 > 0 else None
            for s0, s1, e0, e1 in zip(sizes, sizes[1:], errs, errs[1:])]


def steps_for(plates: Plates, safety: float, t_end: float = T_END) -> int:
    """The fewest steps, a multiple of 4 (the checkpoints), with dt ≤ safety · dt_crit."""
    return 4 * math.ceil(t_end / (4.0 * safety * plates.dt_crit))


def get_plates(built: dict, n: int, plane: str, comm) -> Plates:
    """The :class:`Plates` of n × n cells and ``plane``, built once into ``built``."""
    if (n, plane) not in built:
        built[n, plane] = Plates(n, plane, comm)
    return built[n, plane]


def h_ladder(cells, plane: str, comm, bc: str = "traction", start: str = "projected", stepper: str = "fused",
             safety: float = 0.9, built: dict | None = None) -> dict:
    """Errors and orders on uniform plates of n × n cells (n in ``cells``, doubling),
    dt/h fixed at ``safety`` of the coarsest mesh's stable step.  Collective."""
    built = {} if built is None else built
    base = steps_for(get_plates(built, cells[0], plane, comm), safety)
    rows = []
    for n in cells:
        p = get_plates(built, n, plane, comm)
        res = solve(p, base * n // cells[0], bc, start, stepper)
        res.update(cells=n, h=LENGTH / n, dofs=p.dofs, dt_crit=p.dt_crit)
        if start == "interpolated":
            res["start_mismatch"] = p.start_mismatch(bc)
            res["nodal_residual"] = p.nodal_residual()
        rows.append(res)
    h = [r["h"] for r in rows]
    lad = {"kind": "h", "plane": plane, "bc": bc, "start": start, "stepper": stepper, "safety": safety,
           "rows": rows}
    for key in ("u_end", "u_max", "v_end", "v_max"):
        lad[f"order_{key}"] = orders(h, [r[f"err_{key}"] for r in rows])
    return lad


def dt_ladder(p: Plates, safeties, bc: str = "traction", start: str = "projected", stepper: str = "fused",
              ref_factor: int = 8) -> dict:
    """Errors against u* and, the temporal error alone, against a run with a
    ``ref_factor`` times smaller step than the smallest one, on one mesh; dt
    from ``safeties[0]`` of the stable step down (``safeties`` halving).  Collective."""
    base = steps_for(p, safeties[0])
    steps = [base * round(safeties[0] / s) for s in safeties]
    ref = solve(p, steps[-1] * ref_factor, bc, start, stepper, keep=True)
    u_ref = ref.pop("u_end")
    rows = []
    for s in steps:
        res = solve(p, s, bc, start, stepper, keep=True)
        diff = res.pop("u_end") - u_ref
        num, den = p.comm.allreduce(np.array([diff @ (p.mass * diff), u_ref @ (p.mass * u_ref)]), op=MPI.SUM)
        res["err_time"] = math.sqrt(num / den)  # lumped-mass (discrete L2) norm of u_dt − u_ref, relative
        rows.append(res)
    dts = [r["dt"] for r in rows]
    return {"kind": "dt", "plane": p.plane, "bc": bc, "start": start, "stepper": stepper, "cells": p.n,
            "h": LENGTH / p.n, "dofs": p.dofs, "dt_crit": p.dt_crit, "ref_steps": steps[-1] * ref_factor,
            "ref": ref, "rows": rows,
            "order_time": orders(dts, [r["err_time"] for r in rows]),
            "order_u_end": orders(dts, [r["err_u_end"] for r in rows])}


# --- report --------------------------------------------------------------------------------------------------

def _o(x) -> str:
    return "—" if x is None else f"{x:.2f}"


def label(lad: dict) -> str:
    return f"plane {lad['plane']}, {lad['bc']}, {lad['start']} start"


def summary_table(doc: dict) -> list:
    lines = ["| ladder | finest | L2(u) end | L2(v) end | orders u (end) | orders v (end) |",
             "|---|---|---|---|---|---|"]
    for lad in doc["h_ladders"]:
        r = lad["rows"][-1]
        lines.append(f"| h: {label(lad)} | {r['cells']}×{r['cells']} | {r['err_u_end']:.2e} | {r['err_v_end']:.2e} | "
                     f"{', '.join(map(_o, lad['order_u_end']))} | {', '.join(map(_o, lad['order_v_end']))} |")
    for lad in doc["dt_ladders"]:
        r = lad["rows"][-1]
        lines.append(f"| dt on {lad['cells']}×{lad['cells']}: {label(lad)} (temporal error) | "
                     f"{r['dt'] * 1e9:.3g} ns | {r['err_time']:.2e} | | {', '.join(map(_o, lad['order_time']))} | |")
    return lines


def h_table(lad: dict) -> list:
    lines = [f"### h ladder: {label(lad)}; dt = {lad['safety']} of the coarsest stable step × h/h0", "",
             ("| cells a plate | h [mm] | dofs | steps | dt [ns] | dt/dt_crit | L2(u) end | L2(u) max | L2(v) end | "
              "L2(v) max | order u end | order u max | order v end | order v max |"),
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for i, r in enumerate(lad["rows"]):
        o = [""] * 4 if i == 0 else [_o(lad[f"order_{k}"][i - 1]) for k in ("u_end", "u_max", "v_end", "v_max")]
        lines.append(f"| {r['cells']}×{r['cells']} | {r['h'] * 1e3:.4g} | {r['dofs']} | {r['steps']} | "
                     f"{r['dt'] * 1e9:.4g} | {r['dt_over_crit']:.3f} | {r['err_u_end']:.3e} | {r['err_u_max']:.3e} | "
                     f"{r['err_v_end']:.3e} | {r['err_v_max']:.3e} | {' | '.join(o)} |")
    if "start_mismatch" in lad["rows"][0]:
        mm = [r["start_mismatch"] for r in lad["rows"]]
        lines += ["", "(I_h − P) u*(0) relative to P u*(0), per level: L2 "
                  + ", ".join(f"{m['l2']:.2e}" for m in mm) + "; energy norm "
                  + ", ".join(f"{m['energy']:.2e}" for m in mm) + " (orders "
                  + ", ".join(_o(o) for o in orders([r["h"] for r in lad["rows"]], [m["energy"] for m in mm]))
                  + ").",
                  "", "Why: the nodal residual τ = M⁻¹(f⁰ − K I_h u*(0)) − I_h ü*(0) over max |ü*|, per level, "
                  "largest at interior corner / interior centre / boundary nodes (mass-weighted interior mean "
                  "over that of |τ|): "
                  + "; ".join(f"{r['nodal_residual']['corner']:.3f} / {r['nodal_residual']['centre']:.3f} / "
                              f"{r['nodal_residual']['boundary']:.3f} ({r['nodal_residual']['mass_weighted_mean']:.1e})"
                              for r in lad["rows"]) + "."]
    return lines


def dt_table(lad: dict) -> list:
    lines = [(f"### dt ladder: {label(lad)}; {lad['cells']}×{lad['cells']} cells a plate "
              f"(h = {lad['h'] * 1e3:.4g} mm, {lad['dofs']} dofs); reference {lad['ref_steps']} steps (its L2(u) "
              f"error against u*: {lad['ref']['err_u_end']:.3e})"), "",
             ("| steps | dt [ns] | dt/dt_crit | temporal error of u (vs reference) | order | L2(u) vs u* | order | "
              "L2(v) vs v* |"),
             "|---|---|---|---|---|---|---|---|"]
    for i, r in enumerate(lad["rows"]):
        ot = "" if i == 0 else _o(lad["order_time"][i - 1])
        ou = "" if i == 0 else _o(lad["order_u_end"][i - 1])
        lines.append(f"| {r['steps']} | {r['dt'] * 1e9:.4g} | {r['dt_over_crit']:.3f} | {r['err_time']:.3e} | {ot} | "
                     f"{r['err_u_end']:.3e} | {ou} | {r['err_v_end']:.3e} |")
    return lines


def _guide(ax, x, y0, slope, text):
    x = np.asarray(x)
    ax.loglog(x, 0.5 * y0 * (x / x[0]) ** slope, "k:", lw=1)
    ax.annotate(text, (x[-1], 0.5 * y0 * (x[-1] / x[0]) ** slope), fontsize=7, ha="left", va="top")


def plot(doc: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    marker = {"traction": "o", "dirichlet": "s", "struck": "^"}
    line = {"stress": "-", "strain": "--"}
    main = [lad for lad in doc["h_ladders"] if lad["start"] == "projected"]
    for ax, key, title in ((axes[0], "err_u_end", "displacement"), (axes[1], "err_v_end", "velocity (half steps)")):
        for lad in main:
            h = [r["h"] * 1e3 for r in lad["rows"]]
            ax.loglog(h, [r[key] for r in lad["rows"]], line[lad["plane"]] + marker[lad["bc"]], ms=4,
                      label=f"{lad['plane']}, {lad['bc']}")
        for lad in doc["h_ladders"]:
            if lad["start"] != "projected":
                h = [r["h"] * 1e3 for r in lad["rows"]]
                ax.loglog(h, [r[key] for r in lad["rows"]], ":x", ms=5,
                          label=f"{lad['plane']}, {lad['bc']}, {lad['start']} start")
        h = [r["h"] * 1e3 for r in main[0]["rows"]]
        _guide(ax, h, main[0]["rows"][0][key], 2, "slope 2")
        _guide(ax, h, main[0]["rows"][0][key], 1, "slope 1")
        ax.set_xlabel("cell size along x1, h [mm] (dt ∝ h)")
        ax.set_ylabel("relative L2 error at T")
        ax.set_title(f"h ladder, {title}")
        ax.legend(fontsize=6)
    ax = axes[2]
    for lad in doc["dt_ladders"]:
        dt = [r["dt"] * 1e9 for r in lad["rows"]]
        ax.loglog(dt, [r["err_time"] for r in lad["rows"]], line[lad["plane"]] + "o", ms=4,
                  label=f"u − u(dt/{lad['ref_steps'] // lad['rows'][-1]['steps']} ref.): {lad['plane']}")
        ax.loglog(dt, [r["err_u_end"] for r in lad["rows"]], line[lad["plane"]] + "s", ms=4, alpha=0.5,
                  label=f"u − u*: {lad['plane']}")
    lad = doc["dt_ladders"][0]
    dt = [r["dt"] * 1e9 for r in lad["rows"]][::-1]
    _guide(ax, dt, lad["rows"][-1]["err_time"], 2, "slope 2")
    ax.set_xlabel("time step dt [ns]")
    ax.set_ylabel("relative L2 error of u at T")
    ax.set_title(f"dt ladder on {lad['cells']}×{lad['cells']} cells a plate")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[8, 16, 32, 64, 128],
                    help="h ladder: n × n cells a plate at each level (doubling)")
    ap.add_argument("--dt-cells", type=int, default=64, help="dt ladder: n × n cells a plate")
    ap.add_argument("--safeties", type=float, nargs="+", default=[0.9, 0.45, 0.225, 0.1125, 0.05625],
                    help="dt ladder: fractions of the stable step (halving)")
    ap.add_argument("--safety", type=float, default=0.9, help="h ladder: fraction of the stable step")
    ap.add_argument("--bc", nargs="+", default=list(BCS), choices=BCS)
    ap.add_argument("--stepper", default="fused", choices=tuple(STEPPERS))
    ap.add_argument("--quick", action="store_true", help="cells 8…64, the dt ladder on 32 × 32")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results"))
    a = ap.parse_args(argv)
    if a.quick:
        a.cells, a.dt_cells = [8, 16, 32, 64], 32
    t_start = time.perf_counter()
    built: dict = {}
    doc = {"what": "fricfem's bulk discretisation against a manufactured solution (benchmarks/mms.py)",
           "ranks": comm.size, "host": platform.node(), "date": time.strftime("%Y-%m-%d %H:%M"),
           "stepper": a.stepper,
           "solution": {"plate_m": [LENGTH, HEIGHT], "amplitude_m": AMP, "omega_rad_s": list(OMEGA),
                        "phase": list(PHASE), "t_end_s": T_END, "checkpoints": list(CHECKPOINTS)},
           "h_ladders": [], "dt_ladders": []}
    for plane in PLANES:
        for bc in a.bc:
            doc["h_ladders"].append(h_ladder(a.cells, plane, comm, bc, "projected", a.stepper, a.safety, built))
    for start in ("interpolated", "naive"):  # what the start costs
        doc["h_ladders"].append(h_ladder(a.cells, "stress", comm, "traction", start, a.stepper, a.safety, built))
    for plane in PLANES:
        doc["dt_ladders"].append(dt_ladder(get_plates(built, a.dt_cells, plane, comm), a.safeties, "traction",
                                           "projected", a.stepper))
    doc["seconds"] = time.perf_counter() - t_start
    lines = ["# Bulk discretisation against a manufactured solution", "",
             (f"`mpirun -n {comm.size} .venv/bin/python benchmarks/mms.py` — {doc['seconds']:.0f} s on "
              f"{doc['host']}, {doc['date']}, {comm.size} rank(s), {a.stepper} step.  Two plates of "
              f"{LENGTH * 1e3:g} mm × {HEIGHT * 1e3:g} mm, n × n crossed-triangle cells each; L2 errors at "
              f"T = {T_END * 1e6:g} µs (end) and the largest of those at T/4, T/2, 3T/4, T (max), over the "
              "largest L2 norm of the exact field at those times; the velocity at the half step before each.  "
              "Method: docs/verification_bulk.md."), "",
             "## Summary (observed orders between consecutive levels)", ""]
    lines += summary_table(doc) + ["", "## Cell size (dt/h fixed)", ""]
    for lad in doc["h_ladders"]:
        lines += h_table(lad) + [""]
    lines += ["## Time step (one mesh)", ""]
    for lad in doc["dt_ladders"]:
        lines += dt_table(lad) + [""]
    text = "\n".join(lines)
    if comm.rank == 0:
        out = Path(a.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "mms.json").write_text(json.dumps(doc, indent=1))
        (out / "mms.md").write_text(text + "\n")
        plot(doc, out / "mms.png")
        print(text)
    return doc


if __name__ == "__main__":
    main()
