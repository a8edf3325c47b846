"""What a researcher sees, part 2 (issue 27): ParaView without surprises (float64
declared everywhere, σ1 − σ2 at the nodes, the files saying what the stress and
displacement are, a unit on every dataset of interface.h5 for every law), figure
times that are the rows' times, mode labels that say when the mesh is too coarse
for the pulses they count, fronts named by direction on unstruck runs, and the
gauge figure.

Under ``mpirun -n 2``: the runs are on both ranks; rank 0 reads and draws.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from fricfem import friction, load_scene, runner
from fricfem.output import quantities
from fricfem.output.fields import nodal_projection, to_nodes

COMM = MPI.COMM_WORLD
RANK = COMM.rank
#: a few steps of case1 on the coarse mesh: enough for every dataset to exist
TINY = ["mesh.preset='coarse'", "time.end=1e-6", "output.fields=[]"]


def _tmp(factory, name: str) -> Path:
    return Path(COMM.bcast(str(factory.mktemp(name)) if RANK == 0 else None, root=0))


def _datasets(path: Path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o.attrs.get("unit")) if isinstance(o, h5py.Dataset) else None)
    return out


@pytest.mark.parametrize("law", sorted(friction.LAWS))
def test_every_interface_dataset_has_a_unit(law, tmp_path_factory):
    """state/slip of slip weakening had unit ''; mu_app, open and regions/index too."""
    out = _tmp(tmp_path_factory, f"units_{law}")
    scene = ("rupture_sw", [*TINY]) if law == "slip_weakening" else ("case1", [*TINY, f"friction.law='{law}'"])
    runner.run_scene(load_scene(*scene), out, COMM, quiet=True)
    if RANK:
        return
    units = _datasets(out / "interface.h5")
    state = [n for n in units if n.startswith("state/")]
    assert len(state) == len(friction.LAWS[law].state)
    empty = {n: u for n, u in units.items() if not isinstance(u, str) or not u.strip()}
    assert not empty, f"{law}: datasets without a unit: {empty}"
    for n in state:
        assert units[n] == quantities.STATE_UNITS[n.split("/", 1)[1]]
    if law == "slip_weakening":
        assert units["state/slip"] == "m"


@pytest.fixture(scope="module")
def fields_run(tmp_path_factory):
    out = _tmp(tmp_path_factory, "fields")
    runner.run_scene(load_scene("case3", ["mesh.preset='coarse'", "time.end=6e-6", "output.fields=[3e-6,6e-6]"]),
                     out, COMM, quiet=True)
    return out


def test_fields_xdmf_declares_float64_and_says_what_it_holds(fields_run):
    if RANK:
        return
    root = ET.parse(fields_run / "fields.xdmf").getroot()
    items = list(root.iter("DataItem"))
    floats = [d for d in items if d.get("NumberType", "Float") == "Float"]
    assert floats and all(d.get("Precision") == "8" for d in floats)  # the geometry had no Precision: float32
    geometry = [d for g in root.iter("Geometry") for d in g.iter("DataItem")]
    assert geometry and all(d.get("Precision") == "8" and d.get("NumberType") == "Float" for d in geometry)
    info = {i.get("Name"): i.get("Value") for i in root.find("Domain").findall("Information")}
    assert info["TimeUnit"].startswith("s")
    assert "prestress included" in info["stress_difference"]
    assert "dynamic part only" in info["displacement"]
    for a in root.iter("Attribute"):  # meshio reads an Attribute holding its DataItem alone
        assert [c.tag for c in a] == ["DataItem"]
    names = {a.get("Name"): a.get("Center") for a in root.iter("Attribute")}
    assert names["stress_difference"] == "Cell" and names["stress_difference_nodal"] == "Node"
    for snap in sorted((fields_run / "fields").glob("t*.h5")):
        with h5py.File(snap, "r") as f:
            for name, group in f["Function"].items():
                for d in group.values():
                    assert d.dtype == np.float64 and d.attrs["unit"] and d.attrs["meaning"]
    assert all(u for u in _datasets(fields_run / "fields" / "mesh.h5").values())


def test_nodal_stress_is_the_area_weighted_mean_of_the_cells(fields_run):
    """The nodal σ1 − σ2 against a direct per-node average of the file's own cells."""
    if RANK:
        return
    with h5py.File(fields_run / "fields" / "mesh.h5", "r") as f:
        topo, pts = f["Mesh/mesh/topology"][...], f["Mesh/mesh/geometry"][...]
    snap = sorted((fields_run / "fields").glob("t*.h5"))[-1]
    with h5py.File(snap, "r") as f:
        cells = next(iter(f["Function/stress_difference"].values()))[:, 0]
        nodal = next(iter(f["Function/stress_difference_nodal"].values()))[:, 0]
    assert np.ptp(cells) > 1e5  # the snapshot holds a wave, not the uniform prestress alone
    p = pts[:, :2]
    area = 0.5 * np.abs(np.cross(p[topo[:, 1]] - p[topo[:, 0]], p[topo[:, 2]] - p[topo[:, 0]]))
    rng = np.random.default_rng(3)
    for node in rng.choice(len(p), 200, replace=False):
        around = np.flatnonzero((topo == node).any(axis=1))
        expect = np.sum(area[around] * cells[around]) / np.sum(area[around])
        assert nodal[node] == pytest.approx(expect, rel=1e-12, abs=1e-6)
        assert cells[around].min() - 1e-6 <= nodal[node] <= cells[around].max() + 1e-6
    # a constant field stays constant
    assert np.allclose(to_nodes(nodal_projection(topo, pts), np.full(len(topo), 7.0)), 7.0, rtol=1e-14)
