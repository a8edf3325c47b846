"""Gauges in the bulk of a run: what a strain gauge or a velocity probe on the
specimen would record, and the projectile's momentum and contact force in the
experiment (:mod:`fricfem.model.bodies`).  Recorded after every step (a
runner's ``on_step``), on rank 0.

* a **line** gauge: the mean x1 velocity and the mean strain ε11 over the nodes
  of a segment x1 = X, x2_min ≤ x2 ≤ x2_max, each node weighted by its share
  of the segment (∫N_i ds), and ε11 = (u1(X + h) − u1(X − h))/(2h) on the
  neighbouring node lines (a strain gauge of length 2h across the segment);
* the **projectile**: its momentum Σ M v1 / Σ M (mean velocity) and the force
  the contact presses it with [N/m].

Velocities are v^{n+½}, at t^n + dt/2; displacements u^{n+1}, at t^{n+1}.
Only nodes of the plates' and the buffer's lower half (x2 ≤ 0, the cells below
the interface) count, so the upper plate's interface node is never mixed in.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI


def _lower_nodes(num) -> np.ndarray:
    """bool[n_grid]: grid nodes of cells whose centroid lies below the interface."""
    below = num.x[num.cells].mean(axis=1)[:, 1] < 0.0
    mark = np.zeros(len(num.x), dtype=bool)
    mark[np.unique(num.cells[below])] = True
    return mark


class Gauges:
    """Line gauges ``lines`` {name: (X, x2_min, x2_max, h)} [m] and, for a model with
    the experiment's bodies, the projectile.  :meth:`record` after each step;
    :meth:`result` the histories (rank 0; every rank gets None elsewhere)."""

    def __init__(self, model, lines: dict):
        self.model = model
        num = model.num
        own = num.owned_nodes
        x = num.x[own]
        lower_all = _lower_nodes(num)
        lower = lower_all[own]
        xs = np.unique(num.x[lower_all, 0])  # the node lines x1 = const below the interface
        self.comm = model.comm
        self.lines = {}
        for name, (X, a, b, h) in lines.items():
            g = {}
            for key, off in (("0", 0.0), ("m", -h), ("p", h)):
                near = xs[np.argmin(np.abs(xs - (X + off)))]
                idx = np.flatnonzero(lower & (x[:, 0] == near) & (x[:, 1] >= a) & (x[:, 1] <= b))
                g[f"x{key}"], g[f"i{key}"] = near, idx
                g[f"w{key}"] = self._weights(num, lower_all, near, a, b)(x[idx, 1])
            g["X"] = g["x0"]
            self.lines[name] = g
        self.rows = []

    @staticmethod
    def _weights(num, lower, X, a, b):
        """∫N_i ds over the node line x1 = X within [a, b] (lower nodes), as a function of x2."""
        ys = np.unique(num.x[lower & (num.x[:, 0] == X) & (num.x[:, 1] >= a) & (num.x[:, 1] <= b), 1])
        w = np.zeros(len(ys))
        d = np.diff(ys)
        w[:-1] += 0.5 * d
        w[1:] += 0.5 * d
        return lambda y: w[np.searchsorted(ys, y)] if len(ys) else np.zeros(len(y))

    def _sums(self, state) -> np.ndarray:
        u, v = state.u.array_r, state.v.array_r
        out = []
        for g in self.lines.values():
            i0, im, ip = g["i0"], g["im"], g["ip"]
            out += [np.dot(g["w0"], v[2 * i0]), g["w0"].sum(), np.dot(g["wp"], u[2 * ip]), g["wp"].sum(),
                    np.dot(g["wm"], u[2 * im]), g["wm"].sum()]
        b = self.model.bodies
        if b is not None:
            d = 2 * b.nodes
            m = self.model.mass[d]
            out += [np.dot(m, v[d]), m.sum()]
            p, geo = b.contact.points, b.contact.geometry
            out += [float(np.dot(p.Tn, geo.wq))]
        return np.array(out, dtype=np.float64)

    def record(self, state) -> None:
        """Add this step's values (collective)."""
        tot = np.zeros_like(loc := self._sums(state))
        self.comm.Allreduce(loc, tot, op=MPI.SUM)
        dt = self.model.dt
        row = {"t_v": state.t - 0.5 * dt, "t_u": state.t}
        k = 0
        for name, g in self.lines.items():
            v, wv, up, wp, um, wm = tot[k:k + 6]
            k += 6
            row[f"{name}.v1"] = v / wv if wv else np.nan
            row[f"{name}.eps11"] = (up / wp - um / wm) / (g["xp"] - g["xm"]) if wp and wm else np.nan
        if self.model.bodies is not None:
            row["projectile.v1"] = tot[k] / tot[k + 1]
            row["contact_force"] = tot[k + 2]  # at t^n (the interface time of the step)
        self.rows.append(row)

    def result(self) -> dict | None:
        """{quantity: float64[n_steps]} on rank 0 (None elsewhere)."""
        if self.comm.rank != 0 or not self.rows:
            return None if self.comm.rank != 0 else {}
        return {k: np.array([r[k] for r in self.rows]) for k in self.rows[0]}
