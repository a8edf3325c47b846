"""The dynamic state of one run: displacement, velocity, time, and what the
step keeps between calls (the struck dofs' last displacement, the external
work, which rows are awake, phase timers)."""

from __future__ import annotations

import numpy as np


class State:
    """u^n, v^{n−½} (PETSc vectors), t^n, n, the running external work and the
    struck dofs' previous displacement, for the model ``model``.

    A step computes the interface at t^n (from u^n) and then moves u to
    t^{n+1}: after it, ``t`` is t^{n+1} and ``t_interface`` is t^n, the time at
    which the interface tractions and slip rates hold.

    ``skip_quiet``: starting from rest, the step computes only the rows the
    motion has reached (:class:`fricfem.step.fused.FusedBulk`; bit-identical to
    computing every row).  A state whose u or v is set by hand must be woken
    (:meth:`wake`) before it is stepped.
    """

    def __init__(self, model, skip_quiet: bool = True):
        self.u = model.K.createVecRight()
        self.v = model.K.createVecRight()
        self.f = model.K.createVecRight()  # scratch of the two-pass reference step (tests)
        self.u_next = model.K.createVecRight()  # u^{n+1} is written here, then swapped with u
        self.t = 0.0
        self.t_interface = 0.0  # time of the interface state (tractions, slip rates): t^n of the last step
        self.n = 0
        self.work_ext = 0.0  # this rank's share [J/m]
        self.u_imp_prev = np.zeros(len(model.impact.dofs))  # U(t^{n−1}) of the struck dofs [m]
        self.react_prev = np.zeros(len(model.impact.dofs))  # their load at t^{n−1} [N/m]
        self.damp_prev = np.zeros((len(model.bulk.damping), 4))  # dashpots: u^{n−1} and force at t^{n−1}
        self.absorbed = 0.0  # energy the dashpots absorbed, this rank's share [J/m]
        self.act = model.bulk.activity(at_rest=skip_quiet)  # rows awake (kernels.bulk QUIET/ACTIVE/SPREAD)
        #: wall time per phase of the fused step, summed over steps [s]: the interface
        #: (gather, kernel, reverse scatter), the sweeps, the wait for off-rank displacements
        self.seconds = {"interface": 0.0, "sweep": 0.0, "wait": 0.0}

    def wake(self) -> None:
        """Compute every row from now on (a state set by hand)."""
        self.act[:] = 2  # kernels.bulk.SPREAD

    @property
    def active_fraction(self) -> float:
        """Share of this rank's rows that the next step computes (not quiet)."""
        return float(np.count_nonzero(self.act)) / max(len(self.act), 1)
