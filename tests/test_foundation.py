"""Bulk + elastic interface physics: wave speed, energy balance, symmetry, 1 vs 2 ranks, meshes."""

from __future__ import annotations


import numpy as np
import pytest
from mpi4py import MPI

from fricfem import friction
from fricfem import load_scene
from fricfem.model import grid, mesh
from fricfem.scene import SceneError
from fricfem.step import State
from fricfem.step import evolve
from fricfem.model import build as build_mod
from fricfem.model.loading import ImpactPulse
from fricfem.model.material import Material
from probe import NodeProbe

STUCK = friction.get_law("stuck")
CN, CS = 3e11, 1e11  # Pa/m (docs/model.md: 0.3 and 0.1 MPa/µm)

_MESHES: dict = {}


def plates(name: str, comm):
    """Build (once per communicator kind) a preset mesh."""
    key = (name, comm.size)
    if key not in _MESHES:
        _MESHES[key] = mesh.build(mesh.preset(name), comm)
    return _MESHES[key]


def stuck_model(pm, v_imp=5.0, sigma0=10e6, impact=("impact_lower",), t_rise=10e-6, dt=None):
    return build_mod.build(pm, Material(), ImpactPulse(v_imp=v_imp, t_rise=t_rise), STUCK, np.zeros(0),
                        sigma0, CN, CS, impact_tags=impact, dt=dt)


def run(model, t_end, energy_every=0, each=None):
    state = State(model)
    last = None
    for st, e in evolve(model, state, t_end, energy_every):
        if e:
            last = e
        if each is not None:
            each(st)
    return state, last


def test_longitudinal_front_travels_at_cl(comm):
    """The first arrival (|v1| > 1 % of V_imp) along x2 = −12.5 mm, the middle of
    the struck segment, moves at c_l (plane stress) within 2 %."""
    pm = plates("reference", comm)
    model = stuck_model(pm, t_rise=2e-6)
    xs = np.array([10e-3, 20e-3, 30e-3, 40e-3])
    probe = NodeProbe(model.V, np.column_stack([xs, np.full_like(xs, -12.5e-3)]))
    arrival = np.full(len(xs), np.nan)

    def watch(st):
        v1 = np.abs(probe.values(st.v, 0))
        hit = np.isnan(arrival) & (v1 > 0.01 * 5.0)
        arrival[hit] = st.t - 0.5 * model.dt  # v is at the half step

    run(model, 25e-6, each=watch)
    assert not np.isnan(arrival).any()
    speed = np.polyfit(arrival, xs, 1)[0]
    c_l = Material().c_l
    assert abs(speed / c_l - 1.0) < 0.02, (speed, c_l, arrival)


def test_energy_balance_with_stuck_interface(comm):
    """Kinetic + strain + interface-elastic energy = work of the struck edge (< 1 %)."""
    pm = plates("coarse", comm)
    model = stuck_model(pm, v_imp=5.0)
    _, e = run(model, 60e-6, energy_every=50)
    assert e["external"] > 0
    stored = e["kinetic"] + e["strain"] + e["interface_elastic"]
    assert abs(stored - e["external"]) < 0.01 * e["external"], e
    # for a stuck interface the interface work is all elastic
    assert abs(e["interface_work"] - e["interface_elastic"]) < 1e-3 * e["external"]
    assert e["dissipated"] == 0.0


def test_symmetric_loading_no_shear_jump(comm):
    """Both plates struck alike: the mirror-symmetric mesh keeps Δu_s at round-off."""
    pm = plates("coarse", comm)
    model = stuck_model(pm, v_imp=5.0, impact=("impact_lower", "impact_upper"))
    state, _ = run(model, 30e-6)
    p = state.points
    js = comm.allreduce(float(np.abs(p.jump_s).max(initial=0.0)), op=MPI.MAX)
    umax = comm.allreduce(float(np.abs(state.u.array_r).max()), op=MPI.MAX)
    assert umax > 1e-6
    assert js <= 1e-12 * umax, (js, umax)


def _fields(model, state, pm):
    """(keys, values) of every owned node: key = (x1, x2, plate), value = (u1, u2, v1, v2)."""
    from dolfinx import fem

    V = model.V
    n = V.dofmap.index_map.size_local
    upper_cells = pm.cell_tags.indices[pm.cell_tags.values == mesh.TAGS["upper"]]
    pm.mesh.topology.create_connectivity(2, 2)  # dolfinx >= 0.7 looks the cells' dofs up through it
    upper = fem.locate_dofs_topological(V, 2, upper_cells)
    plate = np.zeros(n)
    plate[upper[upper < n]] = 1.0
    x = V.tabulate_dof_coordinates()[:n, :2]
    keys = np.column_stack([x, plate])
    vals = np.column_stack([state.u.array_r.reshape(-1, 2), state.v.array_r.reshape(-1, 2)])
    return keys, vals


def _sorted_global(comm, keys, vals):
    keys = np.vstack(comm.allgather(keys))
    vals = np.vstack(comm.allgather(vals))
    order = np.lexsort((np.round(keys[:, 1], 12), np.round(keys[:, 0], 12), keys[:, 2]))
    return keys[order], vals[order]


def test_one_rank_equals_two_ranks(comm):
    """The same run on COMM_SELF and on COMM_WORLD gives the same fields (≤ 1e-10)."""
    runs = {}
    for name, c in (("self", MPI.COMM_SELF), ("world", comm)):
        pm = plates("coarse", c)
        model = stuck_model(pm, v_imp=5.0)
        state, _ = run(model, 30e-6)
        keys, vals = _sorted_global(c, *_fields(model, state, pm))
        p = state.points
        x1 = np.concatenate(c.allgather(model.interface.geometry.x1))
        ts = np.concatenate(c.allgather(p.Ts))[np.argsort(x1, kind="stable")]
        runs[name] = (model.dt, keys, vals, ts)
    dt1, k1, v1, t1 = runs["self"]
    dt2, k2, v2, t2 = runs["world"]
    assert dt1 == dt2
    assert np.array_equal(k1, k2)
    assert np.abs(v1 - v2).max() <= 1e-10 * np.abs(v1).max()
    assert np.abs(t1 - t2).max() <= 1e-10 * np.abs(t1).max()


def _tag_lengths(pm):
    msh = pm.mesh
    comm = msh.comm
    ft = pm.facet_tags
    n_owned = msh.topology.index_map(1).size_local
    f2v = msh.topology.connectivity(1, 0)
    x = msh.geometry.x
    out = {}
    for name in ("interface_lower", "interface_upper", "impact_lower", "impact_upper", "bottom", "top", "right", "left"):
        facets = ft.indices[(ft.values == mesh.TAGS[name]) & (ft.indices < n_owned)]
        length = sum(np.linalg.norm(x[f2v.links(f)[0]] - x[f2v.links(f)[1]]) for f in facets)
        out[name] = comm.allreduce(length, op=MPI.SUM)
    return out


def test_mesh_presets_and_tags(comm):
    """Documented preset sizes; tags cover exactly the intended edges."""
    pm = plates("reference", comm)
    msh = pm.mesh
    msh.topology.create_connectivity(1, 0)
    info = mesh.info(pm)
    assert info["cells"] == 4 * 17784
    assert info["interface_facets"] == 228
    assert info["dofs"] == 72208
    assert abs(info["min_altitude_m"] - 0.1e-3) < 1e-12
    L = _tag_lengths(pm)
    spec = pm.spec
    assert L["interface_lower"] == pytest.approx(spec.length, rel=1e-12)
    assert L["interface_upper"] == pytest.approx(spec.length, rel=1e-12)
    assert L["impact_lower"] == pytest.approx(0.025, rel=1e-12)
    assert L["impact_upper"] == pytest.approx(0.025, rel=1e-12)
    perimeter = 2 * 2 * (spec.length + spec.height)
    outer = L["bottom"] + L["top"] + L["right"] + L["left"]
    assert outer == pytest.approx(perimeter - 2 * spec.length - 2 * 0.025, rel=1e-12)
    assert L["bottom"] == L["top"] == pytest.approx(spec.length, rel=1e-12)
    assert L["right"] == pytest.approx(2 * spec.height, rel=1e-12)
    # the fine region is uniform 0.30 × 0.20 mm and the other presets have their sizes
    x = grid.axis_nodes(spec.length, (0.0, spec.fine_x1), spec.dx, spec.grading, spec.max_size, ())
    assert np.allclose(np.diff(x[x <= 0.060 + 1e-12]), 0.3e-3)
    sizes = {"coarse": 1200, "reference": 17784, "half": 33696, "fine": 90396}
    for name, quads in sizes.items():
        assert len(mesh.preset(name).grid_arrays()[1]) == 4 * quads  # four triangles a quadrilateral


@pytest.mark.parametrize("scene", ["case1", "experiment_42"])
def test_tags_are_dolfinx_distributing_them(comm, scene):
    """Each rank's cell and facet tags, taken from its cells' grid indices and its
    facets' grid nodes, are those dolfinx's distribute_entity_data sends with the
    mesh: the plates, and the experiment's steel bodies, on 1 and 2 ranks (also
    checked by hand on 3 and 4 ranks, where cells are ghosted).  The experiment's
    grid has four cell tags (two plates, buffer, projectile)."""
    from rankcheck import comms

    from fricfem import compat

    spec = load_scene(scene, ["mesh.preset='coarse'"]).mesh
    for where, c in comms(comm):
        pm = mesh.build(spec, c)
        if c.rank == 0:
            _, cells, tags, facets, facet_tags = spec.grid_arrays()
        else:
            cells, tags = np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int32)
            facets, facet_tags = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int32)
        for dim, mine, ent, val in ((2, pm.cell_tags, cells, tags), (1, pm.facet_tags, facets, facet_tags)):
            ref = compat.distributed_meshtags(pm.mesh, dim, ent, val)
            seen = set().union(*c.allgather(set(ref.values.tolist())))  # one plate a rank on 2 ranks
            assert seen == c.bcast(set(val.tolist())), (where, dim)  # every tag of the grid is held somewhere
            assert np.array_equal(mine.indices, ref.indices), (where, dim)
            assert np.array_equal(mine.values, ref.values), (where, dim)


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(dx=-1.0), "mesh.dx"),
        (dict(fine_x1=0.2), "mesh.fine_x0"),
        (dict(fine_height=0.1), "mesh.fine_height"),
        (dict(impact_b=0.08), "mesh.impact_b"),
        (dict(grading=3.0), "mesh.grading"),
        (dict(max_size=1e-5), "mesh.max_size"),
        (dict(dx=1e-6, dy=1e-6), "at most 5e6"),
    ],
)
def test_bad_mesh_spec_is_named(change, message):
    """Each bad mesh value is refused by the scene's validation, naming the key."""
    with pytest.raises(SceneError, match=message.replace(".", r"\.")):
        load_scene("case1", [f"mesh.{k}={v!r}" for k, v in change.items()])


def test_error_on_every_rank_is_raised_on_every_rank(comm, tmp_dir_shared):
    """A run whose set-up fails alike on every rank (a library's error, here the
    build) raises that error on every rank, as on one rank, instead of ending the
    job with MPI_Abort (which took pytest, and its report, with it)."""
    from fricfem.runner import run_scene

    scene = load_scene("case1", ["mesh.preset='coarse'"])

    def failing_build(scene, comm):
        raise TypeError("a dolfinx call with a keyword this release does not know")

    with pytest.raises(TypeError, match="this release does not know"):
        run_scene(scene, tmp_dir_shared / "run", comm, quiet=True, build=failing_build)
    assert comm.allreduce(1) == comm.size  # every rank is still here, in step


def test_python_m_fricfem_is_the_fricfem_command(comm, tmp_path):
    """``python -m fricfem`` (no ``fricfem`` script on PATH: conda, the wheel) runs
    the command: ``show`` prints a scene that loads back to the same Scene."""
    import os
    import subprocess
    import sys
    import tomllib

    if comm.rank != 0:
        return
    # a child of an mpirun rank must not take the rank's MPI job for its own
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PMI_", "PRTE_", "HYDRA_"))}
    res = subprocess.run([sys.executable, "-m", "fricfem", "show", "case3"], capture_output=True, text=True,
                         env=env, timeout=300)
    assert res.returncode == 0, res.stderr
    assert tomllib.loads(res.stdout)["loading"]["v_imp"] == 20.0  # case3: V_imp = 20 m/s
    (tmp_path / "shown.toml").write_text(res.stdout)
    assert load_scene(str(tmp_path / "shown.toml")) == load_scene("case3")
    res = subprocess.run([sys.executable, "-m", "fricfem", "show", "no_such_scene"], capture_output=True,
                         text=True, env=env, timeout=300)
    assert res.returncode != 0 and "no_such_scene" in res.stderr


def test_version_specific_dolfinx_calls_are_in_compat_only():
    """Every dolfinx call that differs between 0.5.2, 0.9, 0.10 and 0.11 goes
    through fricfem/compat.py: no other module spells one (a module that did would
    run on one release only)."""
    import re
    from pathlib import Path

    root = Path(mesh.__file__).resolve().parents[1]
    spelled = re.compile(r"VectorFunctionSpace|fem\.FunctionSpace\(|fem\.functionspace\(|dofmap\.array|list\.array"
                         r"|create_cell_partitioner|(?<!compat)\.create_mesh\(|ufl\.(Vector|Finite)Element|basix\.ufl"
                         r"|_cpp_object|mesh\._mesh\b|dolfinx\.__version__ *[<>=]")
    offenders = [f"{p.relative_to(root)}:{i}" for p in sorted(root.rglob("*.py")) if p.name != "compat.py"
                 for i, line in enumerate(p.read_text().splitlines(), 1) if spelled.search(line.split("#")[0])]
    assert not offenders, offenders
