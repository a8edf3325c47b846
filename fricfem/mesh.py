"""Two-plate meshes with a duplicated interface, in the paper's crossed-triangle pattern.

Geometry (SPEC §3): a lower plate ``0 < x1 < length, -height < x2 < 0`` and an
upper plate ``0 < x1 < length, 0 < x2 < height``, meshed separately so that the
interface ``x2 = 0`` carries two coincident node rows (``interface_lower`` and
``interface_upper``).  Each plate is a tensor grid of quadrilaterals, uniform
(``dx × dy``) in a fine region ``fine_x0 ≤ x1 ≤ fine_x1``, ``|x2| ≤ fine_height``
and geometrically graded outside it; every quadrilateral is split into four
linear triangles through its centre node ("crossed triangles", as in the
paper's finite element code).  Grid lines lie exactly on ``x2 = ±impact_b`` so
the impacted segment of the edge ``x1 = 0`` is exact.

The grid is generated with numpy and handed to gmsh as discrete entities with
named physical groups; dolfinx imports it through ``gmshio.model_to_mesh``.
Tag names (see :data:`TAGS`) are the only way code refers to boundaries.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

#: Physical-group ids by name (cells: plates; facets: edges).
TAGS = {
    "lower": 1,
    "upper": 2,
    "interface_lower": 11,
    "interface_upper": 12,
    "impact_lower": 21,
    "impact_upper": 22,
    "outer": 30,
}


@dataclasses.dataclass(frozen=True)
class MeshSpec:
    """A two-plate mesh; lengths in metres.

    ``grading`` is the growth ratio of neighbouring cell sizes outside the fine
    region and ``max_size`` caps the cell size there.
    """

    length: float = 0.137  # plate length along the interface, x1 [m]
    height: float = 0.075  # height of each plate, x2 [m]
    dx: float = 0.30e-3  # fine-region cell size along x1 [m]
    dy: float = 0.20e-3  # fine-region cell size along x2 [m]
    fine_x0: float = 0.0  # fine region start along x1 [m]
    fine_x1: float = 0.060  # fine region end along x1 [m]
    fine_height: float = 2.0e-3  # fine region extent above and below the interface [m]
    impact_b: float = 0.025  # impacted edge segment, x1 = 0, |x2| <= b [m]
    grading: float = 1.15  # cell-size growth ratio outside the fine region [-]
    max_size: float = 5.0e-3  # largest cell size [m]

    def check(self) -> None:
        """Raise ``ValueError`` naming the field and the allowed range."""
        for name in ("length", "height", "dx", "dy", "fine_height", "impact_b", "max_size"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"mesh.{name} = {v!r} m: must be a positive length")
        if not 1.0 <= self.grading <= 2.0:
            raise ValueError(f"mesh.grading = {self.grading!r}: must lie in [1, 2]")
        if not 0.0 <= self.fine_x0 < self.fine_x1 <= self.length:
            raise ValueError(
                f"mesh.fine_x0 = {self.fine_x0!r} m, mesh.fine_x1 = {self.fine_x1!r} m: the fine "
                f"region must satisfy 0 <= fine_x0 < fine_x1 <= length = {self.length!r} m"
            )
        if self.fine_height > self.height:
            raise ValueError(
                f"mesh.fine_height = {self.fine_height!r} m: must not exceed the plate height "
                f"{self.height!r} m"
            )
        if self.impact_b > self.height:
            raise ValueError(
                f"mesh.impact_b = {self.impact_b!r} m: must not exceed the plate height {self.height!r} m"
            )
        for name, h, span in (("dx", self.dx, self.fine_x1 - self.fine_x0), ("dy", self.dy, self.fine_height)):
            if h > span:
                raise ValueError(f"mesh.{name} = {h!r} m: larger than the fine region it meshes ({span!r} m)")
        if self.max_size < max(self.dx, self.dy):
            raise ValueError(f"mesh.max_size = {self.max_size!r} m: must be >= dx and dy")
        cells = self.estimate_quads()
        if cells > 5_000_000:
            raise ValueError(f"mesh: about {cells:.3g} quadrilaterals requested; at most 5e6 are allowed")

    def estimate_quads(self) -> float:
        nx = len(axis_nodes(self.length, (self.fine_x0, self.fine_x1), self.dx, self.grading, self.max_size, ()))
        ny = len(axis_nodes(self.height, (0.0, self.fine_height), self.dy, self.grading, self.max_size, (self.impact_b,)))
        return 2.0 * (nx - 1) * (ny - 1)


#: Mesh presets (SPEC §3).  ``reference`` is the paper's mesh: 200 × 10 cells of
#: 0.30 mm × 0.20 mm per plate next to the interface within 60 mm of the impact
#: edge, 17,784 quadrilaterals in all (the paper: 18,320).  Every quadrilateral
#: carries a centre node, so DOF counts exceed the paper's (which condenses it).
PRESETS = {
    "coarse": MeshSpec(dx=2.1e-3, dy=1.0e-3, grading=1.25, max_size=10e-3),
    "reference": MeshSpec(),
    "half": MeshSpec(dx=0.15e-3, dy=0.20e-3),
    "fine": MeshSpec(dx=0.075e-3, dy=0.10e-3),
}


def preset(name: str) -> MeshSpec:
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"mesh.preset = {name!r}: unknown; allowed: {', '.join(PRESETS)}") from None


def axis_nodes(length, fine, h, ratio, hmax, breaks) -> np.ndarray:
    """Node coordinates on ``[0, length]``: spacing ``h`` inside ``fine = (a, b)``,
    growing geometrically by ``ratio`` per cell away from it (capped at ``hmax``),
    with nodes exactly at ``a``, ``b`` and every point of ``breaks``.

    Geometric growth of cell sizes means the target size grows linearly with the
    distance ``d`` from the fine interval, ``s(d) = min(hmax, h + (ratio - 1) d)``.
    Each piece between break points gets ``round(∫ dx / s)`` cells, placed at
    equal increments of that integral, so the fine region is exactly uniform.
    """
    a, b = fine
    pts = sorted({0.0, float(length), float(a), float(b), *(float(x) for x in breaks if 0 < x < length)})
    nodes = [np.array([0.0])]
    for p, q in zip(pts[:-1], pts[1:]):
        if a <= p and q <= b:  # inside the fine region: exactly uniform
            n = max(1, int(round((q - p) / h)))
            nodes.append(np.linspace(p, q, n + 1)[1:])
            continue
        # cumulative cell count N(x) = ∫ dx / s(x) on a fine sampling of [p, q]
        xs = np.linspace(p, q, 4001)
        d = np.where(xs < a, a - xs, np.where(xs > b, xs - b, 0.0))
        s = np.minimum(hmax, h + (ratio - 1.0) * d)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (1 / s[1:] + 1 / s[:-1]) * np.diff(xs))])
        n = max(1, int(round(cum[-1])))
        nodes.append(np.interp(np.linspace(0.0, cum[-1], n + 1)[1:], cum, xs))
    x = np.concatenate(nodes)
    x[-1] = length
    return x


class PlateGrid(NamedTuple):
    """Crossed-triangle grid of one plate (numpy, no dolfinx).

    x       float64[n_nodes, 2]  node coordinates [m] (corners first, then centres)
    cells   int64[n_cells, 3]    triangles, counter-clockwise
    edges   dict name -> int64[n, 2]  boundary edges by tag name
    """

    x: np.ndarray
    cells: np.ndarray
    edges: dict


def plate_grid(spec: MeshSpec, upper: bool) -> PlateGrid:
    """Build one plate's crossed-triangle grid and its named boundary edges."""
    xs = axis_nodes(spec.length, (spec.fine_x0, spec.fine_x1), spec.dx, spec.grading, spec.max_size, ())
    ys = axis_nodes(spec.height, (0.0, spec.fine_height), spec.dy, spec.grading, spec.max_size, (spec.impact_b,))
    if not upper:
        ys = -ys[::-1]  # lower plate: x2 from -height up to 0
    nx, ny = len(xs) - 1, len(ys) - 1
    X, Y = np.meshgrid(xs, ys, indexing="xy")  # [ny+1, nx+1]
    corners = np.column_stack([X.ravel(), Y.ravel()])
    cx = 0.5 * (xs[:-1] + xs[1:])
    cy = 0.5 * (ys[:-1] + ys[1:])
    CX, CY = np.meshgrid(cx, cy, indexing="xy")
    centres = np.column_stack([CX.ravel(), CY.ravel()])
    x = np.vstack([corners, centres])

    def vid(i, j):  # corner (i along x1, j along x2)
        return j * (nx + 1) + i

    I, J = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    I, J = I.ravel(), J.ravel()
    a, b, c, d = vid(I, J), vid(I + 1, J), vid(I + 1, J + 1), vid(I, J + 1)
    e = (nx + 1) * (ny + 1) + J * nx + I
    cells = np.vstack(
        [np.column_stack(t) for t in ((a, b, e), (b, c, e), (c, d, e), (d, a, e))]
    ).astype(np.int64)

    i = np.arange(nx)
    j = np.arange(ny)
    bottom = np.column_stack([vid(i, 0), vid(i + 1, 0)])
    top = np.column_stack([vid(i, ny), vid(i + 1, ny)])
    left = np.column_stack([vid(0, j), vid(0, j + 1)])
    right = np.column_stack([vid(nx, j), vid(nx, j + 1)])
    interface, far = (bottom, top) if upper else (top, bottom)
    ymid = 0.5 * (ys[j] + ys[j + 1])
    hit = np.abs(ymid) <= spec.impact_b
    name = "upper" if upper else "lower"
    edges = {
        f"interface_{name}": interface,
        f"impact_{name}": left[hit],
        "outer": np.vstack([far, right, left[~hit]]),
    }
    return PlateGrid(x, cells, edges)


def grid_arrays(spec: MeshSpec) -> tuple:
    """Both plates as one grid, lower plate first (numpy, no dolfinx).

    Returns (x float64[n_nodes, 2], cells int64[n_cells, 3], cell_tags
    int32[n_cells], facets int64[n_facets, 2], facet_tags int32[n_facets]);
    facets are grouped by tag in increasing tag order, lower plate before
    upper within a tag (the order a gmsh model of the grid is read back in).
    """
    lo, up = plate_grid(spec, False), plate_grid(spec, True)
    off = len(lo.x)
    x = np.vstack([lo.x, up.x])
    cells = np.vstack([lo.cells, up.cells + off])
    cell_tags = np.concatenate([np.full(len(lo.cells), TAGS["lower"]), np.full(len(up.cells), TAGS["upper"])])
    facets, facet_tags = [], []
    for name in sorted({*lo.edges, *up.edges}, key=lambda n: TAGS[n]):
        for g, shift in ((lo, 0), (up, off)):
            e = g.edges.get(name)
            if e is not None and len(e):
                facets.append(e + shift)
                facet_tags.append(np.full(len(e), TAGS[name]))
    return (x, cells.astype(np.int64), cell_tags.astype(np.int32), np.vstack(facets).astype(np.int64),
            np.concatenate(facet_tags).astype(np.int32))


def write_msh(spec: MeshSpec, path: str) -> None:
    """Write the two-plate grid as a gmsh model (.msh) with physical groups named after :data:`TAGS`."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fricfem_plates")
        offset = 0
        entity = 0
        groups: dict[str, list] = {}
        for upper in (False, True):
            g = plate_grid(spec, upper)
            tags = np.arange(1, len(g.x) + 1, dtype=np.uint64) + offset
            entity += 1
            surf = gmsh.model.addDiscreteEntity(2, entity)
            gmsh.model.mesh.addNodes(2, surf, tags, np.column_stack([g.x, np.zeros(len(g.x))]).ravel())
            gmsh.model.mesh.addElementsByType(surf, 2, [], (g.cells + 1 + offset).ravel())
            groups.setdefault("upper" if upper else "lower", []).append((2, surf))
            for name, edges in g.edges.items():
                if len(edges) == 0:
                    continue
                entity += 1
                curve = gmsh.model.addDiscreteEntity(1, entity)
                gmsh.model.mesh.addElementsByType(curve, 1, [], (edges + 1 + offset).ravel())
                groups.setdefault(name, []).append((1, curve))
            offset += len(g.x)
        for name, ents in groups.items():
            dim = ents[0][0]
            gmsh.model.addPhysicalGroup(dim, [t for _, t in ents], TAGS[name])
            gmsh.model.setPhysicalName(dim, TAGS[name], name)
        gmsh.write(path)
    finally:
        gmsh.finalize()


def bisection_parts(centroids: np.ndarray, nparts: int) -> np.ndarray:
    """int32[n]: a part per point by recursive coordinate bisection.

    Each set is cut across its longer extent so that the two halves hold
    cell counts in the ratio of the parts they get; ties are broken by the
    point's index, so the result depends on nothing but the points.  On the
    two-plate grid two parts are the two plates (the cut lies between them).
    """
    parts = np.zeros(len(centroids), dtype=np.int32)

    def split(ids, first, n):
        if n == 1 or len(ids) == 0:
            parts[ids] = first
            return
        c = centroids[ids]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        order = ids[np.lexsort((ids, c[:, axis]))]
        n1 = n // 2
        k = int(round(len(ids) * n1 / n))
        split(order[:k], first, n1)
        split(order[k:], first + n1, n - n1)

    split(np.arange(len(centroids)), 0, nparts)
    return parts


def _partitioner(centroids: np.ndarray):
    """A dolfinx cell partitioner that deals the cells by :func:`bisection_parts`
    (all cells are on the calling communicator's rank 0 when it runs), with
    ghosts on the parts that hold a facet neighbour when ghosting is asked for.
    The partition, hence every result, is the same from one run to the next."""
    import dolfinx.cpp as cpp

    def part(comm, nparts, graph, ghosting):
        n = len(graph.offsets) - 1
        if n == 0:
            return cpp.graph.AdjacencyList_int32(np.zeros(0, dtype=np.int32), np.zeros(1, dtype=np.int32))
        if n != len(centroids):
            raise RuntimeError(f"mesh: the partitioner got {n} cells, expected {len(centroids)} on one rank")
        owner = bisection_parts(centroids, nparts)
        if not ghosting:
            return cpp.graph.AdjacencyList_int32(owner, np.arange(n + 1, dtype=np.int32))
        adj, off = np.asarray(graph.array), np.asarray(graph.offsets)
        dest = [[int(o), *sorted(set(owner[adj[off[i]:off[i + 1]]].tolist()) - {int(o)})]
                for i, o in enumerate(owner)]
        counts = np.array([len(d) for d in dest], dtype=np.int32)
        return cpp.graph.AdjacencyList_int32(np.concatenate(dest).astype(np.int32),
                                             np.concatenate([[0], np.cumsum(counts)]).astype(np.int32))

    return cpp.mesh.create_cell_partitioner(part)


class PlateMesh(NamedTuple):
    """A distributed two-plate mesh and its tags."""

    mesh: object  # dolfinx.mesh.Mesh
    cell_tags: object  # dolfinx MeshTags on cells (plates)
    facet_tags: object  # dolfinx MeshTags on facets (edges), ids from TAGS
    spec: MeshSpec


def build(spec: MeshSpec, comm, msh_file: str | None = None) -> PlateMesh:
    """Build the two-plate mesh on rank 0 and distribute it over ``comm``
    (collective); the partition is deterministic (:func:`bisection_parts`).

    ``msh_file``: also write the grid there as a gmsh model (rank 0).
    """
    import dolfinx.cpp as cpp
    import dolfinx.mesh as dmesh
    from dolfinx.io import gmshio

    spec.check()
    if comm.rank == 0:
        x, cells, cell_tags, facets, facet_tags = grid_arrays(spec)
        centroids = x[cells].mean(axis=1)
        if msh_file:
            write_msh(spec, msh_file)
    else:
        x, cells, centroids = np.zeros((0, 2)), np.zeros((0, 3), dtype=np.int64), np.zeros((0, 2))
        cell_tags, facets, facet_tags = (np.zeros(0, dtype=np.int32), np.zeros((0, 2), dtype=np.int64),
                                         np.zeros(0, dtype=np.int32))
    msh = dmesh.create_mesh(comm, cells, x, gmshio.ufl_mesh(2, 2), partitioner=_partitioner(centroids))
    tdim = msh.topology.dim
    ents, vals = cpp.io.distribute_entity_data(msh._mesh, tdim, cells, cell_tags)
    msh.topology.create_connectivity(tdim, 0)
    ct = dmesh.meshtags_from_entities(msh, tdim, cpp.graph.AdjacencyList_int32(ents), vals.astype(np.int32))
    ct.name = "Cell tags"
    ents, vals = cpp.io.distribute_entity_data(msh._mesh, tdim - 1, facets, facet_tags)
    msh.topology.create_connectivity(tdim - 1, tdim)
    ft = dmesh.meshtags_from_entities(msh, tdim - 1, cpp.graph.AdjacencyList_int32(ents), vals.astype(np.int32))
    ft.name = "Facet tags"
    msh.topology.create_connectivity(1, 2)
    return PlateMesh(msh, ct, ft, spec)


def info(pm: PlateMesh) -> dict:
    """Global sizes of a built mesh (collective)."""
    from mpi4py import MPI

    msh = pm.mesh
    comm = msh.comm
    tdim = msh.topology.dim
    imap_c = msh.topology.index_map(tdim)
    imap_v = msh.topology.index_map(0)
    x = msh.geometry.x[:, :2]
    cells = msh.geometry.dofmap.array.reshape(-1, 3)[: imap_c.size_local]
    p = x[cells]
    e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)
    area = 0.5 * np.abs(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
    longest = np.linalg.norm(e, axis=2).max(axis=1)
    alt = comm.allreduce(float((2 * area / longest).min()) if len(area) else np.inf, op=MPI.MIN)
    ft = pm.facet_tags
    imap_f = msh.topology.index_map(tdim - 1)
    owned = ft.indices < imap_f.size_local

    def count(name):
        return comm.allreduce(int(np.sum(owned & (ft.values == TAGS[name]))), op=MPI.SUM)

    return {
        "cells": imap_c.size_global,
        "nodes": imap_v.size_global,
        "dofs": 2 * imap_v.size_global,
        "interface_facets": count("interface_lower"),
        "min_altitude_m": alt,
        "min_cell_m": [pm.spec.dx, pm.spec.dy],
        "area_m2": comm.allreduce(float(area.sum()), op=MPI.SUM),
        "spec": dataclasses.asdict(pm.spec),
    }
