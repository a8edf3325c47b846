"""The two-pass explicit step: ``f = K u``, the interface forces added into
``f``, then the leapfrog update and the struck edge — the oracle the fused
step (:mod:`fricfem.step.fused`) must reproduce bit for bit.

``K u`` is summed here in numpy, over each row's blocks in the grid order
the fused sweep uses (:func:`canonical_product`), so the two agree to the
bit; PETSc's ``K.mult`` sums the same numbers in another order.
"""

from __future__ import annotations

import time

import numba
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


def canonical_product(model, u, f) -> None:
    """``f = K u``, each row summed block by block in the stored (grid) order,
    the x-product of a block before its y-product, as the fused sweep does."""
    rows, bulk = model.bulk.rows, model.bulk
    n = len(rows.ptr) - 1
    x = u.array_r
    if bulk.ghost_scatter is not None:
        bulk.ghost_scatter.scatter(u, bulk.ghost_vec, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
    xg = bulk.ug
    ptr = rows.ptr.astype(np.int64)
    col = rows.col.astype(np.int64)
    val = rows.val.reshape(-1, 4)
    counts = np.diff(ptr)
    row = np.repeat(np.arange(n), counts)
    slot = np.arange(len(col)) - ptr[row]
    owned = col < n
    x0 = np.where(owned, x[2 * np.minimum(col, n - 1)], 0.0)
    x1 = np.where(owned, x[2 * np.minimum(col, n - 1) + 1], 0.0)
    if len(xg):
        g = 2 * np.maximum(col - n, 0)
        x0 = np.where(owned, x0, xg[np.minimum(g, len(xg) - 2)])
        x1 = np.where(owned, x1, xg[np.minimum(g, len(xg) - 2) + 1])
    width = int(counts.max()) if n else 0
    pad = np.zeros((6, n, width))
    for k, a in enumerate((val[:, 0], val[:, 1], val[:, 2], val[:, 3], x0, x1)):
        pad[k, row, slot] = a
    s0 = np.zeros(n)
    s1 = np.zeros(n)
    for k in range(width):  # padding blocks add exact zeros
        s0 = s0 + pad[0, :, k] * pad[4, :, k]
        s0 = s0 + pad[1, :, k] * pad[5, :, k]
        s1 = s1 + pad[2, :, k] * pad[4, :, k]
        s1 = s1 + pad[3, :, k] * pad[5, :, k]
    fa = f.array
    fa[0::2] = s0
    fa[1::2] = s1


_SCRATCH: dict = {}  # id(model's K) -> (K, f): the two-pass step's own work vector


def _scratch(model):
    """The work vector ``f`` of the two-pass step for ``model`` (made once)."""
    held = _SCRATCH.get(id(model.K))
    if held is None or held[0] is not model.K:
        held = (model.K, model.K.createVecRight())
        _SCRATCH.clear()  # one model at a time: a test's model goes with the next
        _SCRATCH[id(model.K)] = held
    return held[1]


def step_two_pass(model, state, energy: dict | None = None, timers: dict | None = None) -> None:
    """The step as two passes, f = K u − F_int (PETSc) then the update: the reference
    for :func:`fricfem.step.step`, and the one with phase timers.  If ``timers`` is a dict, the
    seconds spent in the phases ``bulk`` (K·u), ``interface`` (gather, kernel,
    scatter-add) and ``update`` (leapfrog pass, struck edge, work) are added to it."""
    dt = model.dt
    imp = model.impact
    u, v, f = state.u, state.v, _scratch(model)
    if timers is not None:
        t0 = time.perf_counter()
    canonical_product(model, u, f)  # f = K u^n
    if energy is not None:
        strain = 0.5 * u.dot(f)
        v_old = v.array_r.copy()
    if timers is not None:
        t1 = time.perf_counter()
    model.interface.add_forces(state, u, f, dt)  # f = K u^n − F_int(u^n)
    if timers is not None:
        t2 = time.perf_counter()
    fa = f.array_r
    f_imp = fa[imp.dofs]
    v_imp_old = v.array_r[imp.dofs]
    u_imp_old = u.array_r[imp.dofs]
    leapfrog_update(u.array, v.array, fa, model.dt_minv, dt)
    if imp.pulse.prescribed:
        # the struck edge: exact prescribed displacement, consistent half-step velocity
        u1 = imp.pulse.displacement(state.t + dt)
        u0 = imp.pulse.displacement(state.t)
        u.array[imp.dofs] = u1
        v.array[imp.dofs] = (u1 - u0) / dt
        # reaction R^n = M a^n + f^n on the struck dofs; work ½ (R^{n−1} + R^n)(U^n − U^{n−1})
        react = imp.mass * ((u1 - u0) / dt - v_imp_old) / dt + f_imp
        state.work_ext += float(np.dot(0.5 * (state.react_prev + react), u0 - state.u_imp_prev))
        state.u_imp_prev = np.full(len(imp.dofs), u0)
        state.react_prev = react
    else:
        # a traction F = force·sign·V(t^n) − damp·v^n, v^n = (v^{n−½} + v^{n+½})/2 (implicit in v^{n+½})
        sv = imp.pulse.sign * imp.pulse.velocity(state.t)
        c = model.dt_minv[imp.dofs]
        a = 0.5 * c * imp.damp
        v_new = (v_imp_old * (1.0 - a) - c * (f_imp - imp.force * sv)) / (1.0 + a)
        u_new = u_imp_old + dt * v_new
        v.array[imp.dofs] = v_new
        u.array[imp.dofs] = u_new
        load = imp.force * sv - imp.damp * 0.5 * (v_imp_old + v_new)
        state.work_ext += float(np.dot(0.5 * (state.react_prev + load), u_imp_old - state.u_imp_prev))
        state.u_imp_prev = u_imp_old
        state.react_prev = load
    if energy is not None:
        kinetic = 0.5 * float(np.dot(model.mass * v_old, v.array_r))
        loc = np.array([kinetic, state.work_ext])
        tot = np.zeros(2)
        model.comm.Allreduce(loc, tot, op=MPI.SUM)
        energy.update(model.interface.energy(state))
        energy.update(time=state.t, kinetic=tot[0], strain=strain, external=tot[1])
        energy["balance_error"] = (
            energy["kinetic"] + energy["strain"] + energy["interface_work"] - energy["external"]
        )
    state.t_interface = state.t
    state.t += dt
    state.n += 1
    if timers is not None:
        t3 = time.perf_counter()
        for name, seconds in (("bulk", t1 - t0), ("interface", t2 - t1), ("update", t3 - t2)):
            timers[name] = timers.get(name, 0.0) + seconds



@numba.njit(cache=True)
def leapfrog_update(u, v, f, dt_minv, dt):
    """v -= (dt/m) f; u += dt v — one pass over the owned dofs."""
    for i in range(u.size):
        v[i] -= dt_minv[i] * f[i]
        u[i] += dt * v[i]
