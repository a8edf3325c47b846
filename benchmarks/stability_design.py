"""The stability stress test's design (``benchmarks/stability.py``): the factors and
their levels, the design points, each point's scene overrides, and the constants
and spring–slider thresholds the study and its report (``stability_report.py``)
share."""

from __future__ import annotations

import json
import math
import random

from fricfem import load_scene
from fricfem.observe import closure_bound

BASE = "case1"

# ## The factors
#
# Levels per factor and the Case I centre.  ``k`` scales both interface
# stiffnesses of the base scene (C_n = 0.3 MPa/µm, C_s = 0.1 MPa/µm).

LEVELS = {
    "sigma0_MPa": (0.1, 0.3, 1.0, 3.0, 6.0, 10.0, 30.0, 100.0),
    "v_imp_m_s": (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0),
    "k": (0.01, 0.1, 1.0, 10.0, 100.0),
    "dt_safety": (0.5, 0.6, 0.7, 0.8, 0.9, 0.95),
    "gamma": (0.0, 0.25, 0.45, 0.5, 0.6, 0.75, 1.0),
}
FACTORS = tuple(LEVELS)
CENTRE = {"sigma0_MPa": 6.0, "v_imp_m_s": 2.0, "k": 1.0, "dt_safety": 0.9, "gamma": 0.5}
DEFAULT = {"dt_safety": 0.9, "gamma": 0.5}  # fricfem's defaults (time.dt_safety, friction.params.gamma)
LABELS = {"sigma0_MPa": "Σ0 [MPa]", "v_imp_m_s": "V_imp [m/s]", "k": "C_n, C_s × k",
          "dt_safety": "dt_safety", "gamma": "γ"}

#: Loadings (Σ0 MPa, V_imp m/s, k) of the full γ × dt grid: all slide by 40 µs.
GAMMA_DT_LOADINGS = ((6.0, 10.0, 1.0), (30.0, 100.0, 1.0), (6.0, 20.0, 100.0))
#: Stiffness factors of the full Σ0 × V_imp grids.
SIGMA_V_K = (0.01, 1.0, 100.0)
#: Unstable contrast: time.dt = factor × dt_crit at these loadings (Σ0 MPa, V_imp m/s, k).
UNSTABLE_FACTORS = (1.05, 1.2, 1.5)
UNSTABLE_LOADINGS = ((6.0, 2.0, 1.0), (6.0, 10.0, 1.0), (30.0, 100.0, 1.0), (6.0, 20.0, 100.0))
LHS_POINTS = 40
LHS_SEED = 20240603

KINDS = ("ok", "watchdog", "rejected", "error")


def key_of(pt: dict) -> str:
    """Directory-safe name of a point: s<Σ0>_v<V>_k<k>_d<dt_safety>_g<γ> or ..._dt<f>x."""
    head = f"s{pt['sigma0_MPa']:g}_v{pt['v_imp_m_s']:g}_k{pt['k']:g}"
    if pt.get("dt_factor"):
        return f"{head}_dt{pt['dt_factor']:g}x"
    return f"{head}_d{pt['dt_safety']:g}_g{pt['gamma']:g}"


# ## The design


def design(smoke: bool = False) -> list:
    """Every point: {factor: level, ..., "parts": [...]} (unstable ones carry ``dt_factor``)."""
    points = {}

    def add(part, **pt):
        pt = {f: float(pt[f]) for f in FACTORS} | ({"dt_factor": float(pt["dt_factor"])}
                                                   if pt.get("dt_factor") else {})
        points.setdefault(key_of(pt), pt | {"parts": []})["parts"].append(part)

    if smoke:
        add("ofat", **CENTRE)
        add("corner", sigma0_MPa=100.0, v_imp_m_s=100.0, k=100.0, dt_safety=0.95, gamma=1.0)
        add("corner", sigma0_MPa=0.1, v_imp_m_s=100.0, k=0.01, dt_safety=0.5, gamma=0.5)
        add("ofat", **(CENTRE | {"gamma": 0.25}))
        add("unstable", **CENTRE, dt_factor=1.5)
        return list(points.values())

    lo_hi = {f: (LEVELS[f][0], LEVELS[f][-1]) for f in FACTORS}
    for corner in range(2 ** len(FACTORS)):
        add("corner", **{f: lo_hi[f][(corner >> i) & 1] for i, f in enumerate(FACTORS)})
    for f in FACTORS:
        for level in LEVELS[f]:
            add("ofat", **(CENTRE | {f: level}))
    for s, v, k in GAMMA_DT_LOADINGS:
        for g in LEVELS["gamma"]:
            for d in LEVELS["dt_safety"]:
                add("gamma_dt", sigma0_MPa=s, v_imp_m_s=v, k=k, dt_safety=d, gamma=g)
    for k in SIGMA_V_K:
        for s in LEVELS["sigma0_MPa"]:
            for v in LEVELS["v_imp_m_s"]:
                add("sigma_v", sigma0_MPa=s, v_imp_m_s=v, k=k, **DEFAULT)
    rng = random.Random(LHS_SEED)
    columns = {}
    for f in FACTORS:
        col = [LEVELS[f][i % len(LEVELS[f])] for i in range(LHS_POINTS)]
        rng.shuffle(col)
        columns[f] = col
    for i in range(LHS_POINTS):
        add("lhs", **{f: columns[f][i] for f in FACTORS})
    for s, v, k in UNSTABLE_LOADINGS:
        for fac in UNSTABLE_FACTORS:
            add("unstable", sigma0_MPa=s, v_imp_m_s=v, k=k, **DEFAULT, dt_factor=fac)
    return list(points.values())


def overrides(pt: dict, t_end: float, base_cn: float, base_cs: float) -> list:
    """``--set`` items turning Case I into the point's scene (no ``time.dt``: see :func:`run_point`)."""
    cn = float(f"{base_cn * pt['k']:.12g}")
    cs = float(f"{base_cs * pt['k']:.12g}")
    return [
        "mesh.preset='coarse'",
        "output.fields=[]",
        "output.interface_every=1e-9",  # below any step: a snapshot every step
        f"time.end={t_end!r}",
        f"loading.sigma0={round(pt['sigma0_MPa'] * 1e6, 3)!r}",
        f"loading.v_imp={pt['v_imp_m_s']!r}",
        f"interface.Cn={cn!r}",
        f"interface.Cs={cs!r}",
        f"time.dt_safety={pt['dt_safety']!r}",
        f"friction.params.gamma={pt['gamma']!r}",
        f"name={json.dumps('stability_' + key_of(pt))}",
    ]


def expected_cost(pt: dict) -> float:
    """Relative cost, to deal the heavy points first: steps ∝ 1/dt (the interface
    springs shorten the step from k ≈ 10 on), sub-steps grow with V_imp."""
    return (1.0 + math.sqrt(pt["k"] / 10.0)) / pt["dt_safety"] * (1.0 + pt["v_imp_m_s"] / 20.0)


#: A γ × dt cell agrees with the default cell when it is ok with the same mode
#: and a peak slip rate within this fraction of the default's.
PEAK_TOL = 0.05


#: The energy terms of the history (``energy/`` of interface.h5) the checks need.
ENERGY_TERMS = ("time", "kinetic", "strain", "external", "interface_work", "absorbed", "balance_error")

#: An energy history that a sound explicit run cannot have, relative to each
#: row's energy scale: a negative kinetic energy (the staggered ½ v^{n−½}·M v^{n+½}
#: turns negative when v alternates in sign from step to step, the signature of
#: a step beyond the stable one), or a balance error beyond round-off.  The
#: watchdog's own default bound (``watchdog.energy_tol``), checked here again on
#: the stored history of every complete run.
ENERGY_REL = closure_bound(load_scene(BASE).watchdog)


def growth_floor(k: float) -> float:
    """m L0 C_s / B [Pa] with Table 1 and C_s = k × the base scene's: the least |T_s| at
    which a sliding point's slip rate can still grow (docs/friction_reference.md §4.1a)."""
    p = load_scene(BASE).params
    return p["m"] * p["L0"] * load_scene(BASE).Cs * k / p["B"]


def hopf_floor(k: float) -> float:
    """e C_s L0 / (B (μs − μd) p) [Pa]: the least normal traction T_n,c(v) (at v = V1) above
    which steady sliding is unstable and stick–slip sets in (docs/friction_reference.md §4.1c)."""
    p = load_scene(BASE).params
    return math.e * load_scene(BASE).Cs * k * p["L0"] / (p["B"] * (p["mu_s"] - p["mu_d"]) * p["p"])
