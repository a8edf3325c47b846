"""Explicit central-difference dynamics of the two plates with the frictional interface.

Discretisation (as in the paper): linear triangles, lumped mass, explicit
central differences (Newmark β = 0, γ = ½; Belytschko et al. 1976), stiffness
``K`` assembled once.  With ``f = K u − F_int(u)`` the step is

    v^{n+½} = v^{n−½} − dt M⁻¹ f(u^n)          (one sweep over the rows of K,
    u^{n+1} = u^n + dt v^{n+½}                   :mod:`fricfem.fused`)

and on the impacted edge u1 = U(t) = ∫V is prescribed (zero shear traction
there).  The stable step is ``dt = safety · 2/√λmax(M⁻¹(K + K_int))`` with
λmax from a power iteration that includes the interface springs.

Verbs: :func:`build` (assemble once), :func:`step` (and its two-pass reference
:func:`step_two_pass`), :func:`evolve` (generator).
"""

from __future__ import annotations

import math
import time
from typing import NamedTuple

import numba
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from . import fused as fused_mod
from . import interface as iface_mod
from .loading import ImpactPulse
from .material import Material
from .mesh import TAGS


class Impact(NamedTuple):
    """The load on the struck edge (:mod:`fricfem.loading`).

    dofs   int32[n]    owned local indices (into the PETSc arrays) of the x1 dofs
    mass   float64[n]  their lumped masses [kg/m]
    pulse  ImpactPulse
    force  float64[n]  for a traction load (``pulse.kind`` not "velocity"): the
                       nodal force is ``force · sign · V(t) − damp · v1``, with
                       force = A Z_f and damp = A Z_d [N·s/m², per m thickness],
                       A = ∫ N_i ds over the edge; zeros for a prescribed velocity
    damp   float64[n]
    """

    dofs: np.ndarray
    mass: np.ndarray
    pulse: ImpactPulse
    force: np.ndarray = np.zeros(0)
    damp: np.ndarray = np.zeros(0)


class Model(NamedTuple):
    """Everything assembled once for a run."""

    V: object  # dolfinx FunctionSpace (P1 vector)
    K: PETSc.Mat
    mass: np.ndarray  # lumped mass, owned dofs [kg/m]
    dt_minv: np.ndarray  # dt / mass
    impact: Impact
    interface: iface_mod.Interface
    material: Material
    dt: float  # time step [s]
    dt_crit: float  # 2/√λmax [s]
    comm: object
    fused: object = None  # fused_mod.FusedBulk: the one-pass step (set by build)


class State:
    """Dynamic state: u^n, v^{n−½} (PETSc vectors), t^n, n, and the running
    external work and the impacted dofs' previous displacement.

    A step computes the interface at t^n (from u^n) and then moves u to t^{n+1}:
    after it, ``t`` is t^{n+1} and ``t_interface`` is t^n, the time at which the
    interface tractions and slip rates hold."""

    def __init__(self, model: Model):
        self.u = model.K.createVecRight()
        self.v = model.K.createVecRight()
        self.f = model.K.createVecRight()
        self.u_next = model.K.createVecRight()  # u^{n+1} is written here, then swapped with u
        self.t = 0.0
        self.t_interface = 0.0  # time of the interface state (tractions, slip rates): t^n of the last step
        self.n = 0
        self.work_ext = 0.0  # this rank's share [J/m]
        self.u_imp_prev = np.zeros(len(model.impact.dofs))
        if model.fused is not None:
            model.fused.rest(self.u, self.t)  # at rest: the fused step skips what the motion has not reached


def function_space(msh):
    return fem.VectorFunctionSpace(msh, ("Lagrange", 1))


def stiffness(V, material: Material) -> PETSc.Mat:
    """Assemble ``K`` (AIJ with I-node kernels off: ~3× faster MatMult here)."""
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = material.mu, material.lmbda

    def eps(w):
        return ufl.sym(ufl.grad(w))

    def sigma(w):
        return 2.0 * mu * eps(w) + lmbda * ufl.tr(eps(w)) * ufl.Identity(2)

    a = fem.form(ufl.inner(sigma(u), eps(v)) * ufl.dx)
    K = fem_petsc.create_matrix(a)
    K.setOption(PETSc.Mat.Option.USE_INODES, False)
    fem_petsc.assemble_matrix(K, a)
    K.assemble()
    return K


def lumped_mass(V, rho: float) -> np.ndarray:
    """Row-sum lumped mass of the owned dofs: ∫ ρ N_i dx for each component."""
    v = ufl.TestFunction(V)
    ones = fem.Constant(V.mesh, PETSc.ScalarType((1.0, 1.0)))
    b = fem_petsc.assemble_vector(fem.form(rho * ufl.inner(ones, v) * ufl.dx))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b.array.copy()


def impact_dofs(V, facet_tags, names) -> np.ndarray:
    """Owned local x1-dof indices on the facets tagged with any of ``names``."""
    if not names:
        return np.zeros(0, dtype=np.int32)
    facets = np.sort(np.concatenate([facet_tags.indices[facet_tags.values == TAGS[n]] for n in names]))
    dofs = fem.locate_dofs_topological(V.sub(0), V.mesh.topology.dim - 1, facets)
    n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    return np.sort(dofs[dofs < n_owned]).astype(np.int32)


def edge_weights(V, facet_tags, names, dofs) -> np.ndarray:
    """A_i = ∫ N_i ds over the facets tagged ``names`` at the x1 dofs ``dofs`` [m per m]."""
    ds = ufl.Measure("ds", domain=V.mesh, subdomain_data=facet_tags)
    e1 = fem.Constant(V.mesh, PETSc.ScalarType((1.0, 0.0)))
    v = ufl.TestFunction(V)
    form = sum((ufl.inner(e1, v) * ds(TAGS[n]) for n in names[1:]), ufl.inner(e1, v) * ds(TAGS[names[0]]))
    b = fem_petsc.assemble_vector(fem.form(form))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b.array[dofs].copy()


def _coordinate_noise(V) -> np.ndarray:
    """A deterministic pseudo-random vector keyed on dof coordinates (identical on any
    number of ranks), to start the power iteration."""
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n, :2]
    h = np.sin(x[:, 0] * 12989.8 + x[:, 1] * 78233.0) * 43758.5453
    h = h - np.floor(h)
    return np.column_stack([h, 1.0 - h]).ravel() - 0.5


def max_eigenvalue(K, mass, interface, V, iterations=500, rtol=1e-8) -> float:
    """λmax of M⁻¹(K + K_int) by power iteration with the Rayleigh quotient
    x·(K + K_int)x / x·Mx (which converges quadratically)."""
    x = K.createVecRight()
    y = K.createVecRight()
    mx = K.createVecRight()
    x.array[:] = _coordinate_noise(V)
    lam = 0.0
    for _ in range(iterations):
        K.mult(x, y)
        interface.add_spring_action(x, y)
        mx.array[:] = x.array_r * mass
        new = x.dot(y) / x.dot(mx)
        y.array[:] /= mass  # y = M⁻¹ (K + K_int) x
        y.scale(1.0 / y.norm())
        x, y = y, x
        converged = abs(new - lam) <= rtol * new
        lam = new
        if converged:
            break
    return lam


def round_down(x: float, digits: int = 3) -> float:
    """Round down to ``digits`` significant digits (makes dt reproducible across rank counts)."""
    e = math.floor(math.log10(x)) - digits + 1
    return math.floor(x / 10.0**e + 1e-9) * 10.0**e


def _per_point(value, x1, width=None):
    """A per-point array from a scalar/array or a callable of x1."""
    v = value(x1) if callable(value) else value
    v = np.asarray(v, dtype=np.float64)
    shape = (len(x1),) if width is None else (len(x1), width)
    return np.array(np.broadcast_to(v, shape), dtype=np.float64, order="C")  # a writable copy


def build(pm, material: Material, pulse: ImpactPulse, law, params, sigma0: float,
          Cn: float, Cs: float, tau0=0.0, impact_tags=("impact_lower",),
          dt_safety: float = 0.9, dt: float | None = None, skip_quiet: bool = True) -> Model:
    """Assemble everything for a run on the mesh ``pm`` (:class:`fricfem.mesh.PlateMesh`).

    law       a :class:`fricfem.friction.Law`
    params    packed law parameters: float64[n_params], or a callable x1 -> float64[n, n_params]
    sigma0    initial compression Σ0 [Pa] (T_n = Σ0 on the interface at t <= 0)
    Cn, Cs    interface stiffnesses [Pa/m] (scalars or callables of x1)
    tau0      initial shear traction on the interface [Pa] (scalar or callable of x1)
    impact_tags  edges carrying the prescribed velocity
    dt        fixed step [s]; default ``dt_safety · 2/√λmax``, rounded down to 3 digits
    skip_quiet  the fused step skips the rows the motion has not reached
              (:class:`fricfem.fused.FusedBulk`)
    """
    comm = pm.mesh.comm
    V = function_space(pm.mesh)
    K = stiffness(V, material)
    mass = lumped_mass(V, material.rho)
    geom = iface_mod.build_geometry(V, pm.facet_tags, K.createVecRight())
    x1 = geom.x1
    points = iface_mod.make_points(
        law, _per_point(params, x1, len(law.params)), len(x1), sigma0,
        _per_point(tau0, x1), _per_point(Cn, x1), _per_point(Cs, x1),
    )
    interface = iface_mod.Interface(geom, points, law)
    dofs = impact_dofs(V, pm.facet_tags, impact_tags)
    impact = Impact(dofs, mass[dofs].copy(), pulse, np.zeros(len(dofs)), np.zeros(len(dofs)))
    if not pulse.prescribed and len(impact_tags):
        area = edge_weights(V, pm.facet_tags, impact_tags, dofs)
        z_force, z_damp = pulse.impedances(material.rho * material.c_l)
        impact = impact._replace(force=z_force * area, damp=z_damp * area)
    lam = max_eigenvalue(K, mass, interface, V)
    dt_crit = 2.0 / math.sqrt(lam)
    if dt is None:
        dt = round_down(dt_safety * dt_crit)
    model = Model(V, K, mass, dt / mass, impact, interface, material, dt, dt_crit, comm)
    return model._replace(fused=fused_mod.FusedBulk.build(model, skip=skip_quiet))


def step(model: Model, state: State, energy: dict | None = None) -> None:
    """Advance ``state`` by one step ``model.dt``: K u, the interface forces, the
    update and the struck edge in one sweep over the rows of K
    (:mod:`fricfem.fused`).  If ``energy`` is a dict it is filled with the
    energies at t^n (collective)."""
    if energy is not None:
        v_old = state.v.array_r.copy()
    uku, work = model.fused.advance(state.u, state.u_next, state.v, state.u_imp_prev, state.t)
    state.u, state.u_next = state.u_next, state.u  # u^{n+1}; u^n's buffer takes the next output
    state.work_ext += work
    if energy is not None:
        kinetic = 0.5 * float(np.dot(model.mass * v_old, state.v.array_r))
        loc = np.array([kinetic, state.work_ext, 0.5 * uku])
        tot = np.zeros(3)
        model.comm.Allreduce(loc, tot, op=MPI.SUM)
        energy.update(model.interface.energy())
        energy.update(time=state.t, kinetic=tot[0], strain=tot[2], external=tot[1])
        energy["balance_error"] = (
            energy["kinetic"] + energy["strain"] + energy["interface_work"] - energy["external"]
        )
    state.t_interface = state.t
    state.t += model.dt
    state.n += 1


def step_two_pass(model: Model, state: State, energy: dict | None = None, timers: dict | None = None) -> None:
    """The step as two passes, f = K u − F_int (PETSc) then the update: the reference
    for :func:`step`, and the one with phase timers.  If ``timers`` is a dict, the
    seconds spent in the phases ``bulk`` (K·u), ``interface`` (gather, kernel,
    scatter-add) and ``update`` (leapfrog pass, struck edge, work) are added to it."""
    dt = model.dt
    imp = model.impact
    u, v, f = state.u, state.v, state.f
    if timers is not None:
        t0 = time.perf_counter()
    model.K.mult(u, f)  # f = K u^n
    if energy is not None:
        strain = 0.5 * u.dot(f)
        v_old = v.array_r.copy()
    if timers is not None:
        t1 = time.perf_counter()
    model.interface.add_forces(u, f, dt)  # f = K u^n − F_int(u^n)
    if timers is not None:
        t2 = time.perf_counter()
    fa = f.array_r
    f_imp = fa[imp.dofs]
    v_imp_old = v.array_r[imp.dofs]
    u_imp_old = u.array_r[imp.dofs]
    leapfrog_update(u.array, v.array, fa, model.dt_minv, dt)
    if imp.pulse.prescribed:
        # the struck edge: exact prescribed displacement, consistent half-step velocity
        u1 = imp.pulse.displacement(state.t + dt)
        u0 = imp.pulse.displacement(state.t)
        u.array[imp.dofs] = u1
        v.array[imp.dofs] = (u1 - u0) / dt
        # reaction R^n = M a^n + f^n on the struck dofs; work R^n·(u^{n+1} − u^{n−1})/2
        react = imp.mass * ((u1 - u0) / dt - v_imp_old) / dt + f_imp
        state.work_ext += float(np.dot(react, 0.5 * (u1 - state.u_imp_prev)))
        state.u_imp_prev = np.full(len(imp.dofs), u0)
    else:
        # a traction F = force·sign·V(t^n) − damp·v^n, v^n = (v^{n−½} + v^{n+½})/2 (implicit in v^{n+½})
        sv = imp.pulse.sign * imp.pulse.velocity(state.t)
        c = model.dt_minv[imp.dofs]
        a = 0.5 * c * imp.damp
        v_new = (v_imp_old * (1.0 - a) - c * (f_imp - imp.force * sv)) / (1.0 + a)
        u_new = u_imp_old + dt * v_new
        v.array[imp.dofs] = v_new
        u.array[imp.dofs] = u_new
        load = imp.force * sv - imp.damp * 0.5 * (v_imp_old + v_new)
        state.work_ext += float(np.dot(load, 0.5 * (u_new - state.u_imp_prev)))
        state.u_imp_prev = u_imp_old
    if energy is not None:
        kinetic = 0.5 * float(np.dot(model.mass * v_old, v.array_r))
        loc = np.array([kinetic, state.work_ext])
        tot = np.zeros(2)
        model.comm.Allreduce(loc, tot, op=MPI.SUM)
        energy.update(model.interface.energy())
        energy.update(time=state.t, kinetic=tot[0], strain=strain, external=tot[1])
        energy["balance_error"] = (
            energy["kinetic"] + energy["strain"] + energy["interface_work"] - energy["external"]
        )
    state.t_interface = state.t
    state.t += dt
    state.n += 1
    if timers is not None:
        t3 = time.perf_counter()
        for name, seconds in (("bulk", t1 - t0), ("interface", t2 - t1), ("update", t3 - t2)):
            timers[name] = timers.get(name, 0.0) + seconds


def evolve(model: Model, state: State, t_end: float, energy_every: int = 0):
    """Step until ``t_end``; yields ``(state, energy or None)`` after every step."""
    n_end = int(math.floor(t_end / model.dt + 1e-9))
    while state.n < n_end:
        e = {} if energy_every and state.n % energy_every == 0 else None
        step(model, state, e)
        yield state, e


@numba.njit(cache=True)
def leapfrog_update(u, v, f, dt_minv, dt):
    """v -= (dt/m) f; u += dt v — one pass over the owned dofs."""
    for i in range(u.size):
        v[i] -= dt_minv[i] * f[i]
        u[i] += dt * v[i]
