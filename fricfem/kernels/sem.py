"""numba kernel of the spectral elements' stiffness action, matrix-free and
sum-factorized (:mod:`fricfem.model.sem`; the step that calls it:
:mod:`fricfem.step.fused`).

For each element, with the nodal displacements u[j, i, c] (GLL index i along
x1, j along x2, component c), the derivatives at the nodes are one small
product along each grid line of the element (sum factorization, O(p³) an
element instead of the assembled O(p⁴))::

    ∂u/∂x1 [j, i] = (2/hx) Σ_k D[i, k] u[j, k],    ∂u/∂x2 [j, i] = (2/hy) Σ_k D[j, k] u[k, i]

the stresses at the nodes (isotropic, plane), weighted by the GLL quadrature
W[j, i] = w_i w_j hx hy / 4, and the forces the transposed products::

    f_c[j, i] = (2/hx) Σ_k D[k, i] (W σ_{c1})[j, k] + (2/hy) Σ_l D[l, j] (W σ_{c2})[l, i]

which is K_e u_e with K_e = (hy/hx) A + (hx/hy) B + C of
:func:`fricfem.model.sem.element_blocks` (the same integrals, summed in another
order: equal to round-off, ``tests/test_sem_operator.py``).

Rounding.  Each element's arithmetic is fixed, and a node's force is the sum
of its elements' contributions in the element list's order, which is the
grid's (the caller lists, on each rank, every element that touches an owned
node, increasing): a node's force has the same bits on any number of ranks.
"""

import numba
from numba.core import types
from numba.extending import overload


def _at(x, e):
    """``x[e]`` for an array, ``x`` itself for a scalar (compiled only: the moduli
    may be one per element or one for all, without a branch in the loop)."""
    raise NotImplementedError("_at is used inside numba kernels only")


@overload(_at, inline="always")
def _at_impl(x, e):
    if isinstance(x, types.Array):
        return lambda x, e: x[e]
    return lambda x, e: x


@numba.njit(inline="always", cache=True, _nrt=False)
def _element_ku(nodes, hx, hy, lmbda, mu, D, w, n1, u, ug, n_owned, f, scratch):
    """f = K u at the owned nodes, f float64[2 n_owned] (overwritten); inlined into
    one kernel a degree (:data:`KERNELS`).

    nodes   int64[n_el, (p+1)²]  each element's nodes as local indices: an owned
                                 node < n_owned, else n_owned + k, the k-th gathered one
                                 (node j (p+1) + i at GLL index i along x1, j along x2)
    hx, hy  float64[n_el]        element sizes [m]
    lmbda, mu  float, or float64[n_el]  Lamé moduli [Pa] (plane: the plane-stress λ
                                 already), one for all elements or one an element
                                 (several materials: each type compiles its own kernel)
    D       float64[p+1, p+1]    D[k, i] = l_i'(x_k) (:func:`fricfem.model.sem.derivative`)
    w       float64[p+1]         GLL weights
    n1      int                  p + 1 (a constant in each degree's kernel, :data:`KERNELS`)
    u       float64[2 n_owned]   displacements of the owned nodes, interleaved
    ug      float64[2 n_ghost]   of the gathered off-rank nodes
    scratch float64[3, p+1, p+1, 2]  work space (no allocation in the kernel)
    """
    ue = scratch[0]
    sx = scratch[1]  # W σ_{c1}: (σ11, σ21) weighted
    sy = scratch[2]  # W σ_{c2}: (σ12, σ22) weighted
    for k in range(f.size):
        f[k] = 0.0
    for e in range(nodes.shape[0]):
        ax = 2.0 / hx[e]
        ay = 2.0 / hy[e]
        quarter = 0.25 * hx[e] * hy[e]
        lm = _at(lmbda, e)
        m = _at(mu, e)
        lam2 = lm + 2.0 * m
        for j in range(n1):
            for i in range(n1):
                a = nodes[e, j * n1 + i]
                if a < n_owned:
                    ue[j, i, 0] = u[2 * a]
                    ue[j, i, 1] = u[2 * a + 1]
                else:
                    g = 2 * (a - n_owned)
                    ue[j, i, 0] = ug[g]
                    ue[j, i, 1] = ug[g + 1]
        for j in range(n1):
            for i in range(n1):
                d1x = 0.0  # ∂u1/∂ξ, ∂u2/∂ξ, ∂u1/∂η, ∂u2/∂η
                d2x = 0.0
                d1y = 0.0
                d2y = 0.0
                for k in range(n1):
                    d1x += D[i, k] * ue[j, k, 0]
                    d2x += D[i, k] * ue[j, k, 1]
                    d1y += D[j, k] * ue[k, i, 0]
                    d2y += D[j, k] * ue[k, i, 1]
                e11 = ax * d1x
                e22 = ay * d2y
                g12 = ay * d1y + ax * d2x
                W = w[i] * w[j] * quarter
                s11 = W * (lam2 * e11 + lm * e22)
                s22 = W * (lm * e11 + lam2 * e22)
                s12 = W * (m * g12)
                sx[j, i, 0] = s11
                sx[j, i, 1] = s12
                sy[j, i, 0] = s12
                sy[j, i, 1] = s22
        for j in range(n1):
            for i in range(n1):
                a = nodes[e, j * n1 + i]
                if a >= n_owned:
                    continue
                f0 = 0.0
                f1 = 0.0
                for k in range(n1):
                    f0 += ax * D[k, i] * sx[j, k, 0] + ay * D[k, j] * sy[k, i, 0]
                    f1 += ax * D[k, i] * sx[j, k, 1] + ay * D[k, j] * sy[k, i, 1]
                f[2 * a] += f0
                f[2 * a + 1] += f1


# One kernel a degree: the body inlined with p + 1 a constant (the closure's ``n1``, which
# numba compiles as a constant and keys its disk cache on), so that LLVM unrolls the loops
# over an element's lines (1.6x faster than one kernel for all degrees: 19 against 30 ns a
# node at p = 4, benchmarks/sem_operator.py).
def _kernel_of_degree(n1: int):
    @numba.njit(cache=True, _nrt=False)
    def ku(nodes, hx, hy, lmbda, mu, D, w, u, ug, n_owned, f, scratch):
        _element_ku(nodes, hx, hy, lmbda, mu, D, w, n1, u, ug, n_owned, f, scratch)

    return ku


#: The kernel of each degree p: ``KERNELS[p](nodes, hx, hy, λ, μ, D, w, u, ug, n_owned, f, scratch)``.
KERNELS = {p: _kernel_of_degree(p + 1) for p in range(2, 9)}


def element_ku(nodes, hx, hy, lmbda, mu, D, w, u, ug, n_owned, f, scratch):
    """f = K u at the owned nodes with the kernel of D's degree (arguments: :func:`_element_ku`)."""
    KERNELS[D.shape[0] - 1](nodes, hx, hy, lmbda, mu, D, w, u, ug, n_owned, f, scratch)
