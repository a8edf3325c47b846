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
