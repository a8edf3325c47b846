"""Point probes of nodal fields (nearest dof node), parallel-safe."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI


class NodeProbe:
    """Values of a nodal vector field at the dof nodes nearest to given points.

    Each point is served by the rank owning its nearest node; :meth:`values`
    returns the same array on every rank (collective).  On the interface the
    two plates' nodes coincide: probe points there are ambiguous.
    """

    def __init__(self, V, points):
        comm = V.mesh.comm
        n = V.dofmap.index_map.size_local
        x = V.tabulate_dof_coordinates()[:n, :2]
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        d = np.linalg.norm(x[None, :, :] - pts[:, None, :], axis=2) if n else np.full((len(pts), 1), np.inf)
        near = d.argmin(axis=1) if n else np.zeros(len(pts), dtype=int)
        dist = d[np.arange(len(pts)), near]
        best = np.array(comm.allgather(dist))  # [size, n_points]
        owner = best.argmin(axis=0)
        self.mine = np.flatnonzero(owner == comm.rank)
        self.blocks = near[self.mine]
        self.bs = V.dofmap.index_map_bs
        self.n_points = len(pts)
        self.comm = comm
        self.distance = best.min(axis=0)

    def values(self, vec, component: int) -> np.ndarray:
        out = np.zeros(self.n_points)
        out[self.mine] = vec.array_r[self.bs * self.blocks + component]
        return self.comm.allreduce(out, op=MPI.SUM)
