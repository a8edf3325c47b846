"""Line gauges kept in memory (:class:`LineGauges`): the experiment's strain
gauges along node lines of the lower plate, the struck edge's velocities and,
with the experiment's bodies, the projectile's velocity and contact force.
Their nodes' values reach rank 0 as the point gauges' do (:class:`.points.NodeValues`).
"""

from __future__ import annotations

import numpy as np

from ..kernels.reduce import dot
from .points import NodeValues


def _lower_nodes(num) -> np.ndarray:
    """bool[n_grid]: grid nodes of cells whose centroid lies below the interface."""
    below = num.x[num.cells].mean(axis=1)[:, 1] < 0.0
    mark = np.zeros(len(num.x), dtype=bool)
    mark[np.unique(num.cells[below])] = True
    return mark


def line_nodes(num, lower: np.ndarray, X: float, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The nodes of ``lower`` on the node line x1 = X with a ≤ x2 ≤ b and their
    weights ∫N_i ds along it [m] (nodes at one position share its weight)."""
    idx = np.flatnonzero(lower & (num.x[:, 0] == X) & (num.x[:, 1] >= a) & (num.x[:, 1] <= b))
    ys, at = np.unique(num.x[idx, 1], return_inverse=True)
    w = np.zeros(len(ys))
    d = np.diff(ys)
    w[:-1] += 0.5 * d
    w[1:] += 0.5 * d
    return idx, w[at]


class LineGauges:
    """Gauges along segments of the lower plate, the buffer and the projectile,
    recorded after every step (a runner's ``on_step``) and kept in memory: what a
    strain gauge or a velocity probe on the specimen would record, and, for a
    model with the experiment's bodies (:mod:`fricfem.model.bodies`), the
    projectile's mean velocity and contact force.

    ``lines`` {name: (X, x2_min, x2_max, h)} [m]: the segment x1 = X (the nearest
    node line), x2_min ≤ x2 ≤ x2_max, gives ``name.v1``, the mean x1 velocity over
    its nodes, each weighted by its share of the segment (∫N_i ds), and
    ``name.eps11`` = (ū1(X + h) − ū1(X − h))/(2h), the same means of u1 on the
    neighbouring node lines (a strain gauge of length 2h across the segment).
    With bodies: ``projectile.v1`` = Σ M v1 / Σ M and ``contact_force`` [N/m],
    the force the contact presses it with, at the interface time t^n.
    Velocities are v^{n+½} (``t_v``), displacements u^{n+1} (``t_u``).  Only
    nodes of cells below the interface count, so the upper plate's interface
    node is never mixed in.  The nodes' values come to rank 0 through
    :class:`NodeValues` (exact, the same on any number of ranks)."""

    def __init__(self, model, lines: dict):
        self.model = model
        num = model.num
        lower = _lower_nodes(num)
        xs = np.unique(num.x[lower, 0])  # the node lines x1 = const below the interface
        nodes, weights, self.names, self.dx = [], [], tuple(lines), []
        self.positions = {}  # name: the node lines' x1 (X, X + h, X − h) [m]
        for name, (X, a, b, h) in lines.items():
            at = []
            for off in (0.0, h, -h):
                near = xs[np.argmin(np.abs(xs - (X + off)))]
                idx, w = line_nodes(num, lower, near, a, b)
                if not len(idx):
                    raise ValueError(f"line gauge {name}: no node on x1 = {near:g} m within x2 = [{a:g}, {b:g}] m")
                nodes.append(idx)
                weights.append(w)
                at.append(near)
            self.dx.append(at[1] - at[2])
            self.positions[name] = tuple(at)
        self.starts = np.cumsum([0] + [len(i) for i in nodes[:-1]])
        self.w = np.concatenate(weights)
        self.wsum = np.add.reduceat(self.w, self.starts)
        bodies = model.bodies
        self.nodal = NodeValues(num, model.comm, np.concatenate(nodes), extra=3 if bodies is not None else 0)
        if bodies is not None:
            self.dofs = 2 * bodies.nodes
            self.m = model.mass[self.dofs]
        self.rows = []

    def record(self, state) -> None:
        """Add this step's values (collective)."""
        extra = ()
        b = self.model.bodies
        if b is not None:
            p, geo = state.contact, b.contact.geometry
            extra = (dot(self.m, state.v.array_r[self.dofs]), self.m.sum(), dot(p.Tn, geo.wq))  # not BLAS's order
        nodal = self.nodal.gather(state, extra)
        if nodal is None:
            return
        mean = np.add.reduceat(self.w[:, None] * nodal[:, [2, 0]], self.starts) / self.wsum[:, None]
        mean = mean.reshape(-1, 3, 2)  # [line, (X, X + h, X − h), (v1, u1)]
        row = [state.t - 0.5 * self.model.dt, state.t]
        row += np.column_stack([mean[:, 0, 0], (mean[:, 1, 1] - mean[:, 2, 1]) / self.dx]).ravel().tolist()
        if b is not None:
            s = self.nodal.extra_sum
            row += [s[0] / s[1], s[2]]
        self.rows.append(row)

    def result(self) -> dict | None:
        """{quantity: float64[n_steps]} on rank 0 (None elsewhere): ``t_v``, ``t_u``,
        ``name.v1``, ``name.eps11`` per line, then ``projectile.v1`` and
        ``contact_force`` with bodies."""
        if self.model.comm.rank != 0:
            return None
        keys = ["t_v", "t_u"] + [f"{n}.{q}" for n in self.names for q in ("v1", "eps11")]
        keys += ["projectile.v1", "contact_force"] if self.model.bodies is not None else []
        if not self.rows:
            return {}
        return dict(zip(keys, np.array(self.rows).T.copy()))
