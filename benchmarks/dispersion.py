"""The bulk's numerical dispersion, exact (Bloch analysis of the infinite
uniform lattice): the phase speed of P and S plane waves on fricfem's crossed
linear triangles with lumped mass and on the spectral elements (``mesh.degree``
2 to 6, GLL mass), semi-discrete and with the central-difference step at
``time.dt_safety`` 0.9 and 0.45 of the lattice's own stable step.

Why: at fixed h, a supershear rupture's speed on the linear triangles changes
with dt (benchmarks/results/dt_ladder.md: 2240 -> 2222 m/s at 0.2 mm as
dt_safety goes 0.9 -> 0.1125).  Central differences make waves faster, the
lumped linear elements slower, so the step cancels part of the space error;
halving it uncovers the error again.  This script measures that on the exact
discrete dispersion relation, and the same for the spectral elements.

Method.  A square cell h × h with periodic node types (crossed: the corner
and the centre; degree p: the p² GLL nodes of the cell not on its right or
top edge), the element's stiffness assembled with the Bloch phase e^{i k·Δx},
the lumped (GLL) mass; ω_h² the eigenvalues of M^-1/2 K(k) M^-1/2 (the two
acoustic branches: S, then P), and the stepped ω from sin(ω dt/2) = ω_h dt/2.
The stable step 2/√λmax, λmax over a 41 × 41 grid of k in the Brillouin zone.
Phase speed c_h = ω/k against c_p, c_s, at a given number of NODES per
wavelength (λ / (h/p)), waves along x1 and along the diagonal.

    .venv/bin/python benchmarks/dispersion.py

Results: benchmarks/results/dispersion.{json,md}.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from fricfem.model import sem
from fricfem.model.material import Material
from fricfem.scene.cost import _cell

RESULTS = Path(__file__).resolve().parent / "results"
MAT = Material(E=5.2e9, nu=0.34, rho=1230.0, plane="strain")  # Homalite, the peer problems'
NODES_PER_WAVELENGTH = (4, 6, 8, 12, 20)
SAFETY = (0.9, 0.45)


def cell(p: int) -> tuple:
    """(K float64[2n, 2n], mass float64[n], node positions float64[n, 2], node type int[n], types)
    of one h = 1 cell: crossed linear triangles (p = 1) or one degree-p element."""
    if p == 1:
        _, K, m = _cell(1.0, 1.0, MAT)
        pos = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], dtype=float)
        return K, m, pos, np.array([0, 0, 0, 0, 1]), 2
    n = (p + 1) ** 2
    ke = sem.element_blocks(np.array([1.0]), np.array([1.0]), p, MAT.lmbda, MAT.mu)[0]
    K = ke.reshape(n, n, 2, 2).transpose(0, 2, 1, 3).reshape(2 * n, 2 * n)
    m = sem.element_mass(np.array([1.0]), np.array([1.0]), p, MAT.rho)[0]
    xi, _ = sem.gll(p)
    g = 0.5 * (1 + xi)
    i, j = np.tile(np.arange(p + 1), p + 1), np.repeat(np.arange(p + 1), p + 1)
    pos = np.column_stack([g[i], g[j]])
    return K, m, pos, (j % p) * p + (i % p), p * p


def omegas(p: int, k: np.ndarray) -> tuple:
    """(ω_h² of the S wave, of the P wave) of the Bloch problem at wave vector k
    (h = 1): the eigenpairs whose Bloch amplitudes lie closest to a uniform
    displacement across k (P) or along it (S), the plane wave itself (beyond the
    cell's first Brillouin zone, k > π, the acoustic branches are folded among
    the optical ones, so they are picked by their shape, not as the lowest)."""
    A, M, nt = bloch(p, k, matrix=True)
    s = 1.0 / np.sqrt(M)
    w2, vec = np.linalg.eigh(s[:, None] * A * s[None, :])
    n = k / np.linalg.norm(k)
    out = []
    for d in (np.array([-n[1], n[0]]), n):  # S, then P
        target = np.sqrt(M) * np.tile(d, nt)
        out.append(float(w2[np.argmax(np.abs(vec.conj().T @ target))]))
    return tuple(out)


def bloch(p: int, k: np.ndarray, matrix: bool = False):
    """The Bloch matrix K(k) and the mass per node type (``matrix``), or
    (ω_h² increasing,) at wave vector k (h = 1)."""
    K, m, pos, typ, nt = cell(p)
    A = np.zeros((2 * nt, 2 * nt), complex)
    M = np.zeros(2 * nt)
    ph = np.exp(1j * ((pos[None, :, :] - pos[:, None, :]) @ k))  # [a, b]
    for a in range(len(typ)):
        M[2 * typ[a]: 2 * typ[a] + 2] += m[a]
        for b in range(len(typ)):
            A[2 * typ[a]: 2 * typ[a] + 2, 2 * typ[b]: 2 * typ[b] + 2] += K[2 * a: 2 * a + 2, 2 * b: 2 * b + 2] * ph[a, b]
    if matrix:
        return A, M, nt
    s = 1.0 / np.sqrt(M)
    return (np.linalg.eigvalsh(s[:, None] * A * s[None, :]),)


def lam_max(p: int) -> float:
    ks = np.linspace(0.0, math.pi, 41)
    return max(float(bloch(p, np.array([kx, ky]))[0][-1]) for kx in ks for ky in ks)


def study(p: int) -> dict:
    dt_crit = 2.0 / math.sqrt(lam_max(p))  # for h = 1; scales with h / c
    rows = []
    for direction, unit in (("x1", np.array([1.0, 0.0])), ("diagonal", np.array([1.0, 1.0]) / math.sqrt(2))):
        for npw in NODES_PER_WAVELENGTH:
            k = 2 * math.pi / (npw / p)  # wavelength npw node spacings, h/p each (h = 1)
            w2s, w2p = omegas(p, k * unit)
            row = {"direction": direction, "nodes_per_wavelength": npw}
            for wave, c, w in (("S", MAT.c_s, math.sqrt(w2s)), ("P", MAT.c_l, math.sqrt(w2p))):
                row[f"{wave}_semi"] = w / k / c
                for sf in SAFETY:
                    dt = sf * dt_crit
                    x = dt * w / 2
                    row[f"{wave}_{sf:g}"] = (2 / dt * math.asin(x) / k / c) if x <= 1 else float("nan")
            rows.append(row)
    return {"p": p, "dt_crit_cp_over_node_spacing": dt_crit * MAT.c_l * p, "rows": rows}


def table(doc: dict) -> str:
    lines = ["# The bulk's dispersion, exact (Bloch analysis)", "",
             "`.venv/bin/python benchmarks/dispersion.py` (method: its docstring). Phase speed over the wave "
             f"speed, Homalite in plane strain; columns: semi-discrete, and stepped at dt_safety "
             f"{' and '.join(str(s) for s in SAFETY)} of the lattice's stable step; Δ: the change of the "
             "phase speed between the two steps [%] (what a supershear front riding the P wave feels when "
             "dt_safety halves). p = 1: crossed linear triangles, lumped mass.", ""]
    for r in doc["studies"]:
        lines += [f"## p = {r['p']} (stable step {r['dt_crit_cp_over_node_spacing']:.3f} node spacings / c_p)", "",
                  "| direction | nodes / wavelength | P semi | P 0.9 | P 0.45 | Δ P [%] | S semi | S 0.9 | S 0.45 |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for row in r["rows"]:
            d = 100 * (row["P_0.9"] - row["P_0.45"])
            lines.append(f"| {row['direction']} | {row['nodes_per_wavelength']} | {row['P_semi']:.5f} | "
                         f"{row['P_0.9']:.5f} | {row['P_0.45']:.5f} | {d:+.3f} | {row['S_semi']:.5f} | "
                         f"{row['S_0.9']:.5f} | {row['S_0.45']:.5f} |")
        lines.append("")
    return "\n".join(lines)


def main() -> dict:
    doc = {"date": time.strftime("%Y-%m-%d %H:%M"), "studies": [study(p) for p in (1, 2, 3, 4, 5, 6)]}
    (RESULTS / "dispersion.json").write_text(json.dumps(doc, indent=1))
    (RESULTS / "dispersion.md").write_text(table(doc))
    print(table(doc))
    return doc


if __name__ == "__main__":
    main()
