"""Spectral elements: Q_p Lagrange on the grid's rectangles with the nodes at the
Gauss–Lobatto–Legendre (GLL) points and GLL quadrature (``mesh.degree`` 2 to 8).

On a GLL lattice the quadrature points are the nodes, so the mass integrated by
it is exactly diagonal (no lumping), and the element stiffness of an
axis-aligned ``hx × hy`` rectangle splits into three reference matrices::

    K_e = (hy/hx) A + (hx/hy) B + C,

A from ∂x·∂x, B from ∂y·∂y and C from the mixed products (the λ and μ cross
terms), each a (p+1)² × (p+1)² array of 2×2 blocks in (K_xx, K_xy, K_yx,
K_yy) order, as :func:`fricfem.model.assembly.element_blocks` (P1).  The node
of an element with GLL indices (i along x1, j along x2) is ``j (p+1) + i``.

Everything here is plain float arithmetic in a fixed order (no LAPACK, no
BLAS products): the points, the weights and the matrices have the same bits
on any processor and under any BLAS.  The same points as basix's
``gll_warped`` variant of a degree-p Lagrange element (its nodes on an
interval are the GLL points; ``tests/test_sem.py`` compares them).
"""

from __future__ import annotations

import functools
import math

import numpy as np

#: Degrees of the spectral elements (``mesh.degree``; 1 is the paper's crossed P1 triangles).
DEGREES = (2, 3, 4, 5, 6, 7, 8)


def _legendre(n: int, x: float) -> tuple:
    """P_n(x), P_n'(x) by the three-term recurrence."""
    p0, p1 = 1.0, x
    if n == 0:
        return 1.0, 0.0
    for k in range(2, n + 1):
        p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
    if x * x == 1.0:
        return p1, 0.5 * n * (n + 1) * x ** (n + 1)
    return p1, n * (x * p1 - p0) / (x * x - 1.0)


@functools.lru_cache(maxsize=None)
def gll(p: int) -> tuple:
    """GLL points and weights on [−1, 1] for degree ``p`` (p + 1 points, increasing):
    ±1 and the roots of P_p', by Newton's method from the Chebyshev–Lobatto points;
    weights 2 / (p (p+1) P_p(x)²).  Returns (x float64[p+1], w float64[p+1]),
    symmetric to the last bit (the left half mirrored)."""
    if p < 1:
        raise ValueError(f"gll: degree {p} < 1")
    x = np.empty(p + 1)
    x[0], x[p] = -1.0, 1.0
    for i in range(1, p):
        z = -math.cos(math.pi * i / p)
        for _ in range(100):
            # f = P_p'(z); f' = P_p''(z) = (2 z P_p' − p (p+1) P_p)/(1 − z²)
            pn, dpn = _legendre(p, z)
            d2 = (2.0 * z * dpn - p * (p + 1) * pn) / (1.0 - z * z)
            step = dpn / d2
            z -= step
            if abs(step) < 1e-16:
                break
        x[i] = z
    half = (p + 1) // 2
    x[p + 1 - half:] = -x[:half][::-1]
    if p % 2 == 0:
        x[p // 2] = 0.0
    w = np.array([2.0 / (p * (p + 1) * _legendre(p, float(xi))[0] ** 2) for xi in x])
    w[p + 1 - half:] = w[:half][::-1]
    return x, w


@functools.lru_cache(maxsize=None)
def derivative(p: int) -> np.ndarray:
    """D[k, i] = l_i'(x_k), the derivative of the i-th GLL Lagrange polynomial at
    the k-th point, float64[p+1, p+1]."""
    x, _ = gll(p)
    P = np.array([_legendre(p, float(xi))[0] for xi in x])
    D = np.zeros((p + 1, p + 1))
    for k in range(p + 1):
        for i in range(p + 1):
            if k != i:
                D[k, i] = P[k] / (P[i] * (x[k] - x[i]))
    D[0, 0] = -p * (p + 1) / 4.0
    D[p, p] = p * (p + 1) / 4.0
    return D


@functools.lru_cache(maxsize=None)
def _gradients(p: int) -> tuple:
    """∂φ_a at every node q of the reference square [−1, 1]², per unit half-size:
    gx[q, a] = ∂φ_a/∂ξ (q), gy[q, a] = ∂φ_a/∂η (q); node index j (p+1) + i."""
    D = derivative(p)
    n = p + 1
    eye = np.eye(n)
    # q = (l, k) along (η, ξ), a = (j, i): ∂ξ φ_a(q) = D[k, i] δ(l, j); ∂η φ_a(q) = δ(k, i) D[l, j]
    gx = (eye[:, None, :, None] * D[None, :, None, :]).reshape(n * n, n * n)
    gy = (D[:, None, :, None] * eye[None, :, None, :]).reshape(n * n, n * n)
    return gx, gy


def reference_blocks(p: int, lmbda: float, mu: float) -> tuple:
    """(A, B, C), float64[(p+1)², (p+1)², 4] each: the element stiffness of an
    ``hx × hy`` rectangle is (hy/hx) A + (hx/hy) B + C (module docstring).
    With b = ∂φ/∂x, c = ∂φ/∂y and the GLL weights W_q = w_k w_l hx hy / 4::

        K_ab = Σ_q W_q [[(λ+2μ) b_a b_b + μ c_a c_b, λ b_a c_b + μ c_a b_b],
                        [λ c_a b_b + μ b_a c_b, (λ+2μ) c_a c_b + μ b_a b_b]]

    (b = (2/hx) ∂ξ, c = (2/hy) ∂η).  The sums over q are numpy's ``sum`` over an
    axis (no BLAS)."""
    _, w = gll(p)
    W = (w[:, None] * w[None, :]).ravel()  # node q = l (p+1) + k: w_l (η) w_k (ξ)
    gx, gy = _gradients(p)

    def prod(f, g):  # Σ_q W_q f[q, a] g[q, b]
        return (W[:, None, None] * f[:, :, None] * g[:, None, :]).sum(axis=0)

    def mirrored(m):  # symmetric to the last bit: the upper triangle reflected
        return np.triu(m) + np.triu(m, 1).T

    xx, yy, xy = mirrored(prod(gx, gx)), mirrored(prod(gy, gy)), prod(gx, gy)
    yx = xy.T.copy()  # Σ_q W_q ∂η φ_a ∂ξ φ_b = (Σ_q W_q ∂ξ φ_b ∂η φ_a): the transpose
    lam2 = lmbda + 2.0 * mu
    zero = np.zeros_like(xx)
    A = np.stack([lam2 * xx, zero, zero, mu * xx], axis=-1)
    B = np.stack([mu * yy, zero, zero, lam2 * yy], axis=-1)
    C = np.stack([zero, lmbda * xy + mu * yx, lmbda * yx + mu * xy, zero], axis=-1)
    return A, B, C


def element_blocks(hx: np.ndarray, hy: np.ndarray, p: int, lmbda, mu) -> np.ndarray:
    """Stiffness blocks of rectangles ``hx × hy`` (float64[n] each) [N/m per m
    thickness], float64[n, (p+1)², (p+1)², 4]; ``lmbda``, ``mu`` scalars or one per
    element."""
    hx, hy = np.asarray(hx, dtype=np.float64), np.asarray(hy, dtype=np.float64)
    if np.ndim(lmbda) == 0:
        A, B, C = reference_blocks(p, float(lmbda), float(mu))
        return (hy / hx)[:, None, None, None] * A + (hx / hy)[:, None, None, None] * B + C
    out = np.empty((len(hx), (p + 1) ** 2, (p + 1) ** 2, 4))
    for k in range(len(hx)):  # several materials: one reference set per element (the bodies; rare)
        A, B, C = reference_blocks(p, float(lmbda[k]), float(mu[k]))
        out[k] = (hy[k] / hx[k]) * A + (hx[k] / hy[k]) * B + C
    return out


def element_mass(hx: np.ndarray, hy: np.ndarray, p: int, rho) -> np.ndarray:
    """Each element's share of its nodes' (diagonal) mass, ρ w_i w_j hx hy / 4,
    float64[n, (p+1)²] [kg/m]."""
    _, w = gll(p)
    W = (w[:, None] * w[None, :]).ravel()
    share = np.asarray(rho, dtype=np.float64) * np.asarray(hx, dtype=np.float64) * np.asarray(hy) / 4.0
    return share[:, None] * W[None, :]


def lattice(edges: np.ndarray, p: int) -> tuple:
    """The GLL lattice of an axis cut into elements at ``edges`` (float64[n+1],
    increasing): (nodes float64[n p + 1], weights float64[n p + 1]) with the
    element edges exactly at ``edges`` and each node's weight ∫ l_i ds summed
    over its elements (the line's diagonal 'mass' per unit density)."""
    x, w = gll(p)
    a, b = edges[:-1], edges[1:]
    h = b - a
    inner = a[:, None] + 0.5 * (1.0 + x[None, 1:-1]) * h[:, None]
    nodes = np.empty(len(h) * p + 1)
    nodes[::p] = edges
    for i in range(1, p):
        nodes[i::p][: len(h)] = inner[:, i - 1]
    weights = np.zeros(len(nodes))
    for i in range(p + 1):
        weights[i: i + len(h) * p: p] += 0.5 * w[i] * h
    return nodes, weights
