"""Two-plate meshes: the definition (:class:`MeshSpec`, presets in ``meshes/``)
and the distributed dolfinx mesh built from it (:func:`build`).

The grid itself is numpy (:mod:`fricfem.model.grid`); this module hands it to
dolfinx with a deterministic partition and tags its edges by name
(:data:`fricfem.model.grid.TAGS`), the only way code refers to boundaries.
"""

from __future__ import annotations

import dataclasses
import functools
import tomllib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..keys import field
from .grid import TAGS, bisection_parts, grid_arrays, write_msh

#: The folder of mesh definitions (``meshes/`` at the top of the repository).
MESH_DIR = Path(__file__).resolve().parents[2] / "meshes"


@dataclasses.dataclass(frozen=True)
class MeshSpec:
    """A two-plate mesh; lengths in metres (the geometry: :mod:`fricfem.model.grid`)."""

    length: float = field(0.137, "m", 0.0, 10.0, "plate length along the interface (x1)", open_low=True)
    height: float = field(0.075, "m", 0.0, 10.0, "height of EACH plate (x2); the specimen is twice as tall",
                          open_low=True)
    dx: float = field(0.30e-3, "m", 1e-7, 1.0, "cell size along x1 in the fine region")
    dy: float = field(0.20e-3, "m", 1e-7, 1.0, "cell size along x2 in the fine region")
    fine_x0: float = field(0.0, "m", 0.0, 10.0, "fine region start along x1")
    fine_x1: float = field(0.060, "m", 0.0, 10.0, "fine region end along x1", open_low=True)
    fine_height: float = field(2.0e-3, "m", 0.0, 10.0, "fine region extent above and below the interface",
                               open_low=True)
    impact_b: float = field(0.025, "m", 0.0, 10.0, "struck edge segment x1 = 0, |x2| <= b", open_low=True)
    grading: float = field(1.15, "", 1.0, 2.0, "cell-size growth ratio outside the fine region")
    max_size: float = field(5.0e-3, "m", 0.0, 10.0, "largest cell size", open_low=True)
    degree: int = field(1, "", 1, 8, "element degree: 1 the paper's crossed linear triangles; 2 to 8 spectral "
                        "elements (Q_p on the cells, nodes and quadrature at the GLL points; dx, dy the "
                        "element size)", kind=int)

    def grid_arrays(self) -> tuple:
        """The grid of this mesh (:func:`fricfem.model.grid.grid_arrays`); a mesh with the
        experiment's bodies has its own (:class:`fricfem.model.bodies.BodiesMesh`)."""
        return grid_arrays(self)

    def write_msh(self, path: str) -> None:
        """Write this grid as a gmsh model (:func:`fricfem.model.grid.write_msh`)."""
        write_msh(self, path)


def preset_names() -> tuple:
    """Names of the mesh definitions in ``meshes/``."""
    return tuple(sorted(p.stem for p in MESH_DIR.glob("*.toml")))


@functools.lru_cache(maxsize=None)
def _read(path: str) -> MeshSpec:
    with open(path, "rb") as fh:
        table = tomllib.load(fh)
    known = {f.name for f in dataclasses.fields(MeshSpec)}
    unknown = sorted(set(table) - known)
    if unknown:
        raise ValueError(f"mesh file {path!r}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(known))}")
    return MeshSpec(**{k: int(v) if k == "degree" else float(v) for k, v in table.items()})


def preset(ref: str) -> MeshSpec:
    """The mesh named ``ref`` in ``meshes/``, or the mesh file at the path ``ref`` (a .toml)."""
    path = Path(ref) if str(ref).endswith(".toml") else MESH_DIR / f"{ref}.toml"
    if not path.is_file():
        names = ", ".join(preset_names()) or f"(no mesh files in {MESH_DIR})"
        raise ValueError(f"mesh.preset = {str(ref)!r}: no such mesh; allowed: {names} or a path to a .toml mesh file")
    try:
        return _read(str(path.resolve()))
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise ValueError(f"mesh.preset = {str(ref)!r}: cannot read {str(path)!r}: {err}") from None


def ghost_destinations(owner, adj, off, nparts: int) -> tuple:
    """Each cell's parts: its owner first, then the other parts that own one of its
    neighbours (``adj``/``off``: CSR), increasing.  Returns (int32 parts, int32
    offsets) for dolfinx's AdjacencyList (numpy; no loop over cells)."""
    n = len(owner)
    cell = np.repeat(np.arange(n, dtype=np.int64), np.diff(off))
    nb = owner[adj]
    keep = nb != owner[cell]
    key = np.unique(cell[keep] * nparts + nb[keep])  # sorted by cell, then part
    c, o = np.divmod(key, nparts)
    offsets = np.concatenate([[0], np.cumsum(1 + np.bincount(c, minlength=n))])
    dest = np.empty(offsets[-1], dtype=np.int32)
    dest[offsets[:-1]] = owner
    dest[offsets[c] + 1 + np.arange(len(c)) - np.searchsorted(c, c)] = o
    return dest, offsets.astype(np.int32)


def _partitioner(centroids: np.ndarray):
    """A dolfinx cell partitioner that deals the cells by :func:`bisection_parts`
    (all cells are on the calling communicator's rank 0 when it runs), with
    ghosts on the parts that hold a facet neighbour when ghosting is asked for.
    The partition, hence every result, is the same from one run to the next."""
    # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py)
    from .. import compat

    def part(comm, nparts, graph, ghosting):
        n = len(graph.offsets) - 1
        if n == 0:
            return compat.adjacency_int32(np.zeros(0, dtype=np.int32), np.zeros(1, dtype=np.int32))
        if n != len(centroids):
            raise RuntimeError(f"mesh: the partitioner got {n} cells, expected {len(centroids)} on one rank")
        owner = bisection_parts(centroids, nparts)
        if not ghosting:
            return compat.adjacency_int32(owner, np.arange(n + 1, dtype=np.int32))
        dest, offsets = ghost_destinations(owner, np.asarray(graph.array), np.asarray(graph.offsets), nparts)
        return compat.adjacency_int32(dest, offsets)

    return compat.cell_partitioner(part)


class PlateMesh(NamedTuple):
    """A distributed two-plate mesh and its tags."""

    mesh: object  # dolfinx.mesh.Mesh
    cell_tags: object  # dolfinx MeshTags on cells (plates)
    facet_tags: object  # dolfinx MeshTags on facets (edges), ids from TAGS
    spec: MeshSpec


def _runs(tags: np.ndarray) -> tuple:
    """The grid's cell tags as runs: (first cell of each run, its tag); the grid
    numbers each body's cells in one run, so there are as many runs as bodies."""
    starts = np.flatnonzero(np.diff(tags, prepend=np.int32(-1)))
    return starts, tags[starts]


def _cell_tags(msh, runs: tuple) -> tuple:
    """(local cells, their tags) of every cell this rank holds, owned and ghost,
    from each cell's index in the grid (``original_cell_index``) and the runs of
    :func:`_runs`: what distributing the tags with the cells gives, without the
    all-to-all of the cells' vertices (~74 ms of the reference mesh's set-up on
    2 ranks; ``tests/test_foundation.py`` compares the two)."""
    starts, values = runs
    grid_index = np.asarray(msh.topology.original_cell_index)
    local = np.arange(len(grid_index), dtype=np.int32)
    return local, values[np.searchsorted(starts, grid_index, side="right") - 1].astype(np.int32)


def _facet_tags(msh, tagged: tuple) -> tuple:
    """(local facets, their tags) of the tagged grid facets ``tagged`` = (facets as
    pairs of grid nodes, tags) that this rank holds, owned and ghost: each local
    facet's two vertices as grid nodes (``input_global_indices`` of the geometry),
    matched against the tagged pairs.  What distributing the tags with the mesh
    gives (``tests/test_foundation.py`` compares the two); the tagged facets are the
    boundary's, a few thousand, so sending them all to every rank is cheap."""
    # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py)
    from .. import compat

    facets, tags = tagged
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, 0)
    # each topology vertex's geometry node, through the cells (same local order in both)
    c2v = msh.topology.connectivity(tdim, 0).array
    c2g = compat.geometry_dofs(msh)
    node_of = np.empty(msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts, dtype=np.int64)
    node_of[c2v] = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[c2g]
    f2v = msh.topology.connectivity(tdim - 1, 0).array.reshape(-1, 2)
    mine = np.sort(node_of[f2v], axis=1)
    want = np.sort(np.asarray(facets, dtype=np.int64), axis=1)
    n = np.int64(max(int(want.max(initial=0)), int(mine.max(initial=0))) + 1)
    key_mine, key_want = mine[:, 0] * n + mine[:, 1], want[:, 0] * n + want[:, 1]
    order = np.argsort(key_want, kind="stable")
    pos = np.minimum(np.searchsorted(key_want[order], key_mine), max(len(order) - 1, 0))
    hit = np.flatnonzero(key_want[order][pos] == key_mine) if len(order) else np.zeros(0, dtype=np.int64)
    return hit.astype(np.int32), np.asarray(tags, dtype=np.int32)[order][pos[hit]]


def build(spec: MeshSpec, comm, msh_file: str | None = None) -> PlateMesh:
    """Build the two-plate mesh on rank 0 and distribute it over ``comm``
    (collective); the partition is deterministic (:func:`bisection_parts`).

    ``msh_file``: also write the grid there as a gmsh model (rank 0).
    """
    # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py)
    from .. import compat

    if comm.rank == 0:
        x, cells, cell_tags, facets, facet_tags = spec.grid_arrays()
        centroids = x[cells].mean(axis=1)
        if msh_file:
            spec.write_msh(msh_file)
    else:
        x, cells, centroids = np.zeros((0, 2)), np.zeros((0, 3), dtype=np.int64), np.zeros((0, 2))
        cell_tags, facets, facet_tags = (np.zeros(0, dtype=np.int32), np.zeros((0, 2), dtype=np.int64),
                                         np.zeros(0, dtype=np.int32))
    msh = compat.create_mesh(comm, cells, x, compat.coordinate_element(), _partitioner(centroids))
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    ct = compat.meshtags(msh, tdim, *_cell_tags(msh, comm.bcast(_runs(cell_tags) if comm.rank == 0 else None)))
    ct.name = "Cell tags"
    msh.topology.create_connectivity(tdim - 1, tdim)
    ft = compat.meshtags(msh, tdim - 1, *_facet_tags(msh, comm.bcast((facets, facet_tags) if comm.rank == 0 else None)))
    ft.name = "Facet tags"
    msh.topology.create_connectivity(1, 2)
    return PlateMesh(msh, ct, ft, spec)


def info(pm: PlateMesh) -> dict:
    """Global sizes of a built mesh (collective)."""
    # lazy: start-up time (mpi4py initialises MPI; callers that need none load none)
    from mpi4py import MPI

    from .. import compat

    msh = pm.mesh
    comm = msh.comm
    tdim = msh.topology.dim
    imap_c = msh.topology.index_map(tdim)
    imap_v = msh.topology.index_map(0)
    x = msh.geometry.x[:, :2]
    cells = compat.geometry_dofs(msh).reshape(-1, 3)[: imap_c.size_local]
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
