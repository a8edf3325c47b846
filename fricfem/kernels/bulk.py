"""numba kernels of the fused bulk step: one sweep over the rows of K that
computes K u, adds the interface forces, updates v and u and applies the
struck edge (the orchestration, and the derivation: :mod:`fricfem.step.fused`).

Arrays and scalars only.  Arguments come bundled as plain tuples (numba
dispatches a plain tuple as fast as loose arguments; a NamedTuple costs ~5 µs
per call), unpacked on the first line of each kernel:

    rows    (ptr uint32[n+1], col uint32[n_blocks], val float64[4 n_blocks])
            this rank's block rows of K (2×2 blocks, [N/m², per m thickness]);
            ``col`` < n an owned node, n + k the k-th gathered off-rank node
    special (node int32[n_sp+1], impact int32[n_sp], deferred int8[n_sp],
            preloaded int8[n_sp], damped int32[n_sp]): the rows needing more
            than the plain update (:class:`fricfem.step.fused.Special`)
    edge    (mass float64[n_imp] [kg/m], force, damp float64[n_imp] or empty)
            the struck edge's x1 dofs: lumped masses, and for a traction load
            the coefficients of force · sv − damp · v1 [N·s/m², per m]
    load    (dt [s], u0 = U(t^n) [m], u1 = U(t^{n+1}) [m], v_bc = (u1 − u0)/dt
            [m/s], sv = sign · V(t^n) [m/s]) of this step
    absorb  (c float64[n_d, 2] the dashpot coefficient of each damped node's two
            components [N·s/m², per m], prev float64[n_d, 4]: u^{n−1} and the
            dashpot force at t^{n−1} of both components, updated)

Rounding: every row is summed over its blocks in the grid's node order
(:mod:`fricfem.model.numbering`), owned and off-rank columns alike, and an
interface row's force is ``(K u)_i + left_i + right_i`` in that order, so a
row's sums have the same bits on any number of ranks.
"""

import numba

# Activity of a row: QUIET rows are skipped; ACTIVE rows are computed; SPREAD
# rows are computed and have woken their neighbours (fricfem.step.fused).
QUIET, ACTIVE, SPREAD = 0, 1, 2


@numba.njit(inline="always", cache=True)
def _add_block(val, b, x0, x1, s0, s1):
    """Add the 2×2 block at ``val[b:b + 4]`` times (x0, x1) to (s0, s1), term by
    term in PETSc's order (the sums stay bit-identical to its product)."""
    s0 += val[b] * x0
    s0 += val[b + 1] * x1
    s1 += val[b + 2] * x0
    s1 += val[b + 3] * x1
    return s0, s1


@numba.njit(inline="always", cache=True)
def _row(ptr, col, val, x, I):
    """(K x)_{2I}, (K x)_{2I+1} for a row whose columns are all owned, summed
    over its blocks in their stored (grid) order.  Inlined (as :func:`_row_mixed`):
    called as a kernel of its own once per row, it made the sweep ~2× slower."""
    s0 = 0.0
    s1 = 0.0
    for p in range(ptr[I], ptr[I + 1]):
        j = 2 * col[p]
        s0, s1 = _add_block(val, 4 * p, x[j], x[j + 1], s0, s1)
    return s0, s1


@numba.njit(inline="always", cache=True)
def _row_mixed(ptr, col, val, x, xg, n_nodes, I):
    """The same for a boundary row, ``xg`` holding the gathered off-rank values:
    one pass in the stored (grid) order, owned and off-rank columns alike."""
    s0 = 0.0
    s1 = 0.0
    for p in range(ptr[I], ptr[I + 1]):
        J = col[p]
        if J < n_nodes:
            s0, s1 = _add_block(val, 4 * p, x[2 * J], x[2 * J + 1], s0, s1)
        else:
            k = 2 * (J - n_nodes)
            s0, s1 = _add_block(val, 4 * p, xg[k], xg[k + 1], s0, s1)
    return s0, s1


@numba.njit(cache=True, _nrt=False)
def preload(rows, special, u, ug, sp_ku):
    """``K u`` at the interface (preloaded) special nodes into ``sp_ku``
    (float64[2 n_special], by special index), while the interface computes its
    forces; ``ug`` the gathered off-rank displacements, if a row needs them.
    (Spectral elements: ``rows`` the identity and ``u`` K u itself, :func:`sweep`.)"""
    ptr, col, val = rows
    sp_node, _, _, sp_preloaded, _ = special
    n = ptr.size - 1
    for k in range(sp_preloaded.size):
        if sp_preloaded[k]:
            I = sp_node[k]
            s0, s1 = _row_mixed(ptr, col, val, u, ug, n, I)
            sp_ku[2 * k] = s0
            sp_ku[2 * k + 1] = s1


@numba.njit(inline="always", cache=True)
def _damped(i, d, comp, f, u, unew, v, c_dt_minv, dt, absorb):
    """The implicit update of one dashpot component (force −c v^n, v^n the
    mean of the half-step velocities); returns the energy it absorbed over
    the step that ended at t^n (the force's trapezoid: the energy identity)."""
    c, prev = absorb
    a = 0.5 * c_dt_minv * c[d, comp]
    v_old = v[i]
    v[i] = (v_old * (1.0 - a) - c_dt_minv * f) / (1.0 + a)
    unew[i] = u[i] + dt * v[i]
    force = -c[d, comp] * 0.5 * (v_old + v[i])
    absorbed = -0.5 * (prev[d, 2 + comp] + force) * (u[i] - prev[d, comp])
    prev[d, comp] = u[i]
    prev[d, 2 + comp] = force
    return absorbed


@numba.njit(inline="always", cache=True)
def _special_update(I, k, s0, s1, special, edge, load, u, unew, v, dt_minv, gl, gr, imp_prev, imp_react, absorb):
    """Update the special node ``I`` (its index ``k`` in the special arrays) from
    ``s = (K u)_I``; returns (the work of the step's load on it, the energy
    its dashpots absorbed) [J/m], both over the step that ended at t^n.  An
    interface row adds the negative interface forces from the segments on its
    left and right, ``gl`` and ``gr``, in that order.

    On the struck edge either u1 is prescribed (``edge`` masses; U(t^n),
    U(t^{n+1}), v_bc) or, when the edge's force coefficients are not empty, a
    traction acts: the force ``force · sv − damp · v^n`` with v^n = (v^{n−½} +
    v^{n+½})/2, taken implicitly in v^{n+½}.  A node on an absorbing edge has
    dashpots on its free components (:func:`_damped`)."""
    _, sp_impact, _, sp_preloaded, sp_damped = special
    imp_mass, imp_force, imp_damp = edge
    dt, u0, u1, v_bc, sv = load
    i = 2 * I
    if sp_preloaded[k]:
        f0 = s0 + gl[i] + gr[i]  # (K u) + left + right: the same bits on any number of ranks
        f1 = s1 + gl[i + 1] + gr[i + 1]
    else:
        f0 = s0
        f1 = s1
    work = 0.0
    absorbed = 0.0
    q = sp_impact[k]
    d = sp_damped[k]
    if q >= 0 and imp_force.size:
        c = dt_minv[I]
        a = 0.5 * c * imp_damp[q]
        v_old = v[i]
        v[i] = (v_old * (1.0 - a) - c * (f0 - imp_force[q] * sv)) / (1.0 + a)
        unew[i] = u[i] + dt * v[i]
        load_q = imp_force[q] * sv - imp_damp[q] * 0.5 * (v_old + v[i])
        work = 0.5 * (imp_react[q] + load_q) * (u[i] - imp_prev[q])  # trapezoid over [t^{n−1}, t^n]
        imp_prev[q] = u[i]
        imp_react[q] = load_q
    elif q >= 0:
        # prescribed u1 = U(t^{n+1}), v1 = (U(t^{n+1}) − U(t^n))/dt; reaction R^n = M a^n + f^n;
        # its work over the step that ended at t^n, ½ (R^{n−1} + R^n)(U^n − U^{n−1}), is what the
        # central-difference energy identity E^{n+1} − E^n = ½ (F^n + F^{n+1})·(u^{n+1} − u^n) asks
        react = imp_mass[q] * (v_bc - v[i]) / dt + f0
        work = 0.5 * (imp_react[q] + react) * (u0 - imp_prev[q])  # trapezoid over [t^{n−1}, t^n]
        imp_prev[q] = u0
        imp_react[q] = react
        v[i] = v_bc
        unew[i] = u1
    elif d >= 0 and absorb[0][d, 0] > 0.0:
        absorbed += _damped(i, d, 0, f0, u, unew, v, dt_minv[I], dt, absorb)
    else:
        v[i] -= dt_minv[I] * f0
        unew[i] = u[i] + dt * v[i]
    if d >= 0 and absorb[0][d, 1] > 0.0:
        absorbed += _damped(i + 1, d, 1, f1, u, unew, v, dt_minv[I], dt, absorb)
    else:
        v[i + 1] -= dt_minv[I] * f1
        unew[i + 1] = u[i + 1] + dt * v[i + 1]
    return work, absorbed


@numba.njit(inline="always", cache=True)
def _wake_neighbours(ptr, col, act, n, I):
    """Row ``I`` holds a nonzero displacement from now on: its owned neighbours
    are computed from the next step on (or from this one, if still to come)."""
    for p in range(ptr[I], ptr[I + 1]):
        J = col[p]
        if J < n and act[J] == QUIET:
            act[J] = ACTIVE
    act[I] = SPREAD


_U0 = numba.uint64(0)
_U1 = numba.uint64(1)
_U2 = numba.uint64(2)
_U3 = numba.uint64(3)
_u64 = numba.uint64


@numba.njit(inline="always", cache=True)
def _row_u(ptr, col, val, x, I):
    """:func:`_row` with unsigned indices (``I`` uint64): no wrap-around tests on
    any index in the hot loop; the same sums in the same order."""
    s0 = 0.0
    s1 = 0.0
    for p in range(ptr[I], ptr[I + _U1]):
        j = _u64(col[p]) << _U1
        b = _u64(p) << _U2
        x0 = x[j]
        x1 = x[j + _U1]
        s0 += val[b] * x0
        s0 += val[b + _U1] * x1
        s1 += val[b + _U2] * x0
        s1 += val[b + _U3] * x1
    return s0, s1


@numba.njit(cache=True, _nrt=False)
def _plain_rows(ptr, col, val, x, u, unew, v, dt_minv, dt, act, lo, hi, uku):
    """The plain update of the rows ``lo`` <= I < ``hi`` (uint64; none of them
    special), adding each row's u·(K u) to ``uku`` in row order; returns it.

    A kernel of its own, over unsigned indices, with one skip test per row
    (quiet): the loop is then ~1.3× faster than with the special rows' test
    inside it (numba 0.56 / LLVM 11 on x86-64)."""
    n = ptr.size - 1
    for I in range(lo, hi):
        state = act[I]
        if state == QUIET:
            continue  # u = v = 0 here and at the neighbours: the update is exactly zero
        s0, s1 = _row_u(ptr, col, val, x, I)
        i = I << _U1
        i1 = i + _U1
        uku += u[i] * s0 + u[i1] * s1
        c = dt_minv[I]
        v[i] -= c * s0
        unew[i] = u[i] + dt * v[i]
        v[i1] -= c * s1
        unew[i1] = u[i1] + dt * v[i1]
        if state == ACTIVE and (unew[i] != 0.0 or unew[i1] != 0.0):
            _wake_neighbours(ptr, col, act, n, numba.int64(I))
    return uku


@numba.njit(cache=True, _nrt=False)
def sweep(rows, special, edge, load, x, u, unew, v, dt_minv, gl, gr, imp_prev, imp_react, absorb, act, fd):
    """One pass over the owned block rows, the deferred special rows excepted.

    x         float64[2 n]    what the rows multiply: u^n itself (``rows`` K's), or, for
                              spectral elements, K u^n already (their matrix-free action,
                              :func:`fricfem.kernels.sem.element_ku`; ``rows`` the identity)
    u         float64[2 n]    u^n (read)                        [m]
    unew      float64[2 n]    u^{n+1} (written)                 [m]
    v         float64[2 n]    v^{n−½} in, v^{n+½} out           [m/s]
    dt_minv   float64[n]      dt / lumped mass of each node     [s m/kg]
    gl, gr    float64[2 n]    the negative interface forces from the segment on a
                              node's left / right (zero off the interface) [N/m]
    imp_prev  float64[n_imp]  u^{n−1} of the struck dofs, set to u^n = U(t^n) [m]
    imp_react float64[n_imp]  their load (reaction) at t^{n−1}, set to the one at t^n [N/m]
    act       int8[n]         activity of each row (QUIET rows are skipped), updated
    fd        float64[2 n]    the Kelvin–Voigt layer's viscous force η K_L v^{n−½}, added
                              here to the special rows' K u (the plain rows: :func:`viscous_plain`);
                              empty without damping [N/m]

    Returns (u^n · K u^n over the swept rows [J/m, twice the strain energy],
    the load's work and the energy the dashpots absorbed over the step that
    ended at t^n [J/m]).
    """
    ptr, col, val = rows
    sp_node, _, sp_deferred, _, _ = special
    dt = load[0]
    n = ptr.size - 1
    uku = 0.0
    work = 0.0
    absorbed = 0.0
    lo = _U0
    for kk in range(sp_node.size):
        I = sp_node[kk]
        # the plain rows before this special one, then the special row: the rows in order
        uku = _plain_rows(ptr, col, val, x, u, unew, v, dt_minv, dt, act, lo, _u64(I), uku)
        lo = _u64(I) + _U1
        if I == n or sp_deferred[kk]:
            continue  # the sentinel; or in sweep_deferred, once the messages are in
        i = 2 * I
        s0, s1 = _row(ptr, col, val, x, I)
        uku += u[i] * s0 + u[i + 1] * s1
        if fd.size:  # Kelvin–Voigt: the layer's viscous force joins K u (not the strain energy)
            s0 += fd[i]
            s1 += fd[i + 1]
        w, ab = _special_update(I, kk, s0, s1, special, edge, load, u, unew, v, dt_minv, gl, gr, imp_prev,
                                imp_react, absorb)
        work += w
        absorbed += ab
        if act[I] != SPREAD and (unew[i] != 0.0 or unew[i + 1] != 0.0):
            _wake_neighbours(ptr, col, act, n, I)
    return uku, work, absorbed


@numba.njit(cache=True, _nrt=False)
def sweep_deferred(rows, special, edge, load, x, u, ug, unew, v, dt_minv, gl, gr, imp_prev, imp_react, absorb,
                   act, sp_ku, fd):
    """The deferred special rows (interface, MPI boundary), ``ug`` holding the
    gathered off-rank displacements; the preloaded rows' ``K u`` is taken from
    ``sp_ku`` (:func:`preload`).  Otherwise as :func:`sweep`."""
    ptr, col, val = rows
    sp_node, _, sp_deferred, sp_preloaded, _ = special
    n = ptr.size - 1
    uku = 0.0
    work = 0.0
    absorbed = 0.0
    for kk in range(sp_deferred.size):
        if not sp_deferred[kk]:
            continue
        I = sp_node[kk]
        i = 2 * I
        if sp_preloaded[kk]:
            s0 = sp_ku[2 * kk]
            s1 = sp_ku[2 * kk + 1]
        else:
            s0, s1 = _row_mixed(ptr, col, val, x, ug, n, I)
        uku += u[i] * s0 + u[i + 1] * s1
        if fd.size:  # Kelvin–Voigt, as in sweep
            s0 += fd[i]
            s1 += fd[i + 1]
        w, ab = _special_update(I, kk, s0, s1, special, edge, load, u, unew, v, dt_minv, gl, gr, imp_prev,
                                imp_react, absorb)
        work += w
        absorbed += ab
        if act[I] != SPREAD and (unew[i] != 0.0 or unew[i + 1] != 0.0):
            _wake_neighbours(ptr, col, act, n, I)
    return uku, work, absorbed


@numba.njit(cache=True, _nrt=False)
def viscous_forces(lrows, layer, v, vg, eta, fd, v_old):
    """The Kelvin–Voigt layer's force ``fd = η K_L v^{n−½}`` at its rows
    (``layer`` int64[m], owned nodes), K_L the stiffness of the layer's cells
    only (block rows as ``rows``; ``vg`` the gathered off-rank velocities), and
    each layer row's v^{n−½} kept in ``v_old`` float64[2 m] for the dissipation."""
    ptr, col, val = lrows
    n = ptr.size - 1
    for m in range(layer.size):
        I = layer[m]
        s0, s1 = _row_mixed(ptr, col, val, v, vg, n, I)
        fd[2 * I] = eta * s0
        fd[2 * I + 1] = eta * s1
        v_old[2 * m] = v[2 * I]
        v_old[2 * m + 1] = v[2 * I + 1]


@numba.njit(cache=True, _nrt=False)
def viscous_plain(layer, plain, fd, u, unew, v, dt_minv, dt, v_old):
    """After the sweeps: the viscous force of the layer's plain rows (``plain``
    int8[m]: 1 where the sweep did not add it), v^{n+½} −= dt M⁻¹ fd and u^{n+1}
    from it.  Returns (fd · (u^{n+1} − u^{n−1})/2, fd · (u^{n+1} − u^n)/2) [J/m]
    over this rank's layer rows: the first summed over the steps is the
    dissipation ½ Σ (fd^k + fd^{k+1}) · (u^{k+1} − u^k) up to t^n (the energy
    identity of central differences) plus the second, the half of step n's
    term that lies ahead of t^n."""
    dissipated = 0.0
    ahead = 0.0
    for m in range(layer.size):
        I = layer[m]
        for c in range(2):
            i = 2 * I + c
            if plain[m]:
                v[i] -= dt_minv[I] * fd[i]
                unew[i] = u[i] + dt * v[i]
            dissipated += fd[i] * 0.5 * (v_old[2 * m + c] + v[i]) * dt
            ahead += fd[i] * 0.5 * v[i] * dt
    return dissipated, ahead
