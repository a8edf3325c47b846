"""The two-plate grid in numpy: node coordinates, crossed triangles, named edges.

A lower plate ``0 < x1 < length, -height < x2 < 0`` and an upper plate
``0 < x1 < length, 0 < x2 < height`` (a :class:`fricfem.model.mesh.MeshSpec`),
meshed separately so that the interface ``x2 = 0`` carries two coincident node
rows (``interface_lower`` and ``interface_upper``).  Each plate is a tensor
grid of quadrilaterals, uniform (``dx × dy``) in a fine region ``fine_x0 ≤ x1
≤ fine_x1``, ``|x2| ≤ fine_height`` and geometrically graded outside it; every
quadrilateral is split into four linear triangles through its centre node
("crossed triangles", as in the paper's finite element code).  Grid lines lie
exactly on ``x2 = ±impact_b`` so the struck segment of the edge ``x1 = 0`` is
exact.  No dolfinx here: :mod:`fricfem.model.mesh` distributes the grid.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import sem

#: Physical-group ids by name (cells: plates; facets: edges).
TAGS = {
    "lower": 1,
    "upper": 2,
    "interface_lower": 11,
    "interface_upper": 12,
    "impact_lower": 21,
    "impact_upper": 22,
    "bottom": 31,  # the lower plate's far edge, x2 = −height
    "top": 32,  # the upper plate's far edge, x2 = +height
    "right": 33,  # x1 = length, both plates
    "left": 34,  # x1 = 0 outside the struck segments, both plates
    # the experiment's steel bodies (fricfem.model.bodies): cells, and the projectile's contact faces
    "buffer": 3,
    "projectile": 4,
    "contact_buffer": 41,
    "contact_projectile": 42,
}

#: The outer edges by name (each can be made absorbing).
OUTER = ("bottom", "top", "right", "left")

#: Interface kinds: the paper's elastic interface (springs C_n, C_s at Gauss
#: points) or rigid split-node pairs.
INTERFACE_KINDS = ("elastic", "rigid")


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


def plate_axes(spec, upper: bool) -> tuple:
    """The cell (element) edges of one plate along x1 and x2, increasing."""
    xs = axis_nodes(spec.length, (spec.fine_x0, spec.fine_x1), spec.dx, spec.grading, spec.max_size, ())
    ys = axis_nodes(spec.height, (0.0, spec.fine_height), spec.dy, spec.grading, spec.max_size, (spec.impact_b,))
    if not upper:
        ys = -ys[::-1]  # lower plate: x2 from -height up to 0
    return xs, ys


def degree(spec) -> int:
    """The element degree of a mesh (``mesh.degree``; 1: crossed linear triangles)."""
    return int(spec.degree)


def plate_grid(spec, upper: bool) -> PlateGrid:
    """Build one plate's grid and its named boundary edges: crossed triangles
    (degree 1), or the GLL lattice of its spectral elements (:func:`lattice_grid`)."""
    xs, ys = plate_axes(spec, upper)
    if degree(spec) > 1:
        return lattice_grid(spec, xs, ys, upper)
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

    return PlateGrid(x, cells, _named_edges(spec, xs, ys, vid, upper))


def line_shares(edges: np.ndarray, p: int) -> np.ndarray:
    """Each edge of a node line's share of ∫ N_i ds for its two nodes,
    float64[n, 2] [m]: half its length to each (degree 1); on the GLL lattice of
    the element edges ``edges`` (p >= 2), the lattice edge between GLL points k
    and k+1 of an element of size h gives its left node w_k h/2 when k = 0 (a
    corner's weight from this element), else half of it (the other half comes
    from the edge on the node's left), and its right node likewise, so that a
    node's shares sum to its line weight ∫ l_i ds (:func:`fricfem.model.sem.lattice`)."""
    if p == 1:
        half = 0.5 * np.diff(edges)
        return np.column_stack([half, half])
    _, w = sem.gll(p)
    h = np.repeat(np.diff(edges), p)
    k = np.tile(np.arange(p), len(edges) - 1)
    left = np.where(k == 0, w[0], 0.5 * w[k]) * (0.5 * h)
    right = np.where(k == p - 1, w[p], 0.5 * w[np.minimum(k + 1, p)]) * (0.5 * h)
    return np.column_stack([left, right])


def _named_edges(spec, xs, ys, vid, upper: bool, shares=None) -> dict:
    """A plate's boundary edges by name, between neighbouring nodes of the node
    lines ``xs``, ``ys`` (``vid(i, j)``: the node at (xs[i], ys[j])); with
    ``shares`` = (float64[nx, 2], float64[ny, 2]) of :func:`line_shares` along
    each axis, each name's edges' shares too (name -> (edges, shares))."""
    nx, ny = len(xs) - 1, len(ys) - 1
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
        "top" if upper else "bottom": far,
        "right": right,
        "left": left[~hit],
    }
    if shares is None:
        return edges
    sx, sy = shares
    along = {f"interface_{name}": sx, f"impact_{name}": sy[hit], "top" if upper else "bottom": sx,
             "right": sy, "left": sy[~hit]}
    return {k: (e, along[k]) for k, e in edges.items()}


def lattice_grid(spec, xs, ys, upper: bool) -> PlateGrid:
    """One plate's GLL lattice (:func:`fricfem.model.sem.lattice`) of the spectral
    elements on the cells ``xs × ys``: its nodes, row by row along x1, and the
    carrier triangles (each lattice quadrilateral cut in two along its rising
    diagonal) that hold the nodes for dolfinx, the fields and ParaView.  The
    elements themselves: :func:`sem_elements`."""
    p = degree(spec)
    lx, _ = sem.lattice(xs, p)
    ly, _ = sem.lattice(ys, p)
    nx, ny = len(lx) - 1, len(ly) - 1
    X, Y = np.meshgrid(lx, ly, indexing="xy")
    x = np.column_stack([X.ravel(), Y.ravel()])

    def vid(i, j):
        return j * (nx + 1) + i

    I, J = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    I, J = I.ravel(), J.ravel()
    a, b, c, d = vid(I, J), vid(I + 1, J), vid(I + 1, J + 1), vid(I, J + 1)
    cells = np.vstack([np.column_stack((a, b, c)), np.column_stack((a, c, d))]).astype(np.int64)
    return PlateGrid(x, cells, _named_edges(spec, lx, ly, vid, upper))


class Elements(NamedTuple):
    """The spectral elements of a grid of degree p >= 2 (both plates, lower first,
    each plate's row by row along x1).

    nodes  int64[n, (p+1)²]  grid nodes of each element, GLL index i along x1 and
                             j along x2 at j (p+1) + i
    hx, hy float64[n]        element sizes [m]
    x2     float64[n]        x2 of the element's centre [m]
    p      int
    """

    nodes: np.ndarray
    hx: np.ndarray
    hy: np.ndarray
    x2: np.ndarray
    p: int


def sem_elements(spec) -> Elements:
    """The spectral elements of :func:`grid_arrays`' lattice (``mesh.degree`` >= 2)."""
    p = degree(spec)
    parts, offset = [], 0
    for upper in (False, True):
        xs, ys = plate_axes(spec, upper)
        ex, ey = len(xs) - 1, len(ys) - 1
        row = ex * p + 1  # lattice nodes along x1
        EX, EY = np.meshgrid(np.arange(ex), np.arange(ey), indexing="xy")
        EX, EY = EX.ravel(), EY.ravel()
        i = np.tile(np.arange(p + 1), p + 1)
        j = np.repeat(np.arange(p + 1), p + 1)
        nodes = offset + (EY[:, None] * p + j[None, :]) * row + EX[:, None] * p + i[None, :]
        hx, hy = np.diff(xs)[EX], np.diff(ys)[EY]
        parts.append((nodes, hx, hy, 0.5 * (ys[:-1] + ys[1:])[EY]))
        offset += row * (ey * p + 1)
    return Elements(*(np.concatenate([q[k] for q in parts]) for k in range(4)), p)


def facet_shares(spec) -> np.ndarray:
    """Each facet of :func:`grid_arrays` (in its order) shares ∫ N_i ds between its
    two nodes so, float64[n_facets, 2] [m] (:func:`line_shares`): on a GLL
    lattice these are the GLL weights, not half of each lattice edge."""
    p = degree(spec)
    named = {}
    for upper in (False, True):
        xs, ys = plate_axes(spec, upper)
        if p > 1:
            lx, ly = sem.lattice(xs, p)[0], sem.lattice(ys, p)[0]
        else:
            lx, ly = xs, ys
        row = len(lx)
        edges = _named_edges(spec, lx, ly, lambda i, j: j * row + i, upper,
                             (line_shares(xs, p), line_shares(ys, p)))
        for name, (_, share) in edges.items():
            named.setdefault(name, []).append(share)
    parts = [sh for name in sorted(named, key=lambda n: TAGS[n]) for sh in named[name] if len(sh)]
    return np.vstack(parts)


def grid_arrays(spec) -> tuple:
    """Both plates as one grid, lower plate first (numpy, no dolfinx).

    Returns (x float64[n_nodes, 2], cells int64[n_cells, 3], cell_tags
    int32[n_cells], facets int64[n_facets, 2], facet_tags int32[n_facets]);
    facets are grouped by tag in increasing tag order, lower plate before
    upper within a tag (the order a gmsh model of the grid is read back in).
    The plates only: a mesh with the experiment's steel bodies adds them after the
    plates (``spec.grid_arrays()``: :func:`fricfem.model.bodies.grid_arrays`).
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


def write_msh(spec, path: str) -> None:
    """Write the two-plate grid as a gmsh model (.msh) with physical groups named after :data:`TAGS`
    (the plates only; with the experiment's steel bodies: ``spec.write_msh(path)``)."""
    import gmsh  # here: gmsh only to write a .msh file (start-up: the scene imports this module)

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
