"""Field output: displacement, velocity and σ1 − σ2 (prestress included) to XDMF/HDF5.

Stresses are evaluated only when a field snapshot is written (one compiled
loop over the cells, :mod:`fricfem.kernels.stress`).

Layout (crash-safe, and one time series that every XDMF reader takes whole):

- ``fields/mesh.h5`` — the mesh (dolfinx's ``/Mesh/mesh/{geometry,topology}``),
  written once;
- ``fields/tNNNN.h5`` — snapshot NNNN (``/Function/<name>/<time>``, dolfinx's
  layout and order: the nodes as in ``mesh.h5``, vectors padded to three
  components, the cells' values in the topology's order), gathered to rank 0
  and written there in one go (an HDF5 image made in memory, one plain
  write) under a temporary name, renamed when complete; dolfinx's own
  collective writer reopened the file for each function, through MPI-IO (a
  snapshot of the reference mesh on 2 ranks: 14.4 ms then, 9.0 ms with this
  layout, 2–3.5 ms of it interpolating the stress's UFL expression, which a
  numba loop over the cells now does in ~0.3 ms: :mod:`fricfem.kernels.stress`);
- ``fields.xdmf`` — one temporal collection: a grid per snapshot with the mesh
  and the functions (displacement and velocity at the nodes, σ1 − σ2 per cell
  and, for viewers, the same at the nodes: ``stress_difference_nodal``, the
  lumped L2 projection of the cells' values to P1), rewritten (temporary file,
  then renamed) after each snapshot.

What a viewer needs is written into the files themselves: every DataItem
declares ``NumberType="Float" Precision="8"`` (the geometry too: without it
XDMF readers take float32), ``Information`` elements in the Domain state the
time unit (s), each function's unit and meaning (the stress includes the
prestress, the displacement and velocity are the dynamic part only:
:data:`~.quantities.FIELD_MEANING`), and each HDF5 dataset carries ``unit`` and
``meaning`` attributes.  docs/paraview.md shows how to read them in ParaView.

So at any instant ``fields.xdmf`` lists exactly the snapshots whose files are
complete, and meshio's ``TimeSeriesReader``, VTK/pyvista and ParaView read
every function of every snapshot.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .. import compat  # noqa: I001  (mpi4py before dolfinx: fricfem/compat.py)
import ufl
from dolfinx import fem
from dolfinx.io import XDMFFile

from ..kernels import stress
from .points import shape_gradients
from .quantities import DERIVED_FIELDS, FIELD_MEANING, FIELDS

#: the folder beside ``fields.xdmf`` that holds its HDF5 files
FIELDS_DIR = "fields"
MESH_FILE = "mesh.h5"


def principal_difference(sig):
    """σ1 − σ2 of a 2×2 UFL tensor: 2 √(((σ11 − σ22)/2)² + σ12²)."""
    return 2.0 * ufl.sqrt(((sig[0, 0] - sig[1, 1]) / 2.0) ** 2 + sig[0, 1] ** 2)


def stress_with_prestress(u, material, sigma0: float, tau0: float = 0.0):
    """Total in-plane stress: the increment from ``u`` plus the uniform prestress
    S22 = −Σ0, S12 = τ0 (UFL expression)."""
    eps = ufl.sym(ufl.grad(u))
    sig = 2.0 * material.mu * eps + material.lmbda * ufl.tr(eps) * ufl.Identity(2)
    return sig + ufl.as_matrix([[0.0, tau0], [tau0, -sigma0]])


def stress_difference_ufl(u, material, sigma0: float, tau0: float = 0.0):
    """σ1 − σ2 of the total stress as a UFL expression (the reference the
    compiled :func:`fricfem.kernels.stress.stress_difference` is tested against)."""
    return principal_difference(stress_with_prestress(u, material, sigma0, tau0))


def _cell_values(modulus, n_cells: int) -> np.ndarray:
    """A modulus per cell: float64[n_cells] for a DG0 function, float64[1] for a number."""
    if isinstance(modulus, fem.Function):
        return np.ascontiguousarray(modulus.x.array[compat.cell_dofs(modulus.function_space.dofmap)[:n_cells]])
    return np.array([float(modulus)])


def stress_inputs(V, material, sigma0: float, tau0: float, n_cells: int) -> tuple:
    """What :func:`cell_stress` needs for the first ``n_cells`` cells of ``V``'s
    first-order triangle mesh: (shape gradients, the cells' node dofs, μ, λ
    [Pa], Σ0, τ0 [Pa]); ``material.mu``, ``.lmbda`` numbers or DG0 functions."""
    msh = V.mesh
    nodes = compat.geometry_dofs(msh).reshape(-1, 3)[:n_cells]
    return (shape_gradients(msh.geometry.x[nodes][:, :, :2]),
            np.ascontiguousarray(compat.cell_dofs(V.dofmap).reshape(-1, 3)[:n_cells]),
            _cell_values(material.mu, n_cells), _cell_values(material.lmbda, n_cells), float(sigma0), float(tau0))


def cell_stress(inputs: tuple, u: np.ndarray) -> np.ndarray:
    """σ1 − σ2 [Pa] of each cell of ``inputs`` (:func:`stress_inputs`) from the
    displacement dofs ``u`` (owned and ghost) [m]."""
    grad, dofs, mu, lmbda, sigma0, tau0 = inputs
    out = np.empty(len(dofs))
    stress.stress_difference(grad, dofs, u, mu, lmbda, sigma0, tau0, out)
    return out


def _space(folder: Path) -> str:
    """'; the file system is full' when it has (almost) no room left."""
    try:
        st = os.statvfs(folder)
    except OSError:
        return ""
    return "; the file system is full" if st.f_bavail * st.f_frsize < (1 << 20) else ""


def _label_units(path: Path, group: str, units: dict) -> None:
    """A ``unit`` attribute on every dataset under ``group/<name>`` of a file not yet
    renamed into place (``mesh``: the geometry's coordinates; topology is indices)."""
    # lazy: start-up time (h5py only once a file is read or written)
    import h5py

    with h5py.File(path, "r+") as f:
        for name, unit in units.items():
            for key, d in f[group][name].items():
                d.attrs["unit"] = "1 (node indices)" if key == "topology" else unit


def nodal_projection(topology: np.ndarray, points: np.ndarray):
    """What :func:`to_nodes` needs for a first-order triangle mesh (``topology``
    int[n_cells, 3] into ``points`` float[n_nodes, >= 2]): the node of each cell
    corner, each cell's area and each node's summed area."""
    p = np.asarray(points, dtype=np.float64)[:, :2]
    a, b, c = (p[topology[:, k]] for k in range(3))
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    corners = np.ascontiguousarray(topology, dtype=np.int64).reshape(-1)
    weight = np.bincount(corners, weights=np.repeat(area, 3), minlength=len(p))
    return corners, area, weight


def to_nodes(projection: tuple, cell_values: np.ndarray) -> np.ndarray:
    """Cell values (float64[n_cells]) at the nodes: the lumped L2 projection of a
    DG0 function to P1, Σ_c A_c σ_c / Σ_c A_c over the cells c around each node
    (vectorised; exact for a constant field, never outside the cells' range)."""
    corners, area, weight = projection
    summed = np.bincount(corners, weights=np.repeat(area * cell_values, 3), minlength=len(weight))
    return summed / np.where(weight > 0.0, weight, 1.0)


def _replace_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.part")
    tmp.write_text(text)
    os.replace(tmp, path)


def _mesh_xml(xdmf: Path, h5_ref: str) -> ET.Element:
    """The Topology and Geometry of a dolfinx mesh file, pointing at ``h5_ref``."""
    grid = ET.parse(xdmf).getroot().find("Domain").find("Grid")
    for item in grid.iter("DataItem"):
        item.text = h5_ref + ":" + item.text.strip().partition(":")[2]
    for item in grid.find("Geometry").iter("DataItem"):  # float64 on disk: say so (XDMF's default is float32)
        if "DataType" not in item.attrib:
            item.set("NumberType", "Float")
        item.set("Precision", "8")
    return grid


def information_xml() -> str:
    """The Domain's ``Information`` elements of ``fields.xdmf`` (indented XML text)."""
    items = [("TimeUnit", "s (Time values are seconds: multiply by 1e6 for µs; docs/paraview.md)"),
             ("Units", "SI: lengths in m, velocities in m/s, stresses in Pa"),
             ("Geometry", "x1 along the interface, x2 normal to it [m]")]
    for name, unit in {**FIELDS, **DERIVED_FIELDS}.items():
        items.append((name, f"[{unit}] {FIELD_MEANING[name]}"))
    return "".join(f"    {ET.tostring(ET.Element('Information', Name=n, Value=v), encoding='unicode')}\n"
                   for n, v in items)


class FieldWriter:
    """Write u, v and σ1 − σ2 (cell-wise, DG0) at chosen times to ``path`` (.xdmf)
    and the HDF5 files in ``fields/`` beside it (collective).  ``material``: a
    :class:`fricfem.model.material.Material`, or anything with ``mu`` and
    ``lmbda`` as numbers or DG0 functions [Pa]."""

    def __init__(self, path, V, material, sigma0: float, tau0: float = 0.0):
        msh = V.mesh
        self.comm = msh.comm
        self.path = Path(path)
        self.dir = self.path.parent / FIELDS_DIR
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self._layout(msh, V)
        self.stress_inputs = stress_inputs(V, material, sigma0, tau0, self.n_cells)  # σ1 − σ2 of the owned cells
        self.grids: list = []  # rank 0: the XML text of the grid of each written snapshot
        if self.comm.rank == 0:
            self.dir.mkdir(exist_ok=True)
        self.comm.barrier()
        mesh_xdmf = self.dir / ".mesh.xdmf"
        try:
            with XDMFFile(self.comm, str(mesh_xdmf), "w") as f:
                f.write_mesh(msh)
        except RuntimeError as err:
            raise OSError(None, f"cannot write the mesh of the field snapshots ({err}){_space(self.dir)}",
                          str(self.dir / MESH_FILE)) from None
        self.mesh_grid = None  # rank 0: the XML of the mesh's Topology and Geometry, pointing at mesh.h5
        self.projection = None  # rank 0: the mesh's cell corners and areas (σ1 − σ2 to the nodes)
        if self.comm.rank == 0:
            self.mesh_grid = ET.tostring(_mesh_xml(mesh_xdmf, f"{FIELDS_DIR}/{MESH_FILE}"), encoding="unicode")
            _label_units(self.dir / ".mesh.h5", "Mesh", {"mesh": "m"})
            # lazy: start-up time (h5py only once a file is read or written)
            import h5py

            with h5py.File(self.dir / ".mesh.h5", "r") as f:
                self.projection = nodal_projection(f["Mesh/mesh/topology"][...], f["Mesh/mesh/geometry"][...])
            os.replace(self.dir / ".mesh.h5", self.dir / MESH_FILE)
            mesh_xdmf.unlink()

    def _layout(self, msh, V) -> None:
        """Where each written value comes from, in the order dolfinx writes a
        function of a first-order mesh: this rank's owned geometry nodes (their
        value is the dof the cells map them to) and its owned cells (in their
        order); rank 0 also learns every rank's counts (collective)."""
        nodes = compat.geometry_dofs(msh)
        dofs = compat.cell_dofs(V.dofmap)
        if len(nodes) != len(dofs):
            raise ValueError("fields: the function space's cells do not match the mesh's (first order only)")
        node_dof = np.empty(msh.geometry.x.shape[0], dtype=np.int64)
        node_dof[nodes] = dofs
        self.node_dof = node_dof[: msh.geometry.index_map().size_local]
        self.n_cells = msh.topology.index_map(msh.topology.dim).size_local
        self.counts = self.comm.gather((len(self.node_dof), self.n_cells), root=0)
        self.order = None  # rank 0: (nodes, cells) in the order of a resumed run's mesh.h5 (:meth:`resume`)

    def _gathered(self, values, what: int):
        """``values`` of every rank, concatenated in rank order on rank 0 (None
        elsewhere); ``what``: 0 nodes, 1 cells (one Gatherv; collective)."""
        values = np.ascontiguousarray(values, dtype=np.float64)
        width = values.shape[1]
        if self.comm.size == 1:
            return values
        counts = [c[what] * width for c in self.counts] if self.comm.rank == 0 else None
        out = np.empty((sum(counts) // width, width)) if self.comm.rank == 0 else None
        self.comm.Gatherv(values.reshape(-1), (out, counts) if out is not None else None, root=0)
        return out

    def _nodal(self, fn):
        """A vector function's values at this rank's owned geometry nodes, padded to
        three components (as dolfinx writes 2-D vectors)."""
        out = np.zeros((len(self.node_dof), 3))
        out[:, :2] = fn.x.array.reshape(-1, 2)[self.node_dof]
        return out

    def _fill(self, fn, vec):
        fn.x.array[: self.n_owned] = vec.array_r
        fn.x.scatter_forward()

    def write(self, state) -> None:
        """Write the state's u^n, v^{n−½} and σ1 − σ2 at t^n (collective): a new
        snapshot file, then ``fields.xdmf`` listing it."""
        self._fill(self.u, state.u)
        self._fill(self.v, state.v)
        values = {"displacement": self._gathered(self._nodal(self.u), 0),
                  "velocity": self._gathered(self._nodal(self.v), 0),
                  "stress_difference": self._gathered(cell_stress(self.stress_inputs, self.u.x.array)[:, None], 1)}
        error = None
        if self.comm.rank == 0 and self.order is not None:  # the nodes and cells as the run's mesh.h5 has them
            nodes, cells = self.order
            values = {k: v[cells if k == "stress_difference" else nodes] for k, v in values.items()}
        if self.comm.rank == 0:
            try:
                self._write_snapshot(values, state.t)
            except OSError as err:
                error = err
        error = self.comm.bcast(error, root=0)
        if error is not None:
            raise error

    def _write_snapshot(self, values: dict, t: float) -> None:
        """Rank 0: the snapshot's file (temporary name, renamed when complete),
        then ``fields.xdmf`` listing it."""
        # lazy: start-up time (h5py only once a file is read or written)
        import h5py

        k = len(self.grids) + 1
        name = f"t{k:04d}.h5"
        part = self.dir / f".t{k:04d}.part.h5"
        key = f"{t:.17g}".replace(".", "_")  # dolfinx's name for the time's dataset
        # the file made in memory, then written with one plain write: a full disk is an
        # OSError of that write, not an HDF5 error at some later close
        with h5py.File(f"{name}.image", "w", driver="core", backing_store=False) as f:
            values = {**values, "stress_difference_nodal": to_nodes(self.projection, values["stress_difference"][:, 0])[:, None]}
            for fname, a in values.items():
                d = f.create_dataset(f"Function/{fname}/{key}", data=a)
                d.attrs["unit"] = {**FIELDS, **DERIVED_FIELDS}[fname]
                d.attrs["meaning"] = FIELD_MEANING[fname]
                d.attrs["time_s"] = t
            f.flush()
            image = f.id.get_file_image()
        try:
            with open(part, "wb") as out:
                out.write(image)
            os.replace(part, self.dir / name)
        except OSError as err:
            part.unlink(missing_ok=True)
            raise OSError(err.errno, f"cannot write the field snapshot at t = {t:.6g} s ({err.strerror})"
                          f"{_space(self.dir)}", str(self.dir / name)) from None
        grid = self._snapshot_grid(name, key, t, {fname: a.shape for fname, a in values.items()})
        ET.indent(grid, space="  ", level=3)
        self.grids.append("      " + ET.tostring(grid, encoding="unicode").rstrip() + "\n")
        _replace_text(self.path, self._document())

    def _snapshot_grid(self, h5_name: str, key: str, t: float, shapes: dict) -> ET.Element:
        """One grid of the time series: mesh, time, the three functions of ``h5_name``."""
        grid = ET.Element("Grid", Name=f"t{len(self.grids) + 1:04d}", GridType="Uniform")
        for child in ET.fromstring(self.mesh_grid):
            grid.append(child)
        ET.SubElement(grid, "Time", Value=repr(float(t)))
        for fname, shape in shapes.items():
            nodal = fname != "stress_difference"
            vector = fname in ("displacement", "velocity")
            att = ET.SubElement(grid, "Attribute", Name=fname, AttributeType="Vector" if vector else "Scalar",
                                Center="Node" if nodal else "Cell")
            item = ET.SubElement(att, "DataItem", Dimensions=f"{shape[0]} {shape[1]}", NumberType="Float",
                                 Precision="8", Format="HDF")
            item.text = f"{FIELDS_DIR}/{h5_name}:/Function/{fname}/{key}"
        return grid

    def _document(self) -> str:
        """``fields.xdmf``: the Domain's Information elements (time unit, each function's
        unit and meaning), then the temporal collection (its first grid is the mesh
        meshio takes).  An Attribute holds its DataItem alone: meshio refuses more."""
        return ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n  <Domain>\n' + information_xml()
                + '    <Grid Name="fields" GridType="Collection" CollectionType="Temporal">\n'
                + "".join(self.grids) + "    </Grid>\n  </Domain>\n</Xdmf>\n")

    def resume(self, grids: list, old_mesh: Path | None = None) -> None:
        """Continue a run from its checkpoint: the snapshots it had written (``grids``,
        the XML of each, as :attr:`grids` held them) are the series again; the files of
        later snapshots are removed and ``fields.xdmf`` lists those.  ``old_mesh``: the
        run's own ``mesh.h5``, set aside before this writer wrote the mesh again; when
        the nodes or cells are in another order (another rank count), it is put back
        and every later snapshot is written in its order (:attr:`order`, matched by
        coordinates), so the series stays one mesh.  Collective."""
        coords = self._coordinates()
        if self.comm.rank != 0:
            return
        if old_mesh is not None and Path(old_mesh).exists():
            # lazy: start-up time (h5py only once a file is read or written)
            import h5py

            with h5py.File(self.dir / MESH_FILE, "r") as f:
                same = np.array_equal(f["Mesh/mesh/geometry"][...], _read(old_mesh, "geometry")) and \
                    np.array_equal(f["Mesh/mesh/topology"][...], _read(old_mesh, "topology"))
            if same:
                Path(old_mesh).unlink()
            else:
                geometry, topology = _read(old_mesh, "geometry"), _read(old_mesh, "topology")
                self.order = _matching(coords, geometry, topology)
                self.projection = nodal_projection(topology, geometry)
                os.replace(old_mesh, self.dir / MESH_FILE)
        self.grids = list(grids)
        for entry in os.listdir(self.dir):
            k = entry[1:-3]
            if entry.startswith("t") and entry.endswith(".h5") and k.isdigit() and int(k) > len(self.grids):
                (self.dir / entry).unlink()
        _replace_text(self.path, self._document())

    def _coordinates(self):
        """Rank 0: the coordinates of every owned node and of every owned cell's
        vertices, in the order this writer gathers them (collective)."""
        msh = self.u.function_space.mesh
        x = msh.geometry.x[:, :2]
        nodes = np.ascontiguousarray(x[: len(self.node_dof)])
        cells = np.ascontiguousarray(x[compat.geometry_dofs(msh).reshape(-1, 3)[: self.n_cells]].reshape(-1, 6))
        return self._gathered(nodes, 0), self._gathered(cells, 1)

    def close(self) -> None:
        """Nothing stays open between snapshots; kept for the writer's contract."""


def _read(path: Path, name: str) -> np.ndarray:
    """``/Mesh/mesh/<name>`` of a mesh file."""
    # lazy: start-up time (h5py only once a file is read or written)
    import h5py

    with h5py.File(path, "r") as f:
        return f[f"Mesh/mesh/{name}"][...]


def _matching(coords: tuple, geometry: np.ndarray, topology: np.ndarray) -> tuple:
    """(nodes, cells): for each node and cell of a mesh file (``geometry``,
    ``topology``), the index of the same node (its coordinates) and the same cell
    (its vertices' coordinates, in any order) among ``coords`` (nodes [n, 2],
    cells [c, 6]: :meth:`FieldWriter._coordinates`)."""
    nodes, cells = coords

    def match(a, b):  # rows of b as indices into a, rows compared exactly
        ia, ib = np.lexsort(a.T[::-1]), np.lexsort(b.T[::-1])
        if a.shape != b.shape or not np.array_equal(a[ia], b[ib]):
            raise ValueError("fields: the mesh file's nodes or cells are not this mesh's")
        out = np.empty(len(b), dtype=np.int64)
        out[ib] = ia
        return out

    g = np.ascontiguousarray(geometry[:, :2], dtype=np.float64)
    old = g[np.asarray(topology, dtype=np.int64)]  # [c, 3, 2]
    return match(nodes, g), match(_sorted_vertices(cells.reshape(-1, 3, 2)), _sorted_vertices(old))


def _sorted_vertices(v: np.ndarray) -> np.ndarray:
    """Each cell's three vertices (v [c, 3, 2]) sorted by x1, then x2: [c, 6]."""
    by_x2 = np.take_along_axis(v, np.argsort(v[:, :, 1], axis=1, kind="stable")[:, :, None], axis=1)
    by_x1 = np.take_along_axis(by_x2, np.argsort(by_x2[:, :, 0], axis=1, kind="stable")[:, :, None], axis=1)
    return np.ascontiguousarray(by_x1.reshape(-1, 6))
