"""Writes ``interface.h5`` as a run goes: interface snapshots, station histories,
energies (the format: :mod:`.quantities`).  Rank 0 writes; the others send.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .quantities import ENERGY, QUANTITIES


class Recorder:
    """Interface snapshots, station histories and energies → ``interface.h5`` (rank 0 writes)."""

    def __init__(self, path: Path, scene, model, speeds: dict):
        self.itf = model.interface
        self.comm = model.comm
        self.law = self.itf.law
        geom = self.itf.geometry
        x1_all = np.concatenate(self.comm.allgather(geom.x1))
        self.order = np.argsort(x1_all, kind="stable")
        self.x1 = x1_all[self.order]
        self.n_point = len(self.x1)
        # stations: nearest Gauss point; its owner records every step
        self.stations = {}
        for name, xs in scene.output["stations"].items():
            k = int(np.argmin(np.abs(self.x1 - xs)))
            xq = self.x1[k]
            local = np.flatnonzero(geom.x1 == xq)
            self.stations[name] = (xq, int(local[0]) if len(local) else -1)
        self.station_buf = {name: [] for name in self.stations}
        self.snap_t: list = []
        self.snap_rows: dict = {q.name: [] for q in QUANTITIES}
        self.snap_rows.update({f"state/{s}": [] for s in self.law.state})
        self.energy_rows: list = []
        self.pending = 0
        self.h5 = None
        if self.comm.rank == 0:
            import h5py

            self.h5 = h5py.File(path, "w")
            f = self.h5
            f.attrs.update(scene=scene.name, sigma0=scene.sigma0, v_imp=scene.pulse.v_imp, n_time=0,
                           law=scene.law, units="SI", **{k: v for k, v in speeds.items()})
            f["x1"] = self.x1
            f.create_dataset("time", (0,), maxshape=(None,), dtype="f8", chunks=(256,))
            chunk = (max(1, min(64, 2**20 // (8 * max(self.n_point, 1)))), max(self.n_point, 1))
            for q in self.snap_rows:
                dtype = "i1" if q == "open" else "f8"
                f.create_dataset(q, (0, self.n_point), maxshape=(None, self.n_point), dtype=dtype, chunks=chunk)
            for name, (xq, _) in self.stations.items():
                g = f.create_group(f"stations/{name}")
                g.attrs.update(x1=xq, n=0)
                for name in ["time", *(q.name for q in QUANTITIES)]:
                    g.create_dataset(name, (0,), maxshape=(None,), dtype="f8", chunks=(1024,))
            g = f.create_group("energy")
            for k in ENERGY:
                g.create_dataset(k, (0,), maxshape=(None,), dtype="f8", chunks=(256,))

    def _gather(self, arr) -> np.ndarray | None:
        parts = self.comm.gather(np.ascontiguousarray(arr, dtype=np.float64), root=0)
        return None if parts is None else np.concatenate(parts)[self.order]

    def snapshot(self, t: float) -> dict | None:
        """Record every interface point now (collective); returns the rank-0 row dict."""
        p = self.itf.points
        row = {}
        for q in QUANTITIES:
            row[q.name] = self._gather(q.read(p))
        for k, s in enumerate(self.law.state):
            row[f"state/{s}"] = self._gather(p.state[:, k])
        if self.comm.rank == 0:
            self.snap_t.append(t)
            for q, v in row.items():
                self.snap_rows[q].append(v)
            self.pending += 1
        return row

    def station_step(self, t: float) -> None:
        """Record the stations this rank owns (every step, local, no communication)."""
        p = self.itf.points
        for name, (_, q) in self.stations.items():
            if q >= 0:
                self.station_buf[name].append([t] + [float(qq.read(p)[q]) for qq in QUANTITIES])

    def energy(self, e: dict) -> None:
        if self.comm.rank == 0:
            self.energy_rows.append([e[k] for k in ENERGY])

    def flush(self) -> None:
        """Append everything pending to the file and flush it (collective)."""
        bufs = {name: self.comm.gather(self.station_buf[name], root=0) for name in self.stations}
        for name in self.stations:
            self.station_buf[name] = []
        if self.comm.rank != 0:
            return
        f = self.h5
        n0 = f["time"].shape[0]
        new = self.snap_t[n0:]
        if new:
            n1 = n0 + len(new)
            f["time"].resize((n1,))
            f["time"][n0:n1] = new
            for q, rows in self.snap_rows.items():
                f[q].resize((n1, self.n_point))
                f[q][n0:n1] = np.array(rows[n0:n1])
            f.attrs["n_time"] = n1
        for name, parts in bufs.items():
            rows = [r for part in parts for r in part]
            if not rows:
                continue
            g = f[f"stations/{name}"]
            a = np.array(rows)
            m0 = g["time"].shape[0]
            for j, name in enumerate(["time", *(q.name for q in QUANTITIES)]):
                g[name].resize((m0 + len(a),))
                g[name][m0:] = a[:, j]
            g.attrs["n"] = m0 + len(a)
        g = f["energy"]
        m0 = g["time"].shape[0]
        if len(self.energy_rows) > m0:
            a = np.array(self.energy_rows[m0:])
            for j, k in enumerate(ENERGY):
                g[k].resize((len(self.energy_rows),))
                g[k][m0:] = a[:, j]
        f.flush()

    def history(self):
        """(time, slip_rate[n_t, n_p]) recorded so far (rank 0; None elsewhere)."""
        if self.comm.rank != 0:
            return None
        return np.array(self.snap_t), np.array(self.snap_rows["slip_rate"])

    def close(self) -> None:
        if self.h5 is not None:
            self.h5.close()


def interface_profile(interface, names=("slip_rate", "shear_traction")) -> dict:
    """All ranks' interface points now, sorted by x1: ``{"x1": ..., name: ...}``
    for quantities of :data:`.quantities.QUANTITIES` and the law's state
    variables (collective)."""
    from .quantities import BY_NAME

    comm = interface.geometry.comm
    p = interface.points
    x1 = np.concatenate(comm.allgather(interface.geometry.x1))
    order = np.argsort(x1, kind="stable")
    out = {"x1": x1[order]}
    for name in names:
        local = np.asarray(BY_NAME[name].read(p), dtype=np.float64)
        out[name] = np.concatenate(comm.allgather(local))[order]
    for k, sname in enumerate(interface.law.state):
        out[sname] = np.concatenate(comm.allgather(np.ascontiguousarray(p.state[:, k])))[order]
    return out
