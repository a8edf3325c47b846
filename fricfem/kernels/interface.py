"""numba kernels of the frictional interface: one loop over this rank's Gauss
points per bulk step (the interface itself: :mod:`fricfem.model.interface`;
its verbs: :mod:`fricfem.step.interface`).

Arrays and scalars only, bundled as plain tuples unpacked on the first line:

    geom    (seg int32[n_seg, 8], shape float64[4, 2], wq float64[n_pts]):
            per segment the work-vector offsets of its (lower a, lower b, upper
            a, upper b) x1 dofs, then the offsets of its own force slots for the
            same nodes; the shape functions at the Gauss points; the Gauss
            weights × half segment length [m].  (Three members: with a fourth,
            numba 0.56 stops caching the per-law kernels.)
    const   (Tn0, Ts0 [Pa], Cn, Cs [Pa/m] float64[n_pts],
             param_rows float64[k, n_params], param_index int32[n_pts])
    pts     the point state, updated in place: (state float64[n_pts, n_storage],
            Tn, Ts, dTs, jump_n, jump_s, rate_n, rate_s, slip, slip_rate,
            work, dissipated float64[n_pts], is_open int8[n_pts], nsub int32[n_pts])
            (:class:`fricfem.model.interface.Points`, same order)

A friction law enters through its ``advance`` (:mod:`fricfem.friction.base`).
Each law gets its own copy of the kernel (:func:`kernel_for`), in which
``law_advance`` (``law_rigid`` in the rigid kernel) is a global name bound to
the law's function, so the call is resolved and inlined at compile time (no
per-point dispatch) and numba caches the copy on disk like any module-level
function.  (Passing the law's dispatcher as an argument instead made numba
embed the dispatcher's address in the kernel, a "dynamic global" it will not
cache: every process compiled the kernel again.)
"""

from __future__ import annotations

import hashlib
import inspect
import os
import re
import types
import warnings
from pathlib import Path

import numba
import numpy as np
from numba.core.errors import NumbaWarning


@numba.njit(inline="always", cache=True)
def _store_segment(fw, fa, fb, fua, fub, ax, ay, bx, by):
    """Store a segment's *negative* forces on its lower nodes a, b (ax, ay, bx,
    by) into its force slots, and their opposite on the upper nodes."""
    fw[fa] = ax
    fw[fa + 1] = ay
    fw[fb] = bx
    fw[fb + 1] = by
    fw[fua] = -ax
    fw[fua + 1] = -ay
    fw[fub] = -bx
    fw[fub + 1] = -by


def advance_points(w, fw, geom, const, pts, dt):
    """One bulk step ``dt`` [s] of every interface point on this rank.

    ``w`` holds the gathered displacements at the end of the step; the jumps at
    the start of the step are in ``pts``.  Writes the *negative* nodal
    interface forces into ``fw``, each segment into its own slots (they are
    added to ``K u`` by the nodes' owners).  One piece: the
    loop over points is the kernel's whole work, and the law's ``advance``
    (the global ``law_advance`` of the law's copy, :func:`kernel_for`) is
    inlined into it.
    """
    seg, shape, wq = geom
    p_Tn0, p_Ts0, p_Cn, p_Cs, param_rows, param_index = const
    state, Tn, Ts, dTs, jn, js, rn, rs, slip, slip_rate, work, dissipated, is_open, nsub = pts
    nseg = seg.shape[0]
    ng = shape.shape[0]
    for e in range(nseg):
        la = seg[e, 0]
        lb = seg[e, 1]
        ua = seg[e, 2]
        ub = seg[e, 3]
        ax = ay = bx = by = 0.0  # the segment's negative forces on its lower nodes a, b
        for g in range(ng):
            q = e * ng + g
            na = shape[g, 0]
            nb = shape[g, 1]
            dus = na * (w[ua] - w[la]) + nb * (w[ub] - w[lb])
            dun = na * (w[ua + 1] - w[la + 1]) + nb * (w[ub + 1] - w[lb + 1])
            vs = (dus - js[q]) / dt
            vn = (dun - jn[q]) / dt
            tn_old = Tn[q]
            ts_old = Ts[q]
            tn_new = p_Tn0[q] - p_Cn[q] * dun
            if tn_new < 0.0:  # open: traction-free, no frictional slip
                tn_new = 0.0
                ts_new = 0.0
                sr = 0.0
                is_open[q] = 1
                nsub[q] = 0
            else:
                ts_new, sr, dsl, dwk, ns = law_advance(param_rows[param_index[q]], state[q], ts_old,  # noqa: F821
                                                       tn_old, tn_new, vs, p_Cs[q], dt)
                slip[q] += dsl
                dissipated[q] += dwk
                is_open[q] = 0
                nsub[q] = ns
            # work done by the bulk on the interface (trapezoid in time)
            work[q] += (0.5 * (ts_old + ts_new) - p_Ts0[q]) * (dus - js[q]) \
                - (0.5 * (tn_old + tn_new) - p_Tn0[q]) * (dun - jn[q])
            Tn[q] = tn_new
            Ts[q] = ts_new
            dTs[q] = ts_new - ts_old
            jn[q] = dun
            js[q] = dus
            rn[q] = vn
            rs[q] = vs
            slip_rate[q] = sr
            fx = (ts_new - p_Ts0[q]) * wq[q]  # force on the lower plate, x1
            fy = -(tn_new - p_Tn0[q]) * wq[q]  # force on the lower plate, x2
            ax -= na * fx
            ay -= na * fy
            bx -= nb * fx
            by -= nb * fy
        # one store per slot (writing each Gauss point's share into ``fw`` at
        # offsets other than the read ones stops numba 0.56 caching the kernel)
        _store_segment(fw, seg[e, 4], seg[e, 5], seg[e, 6], seg[e, 7], ax, ay, bx, by)


# One piece (longer than the ~80 lines a function is kept to): per pair, the
# trial velocities, the normal traction closing the gap, the law's shear and
# the forces back share the pair's gathered values and masses in registers;
# split into calls they would travel as tuples through the step's inner loop.
def advance_pairs(wu, wv, wk, fw, pgeom, const, pts, dt):
    """One bulk step of every rigid (split-node) pair on this rank (Andrews
    1999; Day et al. 2005, traction at split nodes).

    ``wu``, ``wv``, ``wk``: u^n, v^{n−½} and (K u^n) gathered at the pairs,
    laid out [lower nodes, upper nodes] × 2 components; ``pgeom`` =
    (mass float64[2 n] (lower, upper per pair) [kg/m], A float64[n] [m],
    edge float64[2 n + 1]: 1.0 where a node's x1 velocity is prescribed, then
    that velocity this step [m/s]).
    Without the interface the half-step velocities would be
    ṽ = v^{n−½} − dt (K u)/M; the pair's traction (total, compression
    positive) follows with Z = 1/(dt A (1/M⁺ + 1/M⁻)) [Pa·s/m]:

        T_n = Σ0 − Z (Δṽ_n + Δu_n^n / dt)      (closes the gap at t^{n+1}; open if < 0)
        T_s = T_stick − Z V sgn(T_stick),  T_stick = T_s0 + Z Δṽ_s  (the law's ``rigid``)

    and the pair's jump rate over the step is Δṽ − ΔT/Z (shear) and
    Δṽ_n + ΔT_n/Z (normal); the shear is the law's ``rigid`` (the global
    ``law_rigid`` of the law's copy, :func:`rigid_kernel_for`).  Writes the *negative* nodal forces (lower x, y,
    upper x, y) into ``fw`` and updates the point state ``pts`` as
    :func:`advance_points` does; the work of the bulk on the pair over the
    step that ended at t^n is the trapezoid of the tractions at its ends
    times the jump's increment (the central-difference energy identity:
    E^{n+1} − E^n = ½ (F^n + F^{n+1}) · (u^{n+1} − u^n)).
    One piece: the loop over pairs is the kernel's whole work.
    """
    mass, wq, edge = pgeom
    p_Tn0, p_Ts0, p_Cn, p_Cs, param_rows, param_index = const
    state, Tn, Ts, dTs, jn, js, rn, rs, slip, slip_rate, work, dissipated, is_open, nsub = pts
    n = wq.size
    v_edge = edge[2 * n]
    for k in range(n):
        lo = 2 * k
        up = 2 * (n + k)
        ml = mass[2 * k]
        mu = mass[2 * k + 1]
        # a node whose x1 velocity is prescribed (the struck edge's corner) moves at
        # v_edge whatever the interface does: infinitely heavy along x1
        if edge[2 * k] > 0.0:
            vlx, il = v_edge, 0.0
        else:
            vlx, il = wv[lo] - dt * wk[lo] / ml, 1.0 / ml
        if edge[2 * k + 1] > 0.0:
            vux, iu = v_edge, 0.0
        else:
            vux, iu = wv[up] - dt * wk[up] / mu, 1.0 / mu
        dvs = vux - vlx
        dvn = (wv[up + 1] - dt * wk[up + 1] / mu) - (wv[lo + 1] - dt * wk[lo + 1] / ml)
        dus = wu[up] - wu[lo]
        dun = wu[up + 1] - wu[lo + 1]
        Z = 1.0 / (dt * wq[k] * (1.0 / mu + 1.0 / ml))  # normal
        Zs = 1.0 / (dt * wq[k] * (iu + il)) if iu + il > 0.0 else np.inf  # shear
        tn_old = Tn[k]
        ts_old = Ts[k]
        tn_new = p_Tn0[k] - Z * (dvn + dun / dt)
        if tn_new <= 0.0:  # open: traction-free, no frictional slip
            tn_new = 0.0
            ts_new = 0.0
            sr = 0.0
            is_open[k] = 1
            nsub[k] = 0
        elif Zs == np.inf:  # both nodes move as prescribed along x1: no slip, no shear force
            ts_new = p_Ts0[k]
            sr = 0.0
            is_open[k] = 0
            nsub[k] = 0
        else:
            ts_new, sr, dsl, dwk, ns = law_rigid(param_rows[param_index[k]], state[k],  # noqa: F821
                                                 p_Ts0[k] + Zs * dvs, Zs, tn_old, tn_new, dt)
            slip[k] += dsl
            dissipated[k] += dwk
            is_open[k] = 0
            nsub[k] = ns
        rs_new = dvs - (ts_new - p_Ts0[k]) / Zs
        rn_new = dvn + (tn_new - p_Tn0[k]) / Z
        # work over the step that ended at t^n, the traction's trapezoid (the
        # central-difference energy identity; rs, rn still hold that step's rates)
        work[k] += 0.5 * dt * ((ts_old + ts_new - 2.0 * p_Ts0[k]) * rs[k] - (tn_old + tn_new - 2.0 * p_Tn0[k]) * rn[k])
        Tn[k] = tn_new
        Ts[k] = ts_new
        dTs[k] = ts_new - ts_old
        jn[k] = dun
        js[k] = dus
        rn[k] = rn_new
        rs[k] = rs_new
        slip_rate[k] = sr
        fx = (ts_new - p_Ts0[k]) * wq[k]  # force on the lower plate, x1
        fy = -(tn_new - p_Tn0[k]) * wq[k]  # force on the lower plate, x2
        fw[4 * k] = -fx
        fw[4 * k + 1] = -fy
        fw[4 * k + 2] = fx
        fw[4 * k + 3] = fy


_kernels = {}  # (template, law function) -> the law's compiled copy, for this process


def kernel_for(law):
    """The interface kernel of ``law``: ``kernel(w, fw, geom, const, pts, dt)``
    (``law.kernel`` when the law gives one; else :func:`advance_points` with
    the law's ``advance``, made once per process and cached on disk when
    numba can, see :func:`specialise`)."""
    if law.kernel is not None:
        return law.kernel
    return specialise(advance_points, "law_advance", law.advance)


def rigid_kernel_for(law):
    """The rigid-interface kernel of ``law``: ``kernel(wu, wv, wk, fw, pgeom, const, pts, dt)``
    (``law.rigid_kernel``, else :func:`advance_pairs` with the law's ``rigid``)."""
    if law.rigid is None:
        raise ValueError(f"friction.law = {law.name!r}: no rigid-interface verb (interface.kind = 'rigid' "
                         "needs a law with ``rigid``)")
    if getattr(law, "rigid_kernel", None) is not None:
        return law.rigid_kernel
    return specialise(advance_pairs, "law_rigid", law.rigid)


def specialise(template, name: str, fn):
    """``template`` (a kernel body of this module) compiled with the global
    ``name`` bound to the law's numba function ``fn``, without numba's
    reference counting (the kernels allocate nothing).

    The copy is a module-level function to numba (this file, the template's
    line), named after the law function (:func:`cache_tag`), so numba caches it
    on disk and loads it in the next process.  A function numba cannot key
    safely (no source file, a closure) gets an uncached copy: compiled once
    per process.  Either way one copy per ``fn`` and process."""
    key = (template, fn)
    kernel = _kernels.get(key)
    if kernel is None:
        tag = cache_tag(fn)
        scope = dict(template.__globals__)
        scope[name] = fn
        body = types.FunctionType(template.__code__, scope, template.__name__)
        body.__module__ = template.__module__
        body.__doc__ = template.__doc__
        if tag is not None:
            body.__qualname__ = f"{template.__qualname__}__{tag}"  # numba's cache file name
        kernel = numba.njit(cache=tag is not None, _nrt=False)(body)
        _kernels[key] = kernel
    return kernel


def cache_tag(fn):
    """The name under which a law function's kernel is cached, or None: not cacheable.

    fricfem's own laws: their module and name (:mod:`fricfem.kernels.cache`
    clears the cache when any of fricfem's numba sources changes).  A user's
    law: its module and name, and a hash of its source file and of the plain
    values (numbers, strings, arrays) of the module globals it reads, so an
    edited law or a changed constant gets a kernel of its own.  Not cacheable:
    a function without a source file (typed at a prompt), a closure (what it
    closes over is not in its file), not a numba function.  The law's other
    numba functions in other files are not looked at (as numba's own cache):
    a law that calls a helper from another file of its own should keep the
    helper in the same file as ``advance``, or clear the cache when editing it.
    """
    py = getattr(fn, "py_func", None)
    if py is None or py.__closure__:
        return None
    module = py.__module__ or ""
    qual = re.sub(r"\W", "_", py.__qualname__)
    if module.startswith("fricfem."):
        return f"{module.rsplit('.', 1)[-1]}_{qual}"
    try:
        path = inspect.getsourcefile(py)
        source = Path(path).read_bytes() if path and os.path.isfile(path) else None
    except (OSError, TypeError):
        source = None
    if source is None:
        return None
    h = hashlib.sha256(source)
    h.update(py.__qualname__.encode())
    for gname in sorted(set(py.__code__.co_names)):
        value = py.__globals__.get(gname)
        if isinstance(value, (bool, int, float, complex, str, bytes)):
            h.update(f"{gname}={value!r};".encode())
        elif isinstance(value, np.ndarray):
            h.update(f"{gname}:{value.dtype}{value.shape}".encode())
            h.update(np.ascontiguousarray(value).tobytes())
    return f"{module.rsplit('.', 1)[-1]}_{qual}_{h.hexdigest()[:16]}"


def first_call(kernel, *args):
    """Call ``kernel`` the first time (it compiles, or loads from numba's cache),
    with numba's "Cannot cache compiled function" warning caught here: a law
    numba will not cache still runs (compiled in each process), without
    numba's coloured warning in the run's output."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Cannot cache compiled function", category=NumbaWarning)
        kernel(*args)


@numba.njit(cache=True)
def spring_kernel(w, fw, geom, Cn, Cs):
    """``fw = K_int w`` for the linear interface springs (stability estimate),
    each segment into its own force slots."""
    seg, shape, wq = geom
    ng = shape.shape[0]
    for e in range(seg.shape[0]):
        la, lb, ua, ub = seg[e, 0], seg[e, 1], seg[e, 2], seg[e, 3]
        ax = ay = bx = by = 0.0
        for g in range(ng):
            q = e * ng + g
            na, nb = shape[g, 0], shape[g, 1]
            fx = Cs[q] * wq[q] * (na * (w[ua] - w[la]) + nb * (w[ub] - w[lb]))
            fy = Cn[q] * wq[q] * (na * (w[ua + 1] - w[la + 1]) + nb * (w[ub + 1] - w[lb + 1]))
            ax -= na * fx
            ay -= na * fy
            bx -= nb * fx
            by -= nb * fy
        _store_segment(fw, seg[e, 4], seg[e, 5], seg[e, 6], seg[e, 7], ax, ay, bx, by)
