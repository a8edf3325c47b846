"""What a scene will cost, estimated from the scene alone (no mesh built), and
the budget a run must fit unless ``--force`` is given.

Sizes.  The mesh is a tensor grid per plate (:mod:`fricfem.model.grid`): its
node lines along x1 and x2 come from :func:`~fricfem.model.grid.axis_nodes`,
which is cheap (1-D arrays), so the counts below are exact: ``nx × ny``
quadrilaterals per plate, ``(nx+1)(ny+1) + nx·ny`` nodes (corners and centres),
2 dofs per node, 4 interface Gauss points per segment.  Before calling it the
counts are bounded in closed form (:func:`axis_count`), so an absurd cell
size is refused without allocating anything.

The step.  The run's step is ``dt_safety · 2/√λmax`` of M⁻¹(K + K_int)
(:mod:`fricfem.model.assembly`).  λmax is bracketed without assembling
anything:

* above, by Weyl's inequality and the element eigenvalue theorem (the global
  λmax of lumped-mass elements is at most the largest element λmax):
  ``λmax <= λ_elem + λ_spring``, where ``λ_elem`` is the largest eigenvalue of
  one crossed-triangle element pair of the smallest cell (hx = smallest x1
  spacing, hy = smallest x2 spacing of the grid: every pair is a cell of the
  tensor grid, and shrinking either side only raises an element's λmax) with
  its row-sum lumped mass ρA/3 per node, and ``λ_spring = 6 max(C_n, C_s) /
  (ρ hy1)`` bounds the interface springs by Gershgorin (a node pair on the
  interface: stiffness 2 C ∫N_i ds against the lumped mass ρ ∫N_i ds · hy1/3,
  hy1 the height of the first cell row);
* below, by Rayleigh quotients of single dofs: the centre node of the smallest
  cell (K_ii / M_ii) and an interface node with its spring.

So ``dt_low = dt_safety · 2/√(λ_elem + λ_spring)`` and ``dt_high = dt_safety ·
2/√λ_low`` bracket the step (before its rounding down to 3 digits); the
number of steps is taken from ``dt_low`` (conservative: never fewer than the
run will take), "at least one step" from ``dt_high``.  A fixed ``time.dt``
is used as given.  Checked against built models (tests/test_hostile_input.py,
docs/scenes.md): the built λmax lies inside the bracket.

Memory.  The peak resident memory of a run, summed over its ranks, is
``(MEMORY["rank"] + MEMORY["compile"]) × ranks + MEMORY["quad"] ×
quadrilaterals`` plus the interface snapshots rank 0 keeps for the end-of-run diagnostics
(:func:`memory_bytes`): a fit to the peaks measured with
``benchmarks/memory.py`` (below, at :data:`MEMORY`).  The peak is the
set-up's (the loop adds under 1 %).  A scene whose estimate, for the ranks
on this node, exceeds the node's available memory (``MemAvailable`` of
/proc/meminfo) is refused unless ``--force``, before any mesh is built
(the out-of-memory killer would otherwise end it during the set-up).

Budget (:data:`BUDGET`): a run above any of these is refused unless
``--force``; above :data:`HARD` it is refused always.
"""

from __future__ import annotations

import math
import os
import sys
from typing import NamedTuple

import numpy as np

from ..model.bodies import _steel_axis
from ..model import sem
from ..model.grid import axis_nodes
from .schema import SceneError

#: Refused unless ``--force``: quadrilaterals, steps, dofs × steps, interface output bytes.
BUDGET = {"quads": 5e6, "steps": 2e6, "dof_steps": 2e11, "output_bytes": 2e10}
#: Refused always (rank 0 builds the whole grid in memory; ~1 kB per quadrilateral
#: through numpy and dolfinx): quadrilaterals, steps.
HARD = {"quads": 5e7, "steps": 1e9}

#: Above these (but within the budget) the command says how large the run is, one line.
NOTICE = {"quads": 1e6, "dof_steps": 1e10}
#: dof updates per second and rank assumed for the time a notice states (the fine mesh
#: runs at ~1e8 per rank: README, Speed).
RATE = 1e8

#: The interface quantities stored per point and snapshot (interface.h5), an upper bound.
_QUANTITIES = 12

#: Peak resident memory [bytes], summed over the ranks: ``rank`` per rank (the interpreter,
#: dolfinx, PETSc, numba and the compiled kernels: 184 MB of it after the imports) and ``quad``
#: per quadrilateral of the grid (mesh, numbering, K's rows, K as a PETSc matrix, the fused
#: rows; 4.0 dofs per quadrilateral on these grids, so 3.0 kB per dof).  Least-squares fit to
#: 12 cold set-ups (FRICFEM_CACHE off: λmax by power iteration, K assembled), rsf_aging_2d with
#: mesh.fine_height = 24 mm at h = 0.5, 0.25, 0.125 mm (16.8k, 62.7k, 237k quadrilaterals),
#: interface.kind rigid and elastic, absorbing edges off and on, 2 ranks, VmHWM summed over
#: the ranks after a 2 µs loop: 612-637, 1163-1170, 3268-3314 MB; the fit is within 26 MB of
#: every run, and neither the interface kind nor the absorbing edges move the peak by more
#: (K's assembly and the power iteration add 30 MB at 237k); checked off the fit at h = 0.05 mm,
#: a 4 mm band (325k quadrilaterals, 1.3M dofs): 4342 MB measured, 4356 MB fitted:
#:
#:     export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1
#:     mpirun -n 2 .venv/bin/python benchmarks/memory.py --h 1.25e-4 --band 0.024 --kind elastic
#:
#: (issue 26 saw 11.3 GB at 950k quadrilaterals: 0.41 + 11.5 GB by this fit.)  ``compile``: a
#: rank that compiles the kernels (the first run after a change of a kernel's source, numba's
#: cache then refilled) holds LLVM's memory besides, 0.28 GB a rank (h = 1 mm, 2 ranks: 1010
#: MB against 448 MB with the cache warm); the estimate counts it, so as never to be short.
MEMORY = {"rank": 2.05e8, "quad": 1.215e4, "compile": 2.8e8}


def axis_count(length, fine, h, ratio, hmax) -> float:
    """Upper bound on the number of cells :func:`fricfem.model.grid.axis_nodes`
    makes on ``[0, length]`` (closed form: no arrays), breaks aside (+2 each).

    Inside ``fine = (a, b)`` the spacing is ``h``; at a distance ``d`` outside
    it ``s(d) = min(hmax, h + (ratio − 1) d)``, so ``∫ dd / s`` is a logarithm
    up to the distance where ``s`` reaches ``hmax`` and linear beyond.
    """
    a, b = fine

    def outside(dist):
        if dist <= 0:
            return 0.0
        if ratio <= 1.0 or hmax <= h:
            return dist / min(h, hmax)
        d_cap = (hmax - h) / (ratio - 1.0)
        n = math.log1p((ratio - 1.0) * min(dist, d_cap) / h) / (ratio - 1.0)
        return n + max(0.0, dist - d_cap) / hmax

    return (b - a) / h + outside(a) + outside(length - b) + 4.0


def _triangle_k(p, mat) -> np.ndarray:
    """6×6 stiffness of a linear triangle with corners ``p`` [3, 2] (plane, per unit thickness)."""
    (x1, y1), (x2, y2), (x3, y3) = p
    area = 0.5 * abs((x2 - x1) * (y3 - y1) - (x3 - x1) * (y2 - y1))
    b = np.array([y2 - y3, y3 - y1, y1 - y2]) / (2 * area)
    c = np.array([x3 - x2, x1 - x3, x2 - x1]) / (2 * area)
    B = np.zeros((3, 6))
    B[0, 0::2] = b
    B[1, 1::2] = c
    B[2, 0::2] = c
    B[2, 1::2] = b
    lam, mu = mat.lmbda, mat.mu
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    return area * B.T @ D @ B, area


def _cell(hx, hy, mat):
    """Crossed-triangle cell hx × hy: (largest element λ with lumped mass, K of the
    5-node cell [10, 10], lumped mass per node [5]); nodes: 4 corners then the centre."""
    pts = np.array([[0.0, 0.0], [hx, 0.0], [hx, hy], [0.0, hy], [hx / 2, hy / 2]])
    K = np.zeros((10, 10))
    m = np.zeros(5)
    lam_e = 0.0
    for tri in ((0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)):
        ke, area = _triangle_k(pts[list(tri)], mat)
        me = mat.rho * area / 3.0
        lam_e = max(lam_e, float(np.linalg.eigvalsh(ke).max()) / me)
        dofs = np.ravel([[2 * n, 2 * n + 1] for n in tri])
        K[np.ix_(dofs, dofs)] += ke
        m[list(tri)] += me
    return lam_e, K, m


class Estimate(NamedTuple):
    """The size and cost of a scene's run, from the scene alone."""

    quads: float  # quadrilaterals, both plates
    nodes: float
    dofs: float
    interface_points: float
    h_min: tuple  # (smallest x1 spacing, smallest x2 spacing) [m]
    dt_crit: tuple  # (low, high) [s]: the stable step 2/√λmax lies between them
    dt_low: float  # [s] the run's step is at least this (conservative)
    dt_high: float  # [s] and at most this
    dt_fixed: bool  # time.dt given: dt_low = dt_high = time.dt
    steps: float  # from dt_low: never fewer than the run takes
    dof_steps: float
    output_bytes: float  # interface.h5, about
    memory_bytes: float = 0.0  # peak resident memory, all ranks together (:func:`memory_bytes`)
    ranks: int = 1  # the ranks memory_bytes is for

    def over(self, limits: dict) -> list:
        """The (what, estimate, limit) triples above ``limits``."""
        return [(k, getattr(self, k), v) for k, v in limits.items() if getattr(self, k) > v]

    def text(self) -> str:
        dt = (f"dt = {self.dt_low:.3g} s (time.dt)" if self.dt_fixed
              else f"dt ≈ {self.dt_low:.3g} … {self.dt_high:.3g} s")
        return (f"{self.quads:.3g} quadrilaterals, {self.dofs:.3g} dofs, {self.interface_points:.3g} interface "
                f"points, smallest cell {self.h_min[0]:.3g} × {self.h_min[1]:.3g} m; {dt}, about "
                f"{self.steps:.3g} steps; {self.dof_steps:.3g} dof·steps; interface output about "
                f"{self.output_bytes / 1e6:.3g} MB; memory about {self.memory_bytes / 1e9:.3g} GB on "
                f"{self.ranks} rank(s)")

    def as_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self._asdict().items()}


def size_bound(spec) -> float:
    """Upper bound on the quadrilaterals of a mesh spec, closed form (no arrays)."""
    nx = axis_count(spec.length, (spec.fine_x0, spec.fine_x1), spec.dx, spec.grading, spec.max_size)
    ny = axis_count(spec.height, (0.0, spec.fine_height), spec.dy, spec.grading, spec.max_size) + 2
    return 2.0 * nx * ny


def axes(spec) -> tuple:
    """The grid's node lines (x1 nodes, x2 nodes of one plate from the interface), exact."""
    xs = axis_nodes(spec.length, (spec.fine_x0, spec.fine_x1), spec.dx, spec.grading, spec.max_size, ())
    ys = axis_nodes(spec.height, (0.0, spec.fine_height), spec.dy, spec.grading, spec.max_size, (spec.impact_b,))
    return xs, ys


def gauss_x1(xs) -> np.ndarray:
    """x1 of every interface Gauss point (4 per segment between consecutive x1 nodes)."""
    xi = np.polynomial.legendre.leggauss(4)[0]
    mid, half = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (xs[1:] - xs[:-1])
    return (mid[:, None] + half[:, None] * xi[None, :]).ravel()


def step_bracket(mat, hx: float, hy: float, hy1: float, Cn: float, Cs: float) -> tuple:
    """(λ_low, λ_high) bracketing λmax of M⁻¹(K + K_int) (module docstring)."""
    lam_e, K, m = _cell(hx, hy, mat)
    c = max(Cn, Cs)
    lam_spring = 6.0 * c / (mat.rho * hy1)
    high = lam_e + lam_spring
    # Rayleigh quotients of single dofs: the centre node; an interface corner node
    # (two cells hx × hy1 side by side share it: its bulk diagonal from both, its
    # mass ρ hx hy1 / 3, its spring C ∫N_i² ds = C (2 hx / 3)).
    centre = max(K[8, 8], K[9, 9]) / m[4]
    _, K1, m1 = _cell(hx, hy1, mat)
    # corner 0 of one cell + corner 1 of its neighbour; x1 dof with C_s, x2 dof with C_n
    kx, ky = K1[0, 0] + K1[2, 2], K1[1, 1] + K1[3, 3]
    corner = max(kx + Cs * 2.0 * hx / 3.0, ky + Cn * 2.0 * hx / 3.0) / (m1[0] + m1[1])
    return max(centre, corner), high


def sem_bracket(mat, hx: float, hy: float, p: int, Cn: float = 0.0, Cs: float = 0.0) -> tuple:
    """(λ_low, λ_high) bracketing λmax of M⁻¹(K + K_int) on spectral elements of
    degree ``p`` (:mod:`fricfem.model.sem`), the smallest element ``hx × hy``:
    λmax of the one element with its own diagonal mass is above (the
    element-by-element bound), and a quarter of it below (a node shares its
    element's mass with at most 3 more).  The elastic interface's springs (``Cn``,
    ``Cs`` [Pa/m]; 0: the rigid kind) join at the interface nodes: a node's spring
    C w_x hx/2 over its mass ρ (w_x hx/2)(w_end hy/2) is 2C/(ρ w_end hy), w_end =
    2/(p(p+1)) the end GLL weight across the interface; twice that (the pair's
    relative mode) is added above, and the one-node Rayleigh quotient is below."""
    w_end = 2.0 / (p * (p + 1))  # the end GLL weight on [-1, 1]
    spring = 2.0 * max(Cn, Cs) / (mat.rho * w_end * hy)  # one interface node's spring over its mass
    ke = sem.element_blocks(np.array([hx]), np.array([hy]), p, mat.lmbda, mat.mu)[0]
    n = (p + 1) ** 2
    K = ke.reshape(n, n, 2, 2).transpose(0, 2, 1, 3).reshape(2 * n, 2 * n)
    m = np.repeat(sem.element_mass(np.array([hx]), np.array([hy]), p, mat.rho)[0], 2)
    s = 1.0 / np.sqrt(m)
    lam = float(np.linalg.eigvalsh(s[:, None] * K * s[None, :]).max())
    return max(lam / 4.0, spring), lam + 2.0 * spring


def sem_cost(p: int) -> float:
    """A spectral element's memory against a quadrilateral of crossed triangles:
    K is never assembled (matrix-free), so what grows is the lattice's carrier
    mesh, 2 p² triangles an element against the crossed quadrilateral's 4, with
    the nodes and vectors in proportion."""
    return p * p / 2.0


def steel(exp, ys) -> tuple:
    """(cells, nodes, largest element λ) of the experiment's steel bodies
    (:mod:`fricfem.model.bodies`): the buffer spans the plate's x2 lines ``ys``,
    the projectile those within its diameter, both at ``steel_dx`` along x1, two
    triangles a cell, the buffer's last column the plate's own nodes.  The λ is
    the larger of the two triangles of the narrowest steel cell (steel_dx × the
    smallest x2 spacing) with its lumped mass; the bodies' thickness factors scale
    stiffness and mass alike, so they leave it unchanged."""
    nb = len(_steel_axis(-exp.buffer_length, 0.0, exp.steel_dx)) - 1
    n_p = len(_steel_axis(-exp.buffer_length - exp.projectile_length, -exp.buffer_length, exp.steel_dx)) - 1
    ny = len(ys) - 1
    ny_p = int(np.count_nonzero(ys < exp.projectile_diameter * (1 + 1e-12)) - 1)  # rows below its diameter
    cells = float(nb * ny + n_p * ny_p)
    nodes = float(nb * (ny + 1) + (n_p + 1) * (ny_p + 1))
    hx = min(exp.buffer_length / nb, exp.projectile_length / n_p)
    hy = float(np.diff(ys).min())
    mat = exp.steel()
    lam = 0.0
    with np.errstate(all="ignore"):
        for tri in (((0.0, 0.0), (hx, 0.0), (hx, hy)), ((0.0, 0.0), (hx, hy), (0.0, hy)),
                    ((0.0, 0.0), (hx, 0.0), (0.0, hy)), ((hx, 0.0), (hx, hy), (0.0, hy))):
            ke, area = _triangle_k(np.array(tri), mat)
            lam = max(lam, float(np.linalg.eigvalsh(ke).max()) / (mat.rho * area / 3.0))
    return cells, nodes, lam


def memory_bytes(quads: float, ranks: int, snapshot_bytes: float = 0.0) -> float:
    """Peak resident memory of a run [bytes], all ``ranks`` together (:data:`MEMORY`),
    plus ``snapshot_bytes``: the interface rows rank 0 keeps until the end."""
    return (MEMORY["rank"] + MEMORY["compile"]) * max(int(ranks), 1) + MEMORY["quad"] * quads + snapshot_bytes


def available_bytes() -> float | None:
    """This node's available memory [bytes] (``MemAvailable`` of /proc/meminfo), or None
    where there is no such file."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        return None
    return None


def memory_text() -> str:
    """What this node has available, for ``fricfem run --check``."""
    free = available_bytes()
    return "available here: unknown (no /proc/meminfo)" if free is None else \
        f"available here: {free / 1e9:.3g} GB (MemAvailable)"


def node_ranks() -> tuple:
    """(ranks of the run, ranks on this node), without a collective call: from the MPI
    launcher's environment (Open MPI's ``OMPI_COMM_WORLD_SIZE``/``_LOCAL_SIZE``, MPICH's
    ``PMI_SIZE``/``MPI_LOCALNRANKS``), else mpi4py's world if it is loaded, else (1, 1)."""

    env = os.environ
    for world, local in (("OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_LOCAL_SIZE"), ("PMI_SIZE", "MPI_LOCALNRANKS")):
        try:
            n = int(env[world])
            return n, int(env.get(local, n))
        except (KeyError, ValueError):
            continue
    mpi = sys.modules.get("mpi4py.MPI")
    n = mpi.COMM_WORLD.size if mpi is not None else 1
    return n, n


def estimate(scene, ranks: int = 1) -> Estimate:
    """The size, step and cost of a validated scene's run on ``ranks`` ranks (no mesh built)."""
    spec = scene.mesh
    xs, ys = axes(spec)
    nx, ny = len(xs) - 1, len(ys) - 1
    quads = 2.0 * nx * ny
    p = int(spec.degree)
    nodes = 2.0 * ((nx + 1) * (ny + 1) + nx * ny) if p == 1 else 2.0 * (nx * p + 1) * (ny * p + 1)
    hx, hy = float(np.diff(xs).min()), float(np.diff(ys).min())
    with np.errstate(all="ignore"):
        try:
            springs = (0.0, 0.0) if scene.interface_kind == "rigid" else (scene.Cn, scene.Cs)  # rigid: none
            if p > 1:  # spectral elements: the springs at the interface's GLL nodes
                lam_low, lam_high = sem_bracket(scene.material, hx, hy, p, *springs)
            else:
                lam_low, lam_high = step_bracket(scene.material, hx, hy, float(ys[1] - ys[0]), *springs)
        except (np.linalg.LinAlgError, ValueError, OverflowError, ZeroDivisionError):
            lam_low = lam_high = math.inf
    exp = getattr(scene, "experiment", None)
    if exp is not None:  # the steel buffer and projectile: their cells, nodes and stiffest triangle
        cells, extra, lam_steel = steel(exp, ys)
        quads, nodes = quads + cells, nodes + extra
        hx = min(hx, exp.steel_dx)
        lam_low, lam_high = max(lam_low, lam_steel / 2.0), max(lam_high, lam_steel)
    kv = math.sqrt(1.0 + 2.0 * scene.damping_eta)  # a Kelvin–Voigt layer (model.build)
    crit = tuple(2.0 / math.sqrt(lam) / kv if 0 < lam < math.inf else 0.0 for lam in (lam_high, lam_low))
    if scene.dt:
        dt_low = dt_high = scene.dt
    else:
        dt_low, dt_high = (scene.dt_safety * c for c in crit)
    ratio = scene.t_end / dt_low if dt_low > 0 else math.inf
    steps = float(math.floor(ratio + 1e-9)) if math.isfinite(ratio) else math.inf
    # node pairs (the rigid kind; the elastic kind on spectral elements) or 4 Gauss points a segment
    points = nx * p + 1.0 if scene.interface_kind == "rigid" or p > 1 else 4.0 * nx
    snaps = min(steps, scene.t_end / scene.output.interface_every) + 1
    stations = len(scene.output.stations)
    out = 8.0 * (snaps * points * _QUANTITIES + (steps + 1) * stations * _QUANTITIES)
    mem = memory_bytes(quads * (1.0 if p == 1 else sem_cost(p)), ranks, 8.0 * snaps * points * _QUANTITIES)
    return Estimate(quads, nodes, 2 * nodes, points, (hx, hy), crit, dt_low, dt_high, bool(scene.dt), steps,
                    2 * nodes * steps, out, mem, max(int(ranks), 1))


def notice(est: Estimate, ranks: int = 1) -> str | None:
    """One line when a run within the budget is still large (:data:`NOTICE`), else None."""
    if not est.over(NOTICE):
        return None
    minutes = est.dof_steps / (RATE * max(ranks, 1)) / 60.0
    return (f"a large run: {est.text()}; roughly {minutes:.2g} min of time loop on {ranks} rank(s) "
            f"(at {RATE:.0e} dof updates per second per rank)")


_WHAT = {"quads": "quadrilaterals", "steps": "steps", "dof_steps": "dof·steps", "output_bytes": "bytes of output"}


def check(scene, force: bool = False, ranks=None, available=None) -> Estimate:
    """The estimate, or a SceneError when it exceeds :data:`HARD`, or, without
    ``force``, :data:`BUDGET` or the memory available on this node; the message
    states both.  ``ranks``: (ranks of the run, ranks on this node), default
    :func:`node_ranks`; ``available`` [bytes]: default :func:`available_bytes`
    (None: not checked).  Not collective."""
    n, local = node_ranks() if ranks is None else ranks
    est = estimate(scene, n)
    hard = est.over(HARD)
    if hard:
        what, value, limit = hard[0]
        raise SceneError(f"{scene.name}: about {value:.3g} {_WHAT[what]} estimated; at most {limit:.3g} are "
                         f"possible (even with --force). Estimate: {est.text()}")
    over = est.over(BUDGET)
    if over and not force:
        what, value, limit = over[0]
        raise SceneError(f"{scene.name}: about {value:.3g} {_WHAT[what]} estimated, above the budget of "
                         f"{limit:.3g}; pass --force to run it anyway. Estimate: {est.text()}")
    free = available_bytes() if available is None else available
    here = est.memory_bytes * min(local, n) / max(n, 1)  # this node's share of the ranks
    if free is not None and here > free and not force:
        raise SceneError(f"{scene.name}: about {here / 1e9:.3g} GB of memory estimated for the {min(local, n)} "
                         f"rank(s) on this node, above the {free / 1e9:.3g} GB available (MemAvailable); "
                         f"pass --force to run it anyway. Estimate: {est.text()}")
    return est
