"""The dynamic state of one run: everything a step changes.

The model (:class:`fricfem.model.build.Model`) is read-only in a run; a
state holds displacement, velocity, time and step count, the interface
points' evolving arrays (friction state, tractions, jumps, slip, work: the
``evolving`` fields of its own
:class:`~fricfem.model.interface.Points`), the contact's when the model has
the experiment's bodies, the struck edge's and the dashpots' memories, the
running external work and absorbed energy, and which rows are awake.  Two
states of one model step independently, and the same bits come out of each.

:meth:`State.snapshot` and :meth:`State.restore` take all of it out and put
it back (a checkpoint), so that a restored state steps on with the same bits.
"""

from __future__ import annotations

import numpy as np

#: the scalars of a state (:meth:`State.snapshot`)
_SCALARS = ("t", "t_interface", "n", "work_ext", "absorbed", "viscous")
#: its arrays other than the vectors and the interface points
_ARRAYS = ("u_imp_prev", "react_prev", "damp_prev", "act")
#: the attributes that hold interface points (the frictional interface's, the contact's)
_POINTS = ("points", "contact")


class State:
    """u^n, v^{n−½} (PETSc vectors), t^n, n, the interface points, the running
    external work and the struck dofs' previous displacement, for the model ``model``.

    A step computes the interface at t^n (from u^n) and then moves u to
    t^{n+1}: after it, ``t`` is t^{n+1} and ``t_interface`` is t^n, the time at
    which the interface tractions and slip rates hold.

    ``points``: this run's frictional interface points (the model's constants,
    its own evolving arrays, updated in place by every step); ``contact``: the
    projectile's contact pairs (the experiment's bodies) or None.

    ``skip_quiet``: starting from rest, the step computes only the rows the
    motion has reached (:class:`fricfem.step.fused.FusedBulk`; bit-identical to
    computing every row).  A state whose u or v is set by hand must be woken
    (:meth:`wake`) before it is stepped.
    """

    def __init__(self, model, skip_quiet: bool = True):
        self.u = model.K.createVecRight()
        self.v = model.K.createVecRight()
        self.u_next = model.K.createVecRight()  # u^{n+1} is written here, then swapped with u
        self.t = 0.0
        self.t_interface = 0.0  # time of the interface state (tractions, slip rates): t^n of the last step
        self.n = 0
        self.work_ext = 0.0  # this rank's share [J/m]
        self.u_imp_prev = np.zeros(len(model.impact.dofs))  # U(t^{n−1}) of the struck dofs [m]
        self.react_prev = np.zeros(len(model.impact.dofs))  # their load at t^{n−1} [N/m]
        self.damp_prev = np.zeros((len(model.bulk.damping), 4))  # dashpots: u^{n−1} and force at t^{n−1}
        self.absorbed = 0.0  # energy the dashpots absorbed, this rank's share [J/m]
        self.viscous = 0.0  # energy a Kelvin–Voigt layer dissipated, this rank's share, to t^{n+1} [J/m]
        self.viscous_ahead = 0.0  # the part of it after t^n (the last step's; not state: made by every step)
        self.act = model.bulk.activity(at_rest=skip_quiet)  # rows awake (kernels.bulk QUIET/ACTIVE/SPREAD)
        self.points = None
        self.contact = None
        if model.interface is not None:
            for name, points in model.interface.fresh_points().items():
                setattr(self, name, points)
        #: wall time per phase of the fused step, summed over steps [s]: the interface
        #: (gather, kernel, reverse scatter), the sweeps, the wait for off-rank displacements
        #: (a measurement, not state: not in :meth:`snapshot`)
        self.seconds = {"interface": 0.0, "sweep": 0.0, "wait": 0.0}

    def wake(self) -> None:
        """Compute every row from now on (a state set by hand)."""
        self.act[:] = 2  # kernels.bulk.SPREAD

    @property
    def active_fraction(self) -> float:
        """Share of this rank's rows that the next step computes (not quiet)."""
        return float(np.count_nonzero(self.act)) / max(len(self.act), 1)

    def snapshot(self) -> dict:
        """This rank's part of everything a step changes, as copies: ``{name: array
        or number}`` (``u``, ``v``: the owned entries; ``points.<field>`` and
        ``contact.<field>`` the interface points' evolving arrays).  Local, no
        communication.  :meth:`restore` puts it back."""
        out = {"u": self.u.array_r.copy(), "v": self.v.array_r.copy()}
        for name in _SCALARS:
            out[name] = getattr(self, name)
        for name in _ARRAYS:
            out[name] = np.array(getattr(self, name))
        for slot in _POINTS:
            points = getattr(self, slot)
            if points is not None:
                for field in points.evolving:
                    out[f"{slot}.{field}"] = np.array(getattr(points, field))
        return out

    def restore(self, d: dict) -> None:
        """Put back a :meth:`snapshot` of a state of the same model on this rank: the
        state then steps on with the same bits as the one it was taken from.  The
        arrays are written in place (whoever holds them keeps them).  A missing
        entry, or one of another shape or type, is a ValueError naming it."""
        def put(name, target):
            if name not in d:
                raise ValueError(f"State.restore: {name!r} is missing")
            value = np.asarray(d[name])
            if value.shape != target.shape or value.dtype != target.dtype:
                raise ValueError(f"State.restore: {name!r} is {value.dtype}{list(value.shape)}, this state's "
                                 f"{target.dtype}{list(target.shape)}")
            np.copyto(target, value)

        put("u", self.u.array)
        put("v", self.v.array)
        for name in _ARRAYS:
            put(name, getattr(self, name))
        for slot in _POINTS:
            points = getattr(self, slot)
            if points is not None:
                for field in points.evolving:
                    put(f"{slot}.{field}", getattr(points, field))
        for name in _SCALARS:
            if name not in d:
                raise ValueError(f"State.restore: {name!r} is missing")
        self.t, self.t_interface = float(d["t"]), float(d["t_interface"])
        self.n = int(d["n"])
        self.work_ext, self.absorbed, self.viscous = float(d["work_ext"]), float(d["absorbed"]), float(d["viscous"])
        # the rows a step leaves quiet hold u = 0 in both buffers; every other row of u^{n+1} is written
        self.u_next.array[:] = self.u.array_r
