"""The experiment's steel bodies (the paper's Section 3): a steel buffer plate
bonded to the lower plate's struck edge and a steel projectile that strikes it.

Geometry (x1 along the interface, x2 across it; the plates as in
:mod:`fricfem.model.grid`)::

      projectile                 buffer             lower plate
    −a − L_p < x1 < −a      −a < x1 < 0           0 < x1 < length
    −d < x2 < 0             −height < x2 < 0      −height < x2 < 0

with a = ``buffer_length`` (25.4 mm), L_p = ``projectile_length`` (51 mm) and
d = ``projectile_diameter`` (25 mm).  The buffer shares its nodes on x1 = 0
with the lower plate (bonded: one body of two materials); the projectile is a
separate body whose face x1 = −a meets the buffer's face node for node, in
unilateral frictionless contact (:mod:`fricfem.friction.contact` on the rigid
split-node pairs of :func:`fricfem.kernels.interface.advance_pairs`; the
pairs' normal is x1).  At t = 0 the projectile touches the buffer and moves
at ``projectile_speed`` along +x1; everything else is at rest.

Plane stress per unit thickness of the plates (``thickness``, 9.525 mm): a
body of another thickness t enters with its moduli and density multiplied by
t/thickness (the same mass, stiffness and impedance per unit height as the
real body; the wave speeds are the material's).  The buffer is as thick as
the plates; the projectile, a cylinder of diameter d, has the effective
thickness t_p = (π d²/4)/d = π d/4 (19.6 mm): its cross-section spread over
its 2-D height d, so that its mass and its bar impedance ρ c A are the
cylinder's.

The steel cells: a tensor grid whose x2 lines are the lower plate's (the
buffer's nodes on x1 = 0 are the plate's; the projectile's face matches the
buffer's), with ``steel_dx`` along x1, each cell split into two triangles
(diagonals alternating).  The plate's fine rows (dy high) near the interface
bound the steel's altitudes; two triangles a cell (altitude ≈ dy) instead of
four (dy/2) keep the steel's stable step near the Homalite's although its
wave speed is 2.4 times higher (docs/model.md §14).
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from ..keys import field
from ..kernels.reduce import dot
from .grid import TAGS, axis_nodes, plate_grid
from .material import Material
from .mesh import MeshSpec


@dataclasses.dataclass(frozen=True)
class Experiment:
    """The scene's ``[experiment]`` section: the steel buffer and projectile (module docstring)."""

    projectile_speed: float = field(0.0, "m/s", 0.0, 1e3, "speed of the steel projectile at impact (0: no "
                                                          "experiment bodies, the loading section's edge "
                                                          "velocity acts; > 0 needs loading.v_imp = 0)")
    projectile_length: float = field(0.051, "m", 1e-3, 1.0, "projectile length along x1")
    projectile_diameter: float = field(0.025, "m", 1e-3, 1.0, "projectile diameter: its 2-D height below "
                                                              "the interface, -d <= x2 <= 0 (the grid line "
                                                              "mesh.impact_b is set to it)")
    buffer_length: float = field(0.0254, "m", 1e-3, 1.0, "steel buffer length along x1 (it spans the lower "
                                                          "plate's height)")
    thickness: float = field(9.525e-3, "m", 1e-4, 1.0, "thickness of the plates and the buffer; the 2-D "
                                                       "model is per unit of it")
    projectile_thickness: float = field(0.0, "m", 0.0, 1.0, "effective thickness of the projectile (0: pi d/4, "
                                                            "the cylinder's cross-section over its height d)")
    steel_E: float = field(200e9, "Pa", 1e9, 1e12, "Young's modulus of the steel buffer and projectile")
    steel_nu: float = field(0.29, "", 0.0, 0.5, "Poisson's ratio of the steel", open_high=True)
    steel_rho: float = field(7850.0, "kg/m^3", 1e2, 1e5, "density of the steel")
    steel_dx: float = field(1.0e-3, "m", 1e-5, 1e-2, "cell size along x1 in the steel bodies")

    @property
    def on(self) -> bool:
        """The scene has the experiment's bodies."""
        return self.projectile_speed > 0.0

    def steel(self, plane: str = "stress") -> Material:
        return Material(self.steel_E, self.steel_nu, self.steel_rho, plane)

    @property
    def projectile_t(self) -> float:
        """Effective thickness of the projectile [m]: ``projectile_thickness``, or
        π d/4 for the cylinder (its cross-section over its height d)."""
        return self.projectile_thickness or math.pi * self.projectile_diameter / 4.0

    @property
    def projectile_mass(self) -> float:
        """The projectile's mass per unit thickness of the plates [kg/m]."""
        return self.steel_rho * self.projectile_t * self.projectile_diameter * self.projectile_length \
            / self.thickness

    def kinetic_energy(self) -> float:
        """½ m v² of the projectile per unit thickness of the plates [J/m]."""
        return 0.5 * self.projectile_mass * self.projectile_speed**2


@dataclasses.dataclass(frozen=True)
class BodiesMesh(MeshSpec):
    """A two-plate mesh with the experiment's buffer and projectile (lengths in m);
    the projectile's height is ``impact_b``.  :func:`fricfem.model.grid.grid_arrays`
    builds it through :func:`grid_arrays`."""

    buffer_length: float = 0.0254
    projectile_length: float = 0.051
    steel_dx: float = 1.0e-3

    def grid_arrays(self) -> tuple:
        """The plates' grid with the buffer and the projectile (:func:`grid_arrays`)."""
        return grid_arrays(self)

    def write_msh(self, path: str) -> None:
        """Write it as a gmsh model (:func:`write_msh`)."""
        write_msh(self, path)


def mesh_with_bodies(spec: MeshSpec, exp: Experiment) -> BodiesMesh:
    """``spec`` with the bodies of ``exp`` (the projectile's lower edge on the grid line impact_b)."""
    fields = {f.name: getattr(spec, f.name) for f in dataclasses.fields(MeshSpec)}
    fields["impact_b"] = exp.projectile_diameter
    return BodiesMesh(**fields, buffer_length=exp.buffer_length, projectile_length=exp.projectile_length,
                      steel_dx=exp.steel_dx)


def _split_cells(ids: np.ndarray) -> np.ndarray:
    """Two counter-clockwise triangles per cell of a node-id grid ``ids[j, i]``
    (j along x2 up, i along x1), diagonals alternating like a chessboard."""
    a, b = ids[:-1, :-1], ids[:-1, 1:]
    d, c = ids[1:, :-1], ids[1:, 1:]
    J, I = np.meshgrid(np.arange(a.shape[0]), np.arange(a.shape[1]), indexing="ij")
    even = ((I + J) % 2 == 0).ravel()
    a, b, c, d = a.ravel(), b.ravel(), c.ravel(), d.ravel()
    t1 = np.where(even[:, None], np.column_stack([a, b, c]), np.column_stack([a, b, d]))
    t2 = np.where(even[:, None], np.column_stack([a, c, d]), np.column_stack([b, c, d]))
    return np.vstack([t1, t2]).astype(np.int64)


def _steel_axis(x0: float, x1: float, h: float) -> np.ndarray:
    n = max(1, int(round((x1 - x0) / h)))
    xs = np.linspace(x0, x1, n + 1)
    xs[0], xs[-1] = x0, x1
    return xs


def grid_arrays(spec: BodiesMesh) -> tuple:
    """The grid of :func:`fricfem.model.grid.grid_arrays` with the buffer and the
    projectile: nodes and cells of the lower plate, the upper plate, the buffer,
    the projectile, in that order; cell tags ``buffer`` and ``projectile``;
    the lower plate's edge x1 = 0 is inside the body now (no facets), and the
    contact faces are tagged ``contact_buffer`` and ``contact_projectile``."""
    lo, up = plate_grid(spec, False), plate_grid(spec, True)
    lo = lo._replace(edges={k: v for k, v in lo.edges.items() if k not in ("impact_lower", "left")})
    nx = len(axis_nodes(spec.length, (spec.fine_x0, spec.fine_x1), spec.dx, spec.grading, spec.max_size, ())) - 1
    ys = -axis_nodes(spec.height, (0.0, spec.fine_height), spec.dy, spec.grading, spec.max_size,
                     (spec.impact_b,))[::-1]
    ny = len(ys) - 1
    off = len(lo.x) + len(up.x)
    # buffer: columns i = 0 … nb, the last one the lower plate's nodes on x1 = 0 (vid(0, j) = j (nx + 1))
    xb = _steel_axis(-spec.buffer_length, 0.0, spec.steel_dx)
    nb = len(xb) - 1
    bid = np.empty((ny + 1, nb + 1), dtype=np.int64)
    bid[:, :nb] = off + np.arange((ny + 1) * nb).reshape(ny + 1, nb)
    bid[:, nb] = np.arange(ny + 1) * (nx + 1)
    XB, YB = np.meshgrid(xb[:nb], ys, indexing="xy")
    xbuf = np.column_stack([XB.ravel(), YB.ravel()])
    # projectile: rows from x2 = −d (a grid line) to 0, its face x1 = −a on the buffer's
    j0 = int(np.flatnonzero(ys == -spec.impact_b)[0])
    xp = _steel_axis(-spec.buffer_length - spec.projectile_length, -spec.buffer_length, spec.steel_dx)
    yp = ys[j0:]
    off_p = off + len(xbuf)
    pid = off_p + np.arange(len(yp) * len(xp)).reshape(len(yp), len(xp))
    XP, YP = np.meshgrid(xp, yp, indexing="xy")
    xproj = np.column_stack([XP.ravel(), YP.ravel()])
    cb, cp = _split_cells(bid), _split_cells(pid)
    edges = {
        "contact_buffer": np.column_stack([bid[j0:-1, 0], bid[j0 + 1:, 0]]),
        "contact_projectile": np.column_stack([pid[:-1, -1], pid[1:, -1]]),
    }
    n_lo = len(lo.x)
    x = np.vstack([lo.x, up.x, xbuf, xproj])
    cells = np.vstack([lo.cells, up.cells + n_lo, cb, cp])
    cell_tags = np.concatenate([np.full(len(lo.cells), TAGS["lower"]), np.full(len(up.cells), TAGS["upper"]),
                                np.full(len(cb), TAGS["buffer"]), np.full(len(cp), TAGS["projectile"])])
    facets, facet_tags = [], []
    parts = ((lo.edges, 0), (up.edges, n_lo), (edges, 0))
    for name in sorted({*lo.edges, *up.edges, *edges}, key=lambda n: TAGS[n]):
        for e, shift in parts:
            if name in e and len(e[name]):
                facets.append(e[name] + shift)
                facet_tags.append(np.full(len(e[name]), TAGS[name]))
    return (x, cells.astype(np.int64), cell_tags.astype(np.int32), np.vstack(facets).astype(np.int64),
            np.concatenate(facet_tags).astype(np.int32))


def body_of_cells(x: np.ndarray, cells: np.ndarray, spec: BodiesMesh) -> np.ndarray:
    """int8[n]: 0 Homalite, 1 buffer, 2 projectile, from each cell's centroid."""
    cx = x[cells].mean(axis=1)[:, 0]
    return np.where(cx < -spec.buffer_length, 2, np.where(cx < 0.0, 1, 0)).astype(np.int8)


class CellMaterials(NamedTuple):
    """In-plane moduli and density per grid cell, thickness factor included
    (:func:`fricfem.model.assembly.canonical_rows` takes them for ``material``)."""

    lmbda: np.ndarray
    mu: np.ndarray
    rho: np.ndarray

    def take(self, sel) -> "CellMaterials":
        return CellMaterials(self.lmbda[sel], self.mu[sel], self.rho[sel])


def factors(exp: Experiment) -> np.ndarray:
    """Thickness factors t/thickness of (Homalite, buffer, projectile)."""
    return np.array([1.0, 1.0, exp.projectile_t / exp.thickness])


def cell_materials(num, spec: BodiesMesh, material: Material, exp: Experiment) -> CellMaterials:
    """Per-cell moduli and density of the grid numbering ``num``: Homalite
    (``material``), the buffer and the projectile (steel, times their thickness factor)."""
    body = body_of_cells(num.x, num.cells, spec)
    steel = exp.steel(material.plane)
    f = factors(exp)
    lam = np.array([material.lmbda, f[1] * steel.lmbda, f[2] * steel.lmbda])
    mu = np.array([material.mu, f[1] * steel.mu, f[2] * steel.mu])
    rho = np.array([material.rho, f[1] * steel.rho, f[2] * steel.rho])
    return CellMaterials(lam[body], mu[body], rho[body])


def _face_nodes(num, name: str) -> np.ndarray:
    nodes = np.unique(num.facets[num.facet_tags == TAGS[name]])
    return nodes[np.argsort(num.x[nodes, 1], kind="stable")]


def contact_pairs(num, template, mass: np.ndarray, comm, target):
    """The projectile–buffer contact as rigid split-node pairs
    (:class:`fricfem.model.interface.PairGeometry`) with the normal along x1:
    the gathered layout holds each node's (x2, x1) components, so that the
    pair kernel's (s, n) are (x2, x1); "lower" is the projectile, "upper" the
    buffer (Δu_n = u1(buffer) − u1(projectile), opening positive).  The pairs'
    negative forces are inserted into ``target`` (a vector with the layout of
    the displacement) at their dofs only.  Collective."""
    from .interface import pair_geometry  # here: petsc4py only once a model is built (start-up: scenes import bodies)

    p, b = _face_nodes(num, "contact_projectile"), _face_nodes(num, "contact_buffer")
    if len(p) < 2 or len(p) != len(b) or not np.array_equal(num.x[p], num.x[b]):
        raise RuntimeError("experiment: the projectile's face and the buffer's do not pair up node for node")
    gp, gb = num.global_block[p], num.global_block[b]
    # (x2, x1): the pair kernel's (s, n); no prescribed dof on the contact
    geom = pair_geometry(num.x[p, 1].copy(), gp, gb, (1, 0), template, mass, comm, target=target)
    return geom, np.concatenate([gp[geom.pairs], gb[geom.pairs]])


def projectile_nodes(num, spec: BodiesMesh) -> np.ndarray:
    """This rank's owned local blocks (nodes) of the projectile (the nodes of its cells)."""
    nodes = np.unique(num.cells[body_of_cells(num.x, num.cells, spec) == 2])
    local = num.block_of_node[nodes]
    return np.sort(local[(local >= 0) & (local < num.n_owned)])


class Launch(NamedTuple):
    """What a run of the experiment needs beyond the plates' model: the bodies,
    this rank's owned projectile nodes (local blocks) and the contact interface
    (:class:`fricfem.step.interface.RigidInterface`)."""

    experiment: Experiment
    spec: BodiesMesh
    nodes: np.ndarray
    contact: object


def _handled_blocks(num, geometry) -> np.ndarray:
    """Global blocks of the frictional interface's nodes this rank's segments (or pairs) touch."""
    from .interface import interface_nodes  # here: petsc4py only once a model is built (start-up)

    lo, up = interface_nodes(num, "interface_lower"), interface_nodes(num, "interface_upper")
    segs = getattr(geometry, "segments", None)
    idx = np.unique(np.concatenate([segs, segs + 1])) if segs is not None else geometry.pairs
    return np.concatenate([num.global_block[lo[idx]], num.global_block[up[idx]]])


def attach(num, K, mass, comm, friction_interface, spec: BodiesMesh, exp: Experiment) -> tuple:
    """The frictional interface with the projectile's contact (one interface for the
    step, :class:`fricfem.step.contact.WithContact`) and the :class:`Launch`.  Collective."""
    # here, not at the top: the scene imports this module for its dataclasses, and the contact's law, step
    # and petsc4py are needed only once a model is built (start-up time)
    from .. import friction as _friction  # noqa: F401  (the laws' kernels import the kernels module)
    from ..friction.contact import LAW
    from ..step.contact import WithContact
    from ..step.interface import RigidInterface
    from .interface import make_points

    template = K.createVecRight()
    geom, contact_blocks = contact_pairs(num, template, mass, comm, friction_interface.geometry.right)
    n = len(geom.pairs)
    points = make_points(LAW, np.zeros((n, 0)), n, 0.0, 0.0, 0.0, 0.0)
    contact = RigidInterface(geom, points, LAW, slot="contact")
    blocks = np.concatenate([_handled_blocks(num, friction_interface.geometry), contact_blocks])
    both = WithContact(friction_interface, contact, blocks, template)
    nodes = projectile_nodes(num, spec)
    nodes.setflags(write=False)  # the model's
    return both, Launch(exp, spec, nodes, contact)


def launch(model, state) -> None:
    """Set the projectile moving at t = 0: v^{−½} = ``projectile_speed`` along x1 on
    its nodes (the rows wake), its kinetic energy ½ M v² booked as the external
    work put in, and the energy the first step's node-to-node collision of the
    face pairs dissipates, Σ ½ μ v² with μ = M_p M_b/(M_p + M_b) (at u = 0 the
    contact makes each face pair move together at once: a perfectly inelastic
    collision of two lumped masses, which the discrete kinetic energy
    ½ v^{−½}·M v^{+½} of step 0 already lacks), booked as work done on the
    contact and dissipated there, so that the budget closes to round-off."""
    b = model.bodies
    v0 = b.experiment.projectile_speed
    dofs = 2 * b.nodes
    state.v.array[dofs] = v0
    state.act[b.nodes] = np.maximum(state.act[b.nodes], 1)  # kernels.bulk.ACTIVE: computed, wakes neighbours
    state.work_ext += 0.5 * dot(model.mass[dofs], np.full(len(dofs), v0 * v0))  # fixed order, not BLAS's
    p, g = state.contact, b.contact.geometry
    mp, mb = g.mass[0::2], g.mass[1::2]
    loss = 0.5 * (mp * mb / (mp + mb)) * v0 * v0 / g.wq  # per unit contact length [J/m²]
    p.work[:] += loss
    p.dissipated[:] += loss


class _Moduli(NamedTuple):
    mu: object
    lmbda: object


def field_moduli(V, spec: BodiesMesh, material: Material, exp: Experiment) -> _Moduli:
    """The in-plane moduli as piecewise-constant (DG0) functions on the mesh of ``V``,
    for the field output's stresses (:class:`fricfem.output.fields.FieldWriter`
    takes them for ``material``): Homalite, and the steel in the buffer and the
    projectile (true stresses: the thickness factor is not applied)."""
    # lazy: start-up time (dolfinx/petsc4py are slow to import)
    from dolfinx import fem  # here: dolfinx only for the field output (start-up: scenes import bodies)

    from .. import compat

    W = compat.function_space(V.mesh, "DG", 0)
    steel = exp.steel(material.plane)
    out = []
    for name in ("mu", "lmbda"):
        f = fem.Function(W)
        a, s = getattr(material, name), getattr(steel, name)
        f.interpolate(lambda x, a=a, s=s: np.where(x[0] < 0.0, s, a))
        out.append(f)
    return _Moduli(*out)


def from_section(table: dict, given: dict, spec: MeshSpec, v_imp: float, symmetric: bool) -> tuple:
    """(Experiment or None, the mesh spec with the bodies) of a checked ``[experiment]``
    section (``table``, defaults filled in; ``given``: the keys the scene set),
    with the rules between it and the other sections; a ValueError names the
    key and what is allowed."""
    exp = Experiment(**{k: float(v) for k, v in table.items()})
    if not exp.on:
        if given:
            raise ValueError(f"experiment.{sorted(given)[0]}: set without experiment.projectile_speed > 0; the "
                             "buffer and the projectile exist only with a projectile speed")
        return None, spec
    speed = f"experiment.projectile_speed = {exp.projectile_speed!r} m/s"
    if v_imp != 0.0:
        raise ValueError(f"{speed}: the projectile loads the specimen, so loading.v_imp must be 0 (it is "
                         f"{v_imp!r} m/s: an edge velocity would act on the buffer's face too)")
    if symmetric:
        raise ValueError(f"{speed}: loading.symmetric must be false (the buffer is bonded to the lower plate only)")
    if exp.projectile_diameter > spec.height:
        raise ValueError(f"experiment.projectile_diameter = {exp.projectile_diameter!r} m: must not exceed the "
                         f"plate height mesh.height = {spec.height!r} m (it strikes the buffer below the interface)")
    if exp.steel_dx > min(exp.buffer_length, exp.projectile_length):
        raise ValueError(f"experiment.steel_dx = {exp.steel_dx!r} m: must not exceed the buffer length "
                         f"({exp.buffer_length!r} m) or the projectile length ({exp.projectile_length!r} m)")
    return exp, mesh_with_bodies(spec, exp)


def write_msh(spec: BodiesMesh, path: str) -> None:
    """Write the grid with the bodies as a gmsh model (.msh): one discrete surface per
    cell tag and one curve per facet tag, physical groups named after
    :data:`fricfem.model.grid.TAGS`."""
    import gmsh  # here: gmsh only to write a .msh file (start-up)

    x, cells, ctags, facets, ftags = grid_arrays(spec)
    names = {v: k for k, v in TAGS.items()}
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fricfem_experiment")
        node_tags = np.arange(1, len(x) + 1, dtype=np.uint64)
        for entity, tag in enumerate(np.unique(ctags), start=1):
            surf = gmsh.model.addDiscreteEntity(2, entity)
            if entity == 1:  # every node on the first surface (gmsh: a node belongs to one entity)
                gmsh.model.mesh.addNodes(2, surf, node_tags, np.column_stack([x, np.zeros(len(x))]).ravel())
            gmsh.model.mesh.addElementsByType(surf, 2, [], (cells[ctags == tag] + 1).ravel())
            gmsh.model.addPhysicalGroup(2, [surf], int(tag))
            gmsh.model.setPhysicalName(2, int(tag), names[int(tag)])
        for entity, tag in enumerate(np.unique(ftags), start=100):
            curve = gmsh.model.addDiscreteEntity(1, entity)
            gmsh.model.mesh.addElementsByType(curve, 1, [], (facets[ftags == tag] + 1).ravel())
            gmsh.model.addPhysicalGroup(1, [curve], int(tag))
            gmsh.model.setPhysicalName(1, int(tag), names[int(tag)])
        gmsh.write(path)
    finally:
        gmsh.finalize()
