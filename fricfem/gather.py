"""Gathering distributed interface and field data onto every rank (for output and plots)."""

from __future__ import annotations

import numpy as np

#: Interface quantities exported per Gauss point (name -> attribute of ``Points``).
POINT_FIELDS = ("slip_rate", "Ts", "Tn", "rate_s", "rate_n", "jump_s", "jump_n", "slip", "is_open")


def interface_profile(interface, names=POINT_FIELDS) -> dict:
    """All ranks' interface points, sorted by x1: ``{"x1": ..., name: ...}`` (collective)."""
    comm = interface.geometry.comm
    x1 = np.concatenate(comm.allgather(interface.geometry.x1))
    order = np.argsort(x1, kind="stable")
    out = {"x1": x1[order]}
    for name in names:
        local = np.asarray(getattr(interface.points, name), dtype=np.float64)
        out[name] = np.concatenate(comm.allgather(local))[order]
    state = interface.points.state
    for k, sname in enumerate(interface.law.state):
        out[sname] = np.concatenate(comm.allgather(np.ascontiguousarray(state[:, k])))[order]
    return out


def cell_triangles(fn) -> tuple:
    """(xy float64[n_cells, 3, 2], values float64[n_cells]) of a DG0 function, all
    owned cells of all ranks (collective)."""
    msh = fn.function_space.mesh
    comm = msh.comm
    n = msh.topology.index_map(2).size_local
    cells = msh.geometry.dofmap.array.reshape(-1, 3)[:n]
    xy = msh.geometry.x[cells][:, :, :2]
    dofs = fn.function_space.dofmap.list.array.reshape(-1)[:n]
    vals = fn.x.array[dofs]
    return np.concatenate(comm.allgather(xy)), np.concatenate(comm.allgather(vals))
