"""Field output: displacement, velocity and σ1 − σ2 (prestress included) to XDMF/HDF5.

Stresses are evaluated only when a field snapshot is written: a run that asks
for no fields never compiles or evaluates the stress expression.

Layout (crash-safe, and one time series that every XDMF reader takes whole):

- ``fields/mesh.h5`` — the mesh (dolfinx's ``/Mesh/mesh/{geometry,topology}``),
  written once;
- ``fields/tNNNN.h5`` — snapshot NNNN (``/Function/<name>/<time>``), written by
  dolfinx under a temporary name and renamed when complete;
- ``fields.xdmf`` — one temporal collection: a grid per snapshot with the mesh
  and the three functions (displacement and velocity at the nodes, σ1 − σ2
  per cell), rewritten (temporary file, then renamed) after each snapshot.

So at any instant ``fields.xdmf`` lists exactly the snapshots whose files are
complete, and meshio's ``TimeSeriesReader``, VTK/pyvista and ParaView read
every function of every snapshot.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import ufl
from dolfinx import fem
from dolfinx.io import XDMFFile

from .quantities import FIELDS

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
    import h5py

    with h5py.File(path, "r+") as f:
        for name, unit in units.items():
            for key, d in f[group][name].items():
                d.attrs["unit"] = "" if key == "topology" else unit


def _replace_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.part")
    tmp.write_text(text)
    os.replace(tmp, path)


def _mesh_xml(xdmf: Path, h5_ref: str) -> ET.Element:
    """The Topology and Geometry of a dolfinx mesh file, pointing at ``h5_ref``."""
    grid = ET.parse(xdmf).getroot().find("Domain").find("Grid")
    for item in grid.iter("DataItem"):
        item.text = h5_ref + ":" + item.text.strip().partition(":")[2]
    return grid


class FieldWriter:
    """Write u, v and σ1 − σ2 (cell-wise, DG0) at chosen times to ``path`` (.xdmf)
    and the HDF5 files in ``fields/`` beside it (collective)."""

    def __init__(self, path, V, material, sigma0: float, tau0: float = 0.0):
        msh = V.mesh
        self.comm = msh.comm
        self.path = Path(path)
        self.dir = self.path.parent / FIELDS_DIR
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        W = fem.FunctionSpace(msh, ("DG", 0))
        self.s = fem.Function(W, name="stress_difference")
        expr = principal_difference(stress_with_prestress(self.u, material, sigma0, tau0))
        self.expr = fem.Expression(expr, W.element.interpolation_points())
        self.n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
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
        self.mesh_text = None
        if self.comm.rank == 0:
            self.mesh_text = mesh_xdmf.read_text()
            _label_units(self.dir / ".mesh.h5", "Mesh", {"mesh": "m"})
            os.replace(self.dir / ".mesh.h5", self.dir / MESH_FILE)
            mesh_xdmf.unlink()

    def _fill(self, fn, vec):
        fn.x.array[: self.n_owned] = vec.array_r
        fn.x.scatter_forward()

    def write(self, state) -> None:
        """Write the state's u^n, v^{n−½} and σ1 − σ2 at t^n (collective): a new
        snapshot file, then ``fields.xdmf`` listing it."""
        self._fill(self.u, state.u)
        self._fill(self.v, state.v)
        self.s.interpolate(self.expr)
        k = len(self.grids) + 1 if self.comm.rank == 0 else 0
        k = self.comm.bcast(k, root=0)
        part = self.dir / f".t{k:04d}.part.xdmf"
        if self.comm.rank == 0:  # the mesh first, as dolfinx expects, pointing at mesh.h5
            part.write_text(self.mesh_text.replace(".mesh.h5:", f"{MESH_FILE}:"))
        self.comm.barrier()
        try:
            with XDMFFile(self.comm, str(part), "a") as f:
                for fn in (self.u, self.v, self.s):
                    f.write_function(fn, state.t)
        except RuntimeError as err:  # dolfinx says only that HDF5 failed: say where, and why if it is space
            raise OSError(None, f"cannot write the field snapshot at t = {state.t:.6g} s ({err}){_space(self.dir)}",
                          str(part.with_suffix(".h5"))) from None
        if self.comm.rank == 0:
            name = f"t{k:04d}.h5"
            _label_units(part.with_suffix(".h5"), "Function", FIELDS)
            os.replace(part.with_suffix(".h5"), self.dir / name)
            grid = self._snapshot_grid(part, name, state.t)
            ET.indent(grid, space="  ", level=3)
            self.grids.append("      " + ET.tostring(grid, encoding="unicode").rstrip() + "\n")
            part.unlink()
            _replace_text(self.path, self._document())

    def _snapshot_grid(self, part: Path, h5_name: str, t: float) -> ET.Element:
        """One grid of the time series: mesh, time, the three functions of ``part``."""
        root = ET.parse(part).getroot()
        grid = ET.Element("Grid", Name=f"t{len(self.grids) + 1:04d}", GridType="Uniform")
        mesh = _mesh_xml(part, f"{FIELDS_DIR}/{MESH_FILE}")
        for child in mesh:
            grid.append(child)
        ET.SubElement(grid, "Time", Value=repr(float(t)))
        for att in root.iter("Attribute"):
            item = att.find("DataItem")
            item.text = f"{FIELDS_DIR}/{h5_name}:" + item.text.strip().partition(":")[2]
            item.set("Precision", "8")
            grid.append(att)
        return grid

    def _document(self) -> str:
        """``fields.xdmf``: the temporal collection (its first grid is the mesh meshio takes)."""
        return ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n  <Domain>\n'
                '    <Grid Name="fields" GridType="Collection" CollectionType="Temporal">\n'
                + "".join(self.grids) + "    </Grid>\n  </Domain>\n</Xdmf>\n")

    def close(self) -> None:
        """Nothing stays open between snapshots; kept for the writer's contract."""
