"""Friction laws a user would register, for the tests of ``fricfem.register_law``: a
rate-independent Coulomb law (μ = p[0]) with both verbs, numba-compiled in plain sight."""

import numba

from fricfem.friction import frictional_work


@numba.njit
def coulomb_advance(p, s, Ts, Tn0, Tn1, vs, Cs, dt):
    """The elastic-interface verb: a trial traction from the spring, returned to the strength."""
    trial = Ts + Cs * vs * dt
    strength = p[0] * Tn1
    if abs(trial) <= strength:
        return trial, 0.0, 0.0, 0.0, 1
    dslip = (abs(trial) - strength) / Cs
    Ts1 = strength if trial > 0 else -strength
    return Ts1, dslip / dt, dslip, frictional_work(Ts, Ts1, dslip), 1


@numba.njit
def coulomb_rigid(p, s, T_stick, Z, Tn0, Tn1, dt):
    """The rigid (split-node) verb: the pair's impedance takes the traction above the strength."""
    strength = p[0] * Tn1
    if abs(T_stick) <= strength:
        return T_stick, 0.0, 0.0, 0.0, 1
    v = (abs(T_stick) - strength) / Z
    return (strength if T_stick > 0 else -strength), v, v * dt, strength * v * dt, 1
