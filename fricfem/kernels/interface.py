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
Each law compiles its own kernel (:func:`specialise`), so the call to
``advance`` is resolved and inlined at compile time: no per-point dispatch.
"""

import numba


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


def advance_points(advance, w, fw, geom, const, pts, dt):
    """One bulk step ``dt`` [s] of every interface point on this rank.

    ``w`` holds the gathered displacements at the end of the step; the jumps at
    the start of the step are in ``pts``.  Writes the *negative* nodal
    interface forces into ``fw``, each segment into its own slots (they are
    added to ``K u`` by the nodes' owners).  One piece: the
    loop over points is the kernel's whole work, and the law's ``advance`` is
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
                ts_new, sr, dsl, dwk, ns = advance(param_rows[param_index[q]], state[q], ts_old, tn_old,
                                                   tn_new, vs, p_Cs[q], dt)
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


#: ``advance_points`` compiled per ``advance`` it is called with, without
#: numba's reference counting (the kernel allocates nothing; the point rows it
#: hands to the law are plain views).  A law module closes over it with its own
#: ``advance`` in a module-level function, which numba caches on disk:
#:
#:     @numba.njit(cache=True, _nrt=False)
#:     def kernel(*args):
#:         specialise(advance, *args)
#:
#: (numba caches module-level functions, not ones a factory makes.)
specialise = numba.njit(_nrt=False)(advance_points)

_runtime = {}


def kernel_for(law):
    """The interface kernel of ``law``: ``kernel(w, fw, geom, const, pts, dt)``.

    The law's own kernel when its module defines one; otherwise (a law
    registered at run time) one specialised now for its ``advance``, kept for
    the rest of the process (compiled once, not cached on disk)."""
    if law.kernel is not None:
        return law.kernel
    kernel = _runtime.get(law.advance)
    if kernel is None:
        advance = law.advance

        @numba.njit(_nrt=False)
        def kernel(*args):
            specialise(advance, *args)

        _runtime[law.advance] = kernel
    return kernel


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
