"""Every dolfinx call whose spelling depends on the dolfinx release, in one place.

fricfem runs on dolfinx 0.5.2 (Debian 12), 0.9 (Debian 13), 0.10 and 0.11
(conda, the PyPI wheel ``dolfinx-solver-real``; docs/install.md).  The rest of
fricfem (and its tests) calls these functions for the calls below and never
looks at ``dolfinx.__version__`` itself:

================================  ===========================  ==================================
what                              0.5.2                        0.9 – 0.11
================================  ===========================  ==================================
coordinate element                ``ufl.VectorElement``        ``basix.ufl.element(shape=(2,))``
function spaces                   ``fem.VectorFunctionSpace``  ``fem.functionspace``
dofmap / geometry dofmap          adjacency list ``.array``    2-D numpy array
cell partitioner                  ``(part)``; ghost mode in    ``(part, mode)``; 0.11 adds the
                                  ``create_mesh``              facet's largest cell count
``create_mesh``                   ``(comm, cells, x, e)``      0.11: ``(comm, cells, e, x)``
================================  ===========================  ==================================

``from mpi4py import MPI`` comes before dolfinx here: the PyPI wheel's dolfinx
finds its MPI library (libmpi.so.12) only once mpi4py has loaded it.  Modules
that import dolfinx at their top import this module first.
"""

from __future__ import annotations

import inspect

import numpy as np
from mpi4py import MPI  # noqa: F401  (before dolfinx; see above)

import dolfinx  # noqa: I001
import dolfinx.cpp as _cpp
import dolfinx.mesh as _dmesh
import ufl
from dolfinx import fem as _fem

#: dolfinx's (major, minor) release, e.g. (0, 5) or (0, 11).
VERSION = tuple(int(p) for p in dolfinx.__version__.split(".")[:2])
#: 0.5/0.6: legacy UFL elements, ``.array`` on dofmaps, ghost mode given to create_mesh.
LEGACY = VERSION < (0, 7)

#: the ghosting of every fricfem mesh (a layer of cells sharing a facet)
GHOST_MODE = _dmesh.GhostMode.shared_facet


def coordinate_element():
    """The coordinate element of first-order triangles in the plane, as
    ``create_mesh`` takes it (what ``dolfinx.io.gmshio.ufl_mesh(2, 2)`` gives,
    without importing gmsh)."""
    if LEGACY:
        cell = ufl.Cell("triangle", geometric_dimension=2)
        return ufl.Mesh(ufl.VectorElement(ufl.FiniteElement("Lagrange", cell, 1, variant="equispaced")))
    # here: the newer dolfinx API only (the LEGACY dolfinx 0.5 path above has none of it)
    import basix
    import basix.ufl

    return ufl.Mesh(basix.ufl.element("Lagrange", "triangle", 1, lagrange_variant=basix.LagrangeVariant.equispaced,
                                      shape=(2,), dtype=np.float64))


def cell_partitioner(part):
    """A cell partitioner for :func:`create_mesh` from a graph partitioner
    ``part(comm, nparts, local_graph, ghosting) -> AdjacencyList_int32`` (each
    cell's destination ranks, owner first), ghosted as :data:`GHOST_MODE`."""
    if LEGACY:
        return _cpp.mesh.create_cell_partitioner(part)
    try:  # 0.10/0.11: and at most two cells share a facet
        return _cpp.mesh.create_cell_partitioner(part, GHOST_MODE, 2)
    except TypeError:  # 0.7-0.9
        return _cpp.mesh.create_cell_partitioner(part, GHOST_MODE)


def adjacency_int32(data, offsets):
    """A dolfinx int32 adjacency list (what a graph partitioner returns)."""
    return _cpp.graph.AdjacencyList_int32(np.asarray(data, dtype=np.int32), np.asarray(offsets, dtype=np.int32))


def create_mesh(comm, cells, x, element, partitioner):
    """``dolfinx.mesh.create_mesh`` with a partitioner, cells ghosted as :data:`GHOST_MODE`."""
    names = list(inspect.signature(_dmesh.create_mesh).parameters)
    if LEGACY:
        return _dmesh.create_mesh(comm, cells, x, element, ghost_mode=GHOST_MODE, partitioner=partitioner)
    if names.index("x") < names.index("e"):
        return _dmesh.create_mesh(comm, cells, x, element, partitioner=partitioner)
    return _dmesh.create_mesh(comm, cells, element, x, partitioner=partitioner)


def meshtags(msh, dim: int, entities, values):
    """Mesh tags on the sorted local entities ``entities`` of dimension ``dim``."""
    return _dmesh.meshtags(msh, dim, np.asarray(entities, dtype=np.int32), np.asarray(values, dtype=np.int32))


def distributed_meshtags(msh, dim: int, entities, values):
    """Mesh tags as dolfinx itself distributes them with a mesh (the reference
    fricfem's own tags are tested against): ``entities`` (grid vertex indices,
    one row an entity) and ``values`` on rank 0, sent to the ranks that hold them
    (``distribute_entity_data``) and looked up (``meshtags_from_entities``)."""
    entities = np.asarray(entities, dtype=np.int64)
    values = np.asarray(values, dtype=np.int32)
    msh.topology.create_connectivity(dim, 0)
    if LEGACY:
        ents, vals = _cpp.io.distribute_entity_data(msh._mesh, dim, entities, values)
        return _dmesh.meshtags_from_entities(msh, dim, _cpp.graph.AdjacencyList_int32(ents), vals.astype(np.int32))
    # here: the newer dolfinx API only (the LEGACY dolfinx 0.5 path above has none of it)
    import dolfinx.graph
    from dolfinx.io.utils import distribute_entity_data

    msh.topology.create_connectivity(dim, msh.topology.dim)
    ents, vals = distribute_entity_data(msh, dim, entities, values)
    adj = dolfinx.graph.adjacencylist(np.ascontiguousarray(ents, dtype=np.int32))
    return _dmesh.meshtags_from_entities(msh, dim, adj, np.asarray(vals, dtype=np.int32))


def function_space(msh, family: str, degree: int, shape: tuple | None = None):
    """The function space of ``family`` and ``degree`` on ``msh``: scalar, or of
    values of ``shape`` (``(2,)``: a plane vector field)."""
    if LEGACY:
        if shape:
            return _fem.VectorFunctionSpace(msh, (family, degree), dim=shape[0])
        return _fem.FunctionSpace(msh, (family, degree))
    return _fem.functionspace(msh, (family, degree, shape) if shape else (family, degree))


def cell_dofs(dofmap):
    """Each local cell's dofs (blocks, for a blocked space) of a function space's
    ``dofmap``, int32, flat (cell after cell)."""
    lst = dofmap.list
    return np.asarray(lst.array if LEGACY else lst).reshape(-1)


def geometry_dofs(msh):
    """Each local cell's geometry nodes (rows of ``msh.geometry.x``), int32, flat (cell after cell)."""
    g = msh.geometry
    if LEGACY:
        return np.asarray(g.dofmap.array).reshape(-1)
    dms = getattr(g, "dofmaps", None)  # 0.10/0.11: one per cell type (``dofmap`` deprecated)
    return np.asarray(dms[0] if isinstance(dms, (list, tuple)) else g.dofmap).reshape(-1)


def interpolation_points(V):
    """The reference points at which ``V``'s element interpolates (for ``fem.Expression``)."""
    pts = V.element.interpolation_points
    return pts() if callable(pts) else pts
