"""The grid's own numbering, the same on any number of ranks.

dolfinx numbers dofs by rank and orders cells locally, so sums assembled
through it (a stiffness entry over its cells, a node's mass, an interface
node's forces from two segments) run in an order that depends on the
partition, and results then differ in the last bits between 1 and N ranks.
fricfem sums in the order of its grid (:mod:`.grid`: nodes and cells numbered
the same way on every rank, rebuilt on each rank in milliseconds), and maps
each of this rank's dof blocks to its grid node through
``geometry.input_global_indices``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import grid


class Numbering(NamedTuple):
    """This rank's dofs against the grid.

    x             float64[n_grid, 2]  grid node coordinates [m] (bit-identical on every rank)
    cells         int64[n_cells, 3]   the grid's triangles, counter-clockwise
    facets        int64[n_facets, 2]  tagged boundary edges; ``facet_tags`` int32[n_facets]
    node_of_block int64[n_local]      grid node of each local dof block (owned, then ghosts)
    n_owned       int                 owned dof blocks
    block_of_node int64[n_grid]       this rank's local block of a grid node, or −1
    global_block  int64[n_grid]       PETSc global block index of every grid node
    elements      the spectral elements (:class:`fricfem.model.grid.Elements`) of a
                  grid of degree >= 2, whose ``cells`` are then the lattice's carrier
                  triangles (fields, gauges); None for the crossed triangles
    facet_share   float64[n_facets, 2]  each facet's share of ∫ N_i ds for its two
                  nodes (:func:`fricfem.model.grid.facet_shares`); None: half its length
    """

    x: np.ndarray
    cells: np.ndarray
    facets: np.ndarray
    facet_tags: np.ndarray
    node_of_block: np.ndarray
    n_owned: int
    block_of_node: np.ndarray
    global_block: np.ndarray
    elements: object = None
    facet_share: np.ndarray | None = None

    @property
    def owned_nodes(self) -> np.ndarray:
        """Grid nodes of the owned blocks, in local block order."""
        return self.node_of_block[: self.n_owned]


def numbering(pm, V) -> Numbering:
    """The numbering of the distributed mesh ``pm`` and its P1 vector space ``V``
    (collective: one allgather of the owned blocks' global indices)."""
    # lazy: start-up time (it loads mpi4py, dolfinx, petsc4py)
    from .. import compat

    x, cells, _, facets, facet_tags = pm.spec.grid_arrays()
    msh = pm.mesh
    imap = V.dofmap.index_map
    n_local = imap.size_local + imap.num_ghosts
    dof_cells = compat.cell_dofs(V.dofmap).reshape(-1, 3)
    geo_cells = compat.geometry_dofs(msh).reshape(-1, 3)
    node = np.full(n_local, -1, dtype=np.int64)
    node[dof_cells.ravel()] = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[geo_cells.ravel()]
    if (node < 0).any():
        raise RuntimeError("numbering: a dof block is in no cell")
    block_of_node = np.full(len(x), -1, dtype=np.int64)
    block_of_node[node] = np.arange(n_local)
    n_owned = imap.size_local
    start = imap.local_range[0]
    parts = msh.comm.allgather(np.column_stack([node[:n_owned], start + np.arange(n_owned)]))
    pairs = np.vstack(parts)
    global_block = np.full(len(x), -1, dtype=np.int64)
    global_block[pairs[:, 0]] = pairs[:, 1]
    if (global_block < 0).any():
        raise RuntimeError("numbering: a grid node is owned by no rank")
    elements = share = None
    if grid.degree(pm.spec) > 1:
        elements, share = grid.sem_elements(pm.spec), grid.facet_shares(pm.spec)
        for a in (*elements[:4], share):
            a.setflags(write=False)
    return Numbering(x, cells, facets, facet_tags, node, n_owned, block_of_node, global_block, elements, share)
