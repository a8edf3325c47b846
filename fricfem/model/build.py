"""Everything a run assembles once, in one record (:class:`Model`), from a scene
or from its parts.

    scene ─► mesh (model.mesh) ─► grid numbering (model.numbering)
                                ─► K, lumped mass in the grid's order (model.assembly)
                                ─► interface geometry and points (model.interface)
                                ─► struck edge (Impact) ─► λmax, dt ─► the fused step

The model holds no state of a run: that is :class:`fricfem.step.state.State`.
Its numpy arrays are read-only once built (:func:`build` marks them so; the
PETSc work vectors of the interface and the fused step are scratch, written
before they are read in every step), so one model serves any number of runs,
one after another, with no reset between them.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .. import friction
from ..step.fused import FusedBulk, block_rows, identity_rows
from ..step.interface import Interface, RigidInterface
from . import bodies as bodies_mod
from . import diskcache
from . import interface as iface_mod
from . import mesh as mesh_mod
from .grid import INTERFACE_KINDS
from .assembly import (canonical_mass, canonical_rows, dashpots, edge_weights, function_space, impact_dofs,
                       layer_rows, max_eigenvalue, round_down, SemStiffness, Stiffness)
from .numbering import Numbering, numbering
from .loading import ImpactPulse
from .material import Material


class Impact(NamedTuple):
    """The load on the struck edge (:mod:`fricfem.model.loading`).

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
    """Everything assembled once for a run (no run state; read-only numpy arrays)."""

    V: object  # dolfinx FunctionSpace (P1 vector)
    K: Stiffness  # PETSc AIJ, assembled when first used (a run needs only its vectors)
    mass: np.ndarray  # lumped mass, owned dofs [kg/m]
    dt_minv: np.ndarray  # dt / mass
    impact: Impact
    interface: Interface
    material: Material
    dt: float  # time step [s]
    dt_crit: float  # 2/√λmax [s]
    comm: object
    bulk: FusedBulk  # the one-pass step
    num: Numbering  # this rank's dofs against the grid
    bodies: object = None  # the experiment's buffer and projectile (fricfem.model.bodies.Launch), or None


def build(pm, material: Material, pulse: ImpactPulse, law, params, sigma0: float,
          Cn: float, Cs: float, tau0=0.0, impact_tags=("impact_lower",),
          dt_safety: float = 0.9, dt: float | None = None, interface_kind: str = "elastic",
          absorbing=(), state_tau0=None, like: Model | None = None, experiment=None,
          damping=(0.0, 0.0)) -> Model:
    """Assemble everything for a run on the mesh ``pm`` (:class:`fricfem.model.mesh.PlateMesh`).
    Collective.

    law       a :class:`fricfem.friction.Law`
    params    packed law parameters: float64[n_params], or a callable x1 -> float64[n, n_params]
    sigma0    initial compression Σ0 [Pa] (T_n = Σ0 on the interface at t <= 0)
    Cn, Cs    interface stiffnesses [Pa/m] (scalars or callables of x1)
    tau0      initial shear traction on the interface [Pa] (scalar or callable of x1;
              a rigid pair takes its mean over the pair's share, ``iface_mod.pair_mean``)
    impact_tags  edges carrying the impact (none: the edge is free)
    dt        fixed step [s]; default ``dt_safety · 2/√λmax``, rounded down to 3 digits
    interface_kind  "elastic" (springs C_n, C_s at 4 Gauss points a segment, the paper's)
              or "rigid" (split-node pairs: the traction from the pairs' trial velocities)
    absorbing outer edges with dashpots (of :data:`fricfem.model.grid.OUTER`)
    state_tau0  the shear traction the law's initial state is set from (scalar or
              callable of x1; default ``tau0``, each point's own)
    damping   (ξ, w): a Kelvin–Voigt layer, the cells whose centroid has |x2| < w [m],
              with the stress C:ε(u + η v), η = ξ dt (SEM2DPACK's ETA); the stable
              step is 2/√λmax/√(1 + 2ξ) (:func:`fricfem.model.assembly.layer_rows`)
    like      a model built on ``pm`` with the same material, interface kind and
              stiffnesses, struck edges, load kind, step and absorbing edges
              (:func:`fricfem.model.reuse.model_key`): its K, lumped mass,
              numbering, interface geometry, λmax, dt and the fused step's rows and
              scatters are taken as they are, and only the interface points, the law
              and the load are made here (not collective then)
    experiment  the experiment's steel buffer and projectile
              (:class:`fricfem.model.bodies.Experiment`; ``pm`` built from a
              :class:`fricfem.model.bodies.BodiesMesh`), or None
    """
    if interface_kind not in INTERFACE_KINDS:
        raise ValueError(f"interface_kind = {interface_kind!r}: one of {INTERFACE_KINDS}")
    if like is None:
        comm = pm.mesh.comm
        V = function_space(pm.mesh)
        num = numbering(pm, V)
        cells = material if experiment is None else bodies_mod.cell_materials(num, pm.spec, material, experiment)
        if num.elements is not None:  # spectral elements: K matrix-free, never assembled
            rows = None
            K = SemStiffness(num, material, comm)
        else:  # this rank's rows from the on-disk cache when they are there (.diskcache)
            rows = (diskcache.cached_rows(pm.spec, material, num, comm, lambda: canonical_rows(num, cells))
                    if experiment is None else canonical_rows(num, cells))
            K = Stiffness(num, rows, comm)
        mass = canonical_mass(num, cells.rho)
        dofs = impact_dofs(V, pm.facet_tags, impact_tags)
        if interface_kind == "rigid":
            geom = iface_mod.build_pairs(num, K.createVecRight(), mass, comm, dofs if pulse.prescribed else ())
        else:
            geom = iface_mod.build_geometry(num, K.createVecRight(), comm)
    else:
        num, mass, dofs, geom = like.num, like.mass, like.impact.dofs, like.interface.geometry
    x1 = geom.x1

    # a point at a node carries the mean of a traction field over the node's share (iface_mod.pair_mean);
    # a Gauss point inside a segment, the field's value there
    if interface_kind == "rigid":
        at_nodes = geom.pairs  # one point a node pair
    elif len(geom.shape) == 1:
        at_nodes = geom.segments  # the elastic kind on spectral elements: one point a node, at the node
    else:
        at_nodes = None  # the elastic kind on the triangles: 4 Gauss points a segment

    def traction(f):
        if at_nodes is not None and callable(f):
            return iface_mod.pair_mean(f, geom.x1_nodes, at_nodes)
        return iface_mod.per_point(f, x1)

    points = iface_mod.make_points(
        law, iface_mod.per_point(params, x1, len(law.params)), len(x1), sigma0,
        traction(tau0), iface_mod.per_point(Cn, x1), iface_mod.per_point(Cs, x1),
        state_Ts0=None if state_tau0 is None else traction(state_tau0),
    )
    interface = (RigidInterface if interface_kind == "rigid" else Interface)(geom, points, law)
    impact = Impact(dofs, mass[dofs].copy(), pulse, np.zeros(len(dofs)), np.zeros(len(dofs)))
    if not pulse.prescribed and len(impact_tags):
        area = edge_weights(num, impact_tags, dofs)
        z_force, z_damp = pulse.impedances(material.rho * material.c_l)
        impact = impact._replace(force=z_force * area, damp=z_damp * area)
    _freeze_impact(impact)
    if like is not None:
        return like._replace(impact=impact, interface=interface, bulk=like.bulk.rebind(interface, impact))
    launch = None
    if experiment is not None:  # the projectile's contact on the buffer joins the frictional interface
        interface, launch = bodies_mod.attach(num, K, mass, comm, interface, pm.spec, experiment)
    if experiment is None:  # λmax from the on-disk cache when it is there (.diskcache)
        lam = diskcache.cached_lam((pm.spec, material, num, interface, interface_kind, impact_tags,
                                    pulse.prescribed, absorbing), comm,
                                   lambda: max_eigenvalue(K, mass, interface, num))
    else:
        lam = max_eigenvalue(K, mass, interface, num)
    xi, width = float(damping[0]), float(damping[1])
    # central differences with the layer's force at v^{n−½}: stable for (ω dt)² (1 + 2ξ) <= 4
    dt_crit = 2.0 / math.sqrt(lam) / math.sqrt(1.0 + 2.0 * xi)
    if dt is None:
        dt = round_down(dt_safety * dt_crit)
    viscous = None
    if xi > 0:
        viscous = (block_rows(num, layer_rows(num, material, width)), xi * dt)
    spectral = rows is None  # the identity rows pass the matrix-free K u on
    bulk = FusedBulk(identity_rows(num.n_owned, K.ghost) if spectral else block_rows(num, rows), dt / mass, dt,
                     interface, impact, K.createVecRight(), comm, dashpots(num, tuple(absorbing), material),
                     viscous=viscous, sem=K.kernel_args() if spectral else None)
    dt_minv = dt / mass
    for a in (mass, dt_minv, *(a for a in num if isinstance(a, np.ndarray))):
        a.setflags(write=False)
    return Model(V, K, mass, dt_minv, impact, interface, material, dt, dt_crit, comm, bulk, num, launch)


def _freeze_impact(impact: Impact) -> None:
    """The struck edge's arrays read-only (the model's)."""
    for a in (impact.dofs, impact.mass, impact.force, impact.damp):
        if isinstance(a, np.ndarray):
            a.setflags(write=False)


def impact_tags(scene) -> tuple:
    """The edges a scene strikes: none without an impact (a rupture problem: the
    edge is free), the lower plate's, or both plates' (symmetric loading)."""
    if scene.pulse.v_imp == 0:
        return ()
    return ("impact_lower", "impact_upper") if scene.symmetric else ("impact_lower",)


def param_field(scene, law) -> iface_mod.ParamField:
    """The scene's friction parameters along x1 (``law`` the scene's law): its
    ``friction.params``, each ``friction.regions`` entry where x1_min <= x1 <=
    x1_max, then each ``friction.profiles`` parameter between its knots."""
    names = friction.param_names(law)
    regions = tuple((reg["x1_min"], reg["x1_max"], friction.pack(law, {**scene.params, **reg.get("params", {})}))
                    for reg in scene.regions)
    profiles = tuple((names.index(name), *np.array(knots, dtype=np.float64).T) for name, knots in scene.profiles)
    return iface_mod.ParamField(friction.pack(law, scene.params), regions, profiles)


def traction_field(scene) -> iface_mod.TractionField:
    """The initial shear traction along x1 [Pa]: uniform ``interface.tau0``, then each
    ``interface.patches`` entry where x1_min <= x1 <= x1_max."""
    return iface_mod.TractionField(scene.tau0, tuple((p["x1_min"], p["x1_max"], p.get("tau0", scene.tau0))
                                                     for p in scene.tau0_patches))


def build_model(scene, comm, like=None):
    """Mesh and model of a validated scene (:class:`fricfem.scene.Scene`); collective.
    Returns ``(plate mesh, model)``.  ``like``: the ``(plate mesh, model)`` of a scene
    with the same :func:`fricfem.model.reuse.model_key`, whose mesh and assembled
    parts are reused (``build(like=...)``; the result is the same, bit for bit).
    A scene with the experiment's bodies is always built in full (``like`` is
    ignored: its contact and projectile are not part of what a model shares)."""
    # the scene resolved into plain data first; from here on it flows down
    experiment = getattr(scene, "experiment", None)
    if experiment is not None:
        like = None
    law = friction.get_law(scene.law)
    params, tau0, tags = param_field(scene, law), traction_field(scene), impact_tags(scene)
    state_tau0 = scene.tau0 if scene.initial_state == "background" else None
    pm = mesh_mod.build(scene.mesh, comm) if like is None else like[0]
    model = build(
        pm, scene.material, scene.pulse, law, params, scene.sigma0, scene.Cn, scene.Cs, tau0=tau0,
        impact_tags=tags, dt_safety=scene.dt_safety, dt=scene.dt, interface_kind=scene.interface_kind,
        absorbing=scene.absorbing, state_tau0=state_tau0, like=None if like is None else like[1],
        experiment=experiment, damping=(scene.damping_eta, scene.damping_width),
    )
    return pm, model
