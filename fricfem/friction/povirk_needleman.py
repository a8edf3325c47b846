"""Povirk–Needleman rate- and state-dependent friction with Prakash–Clifton
normal-stress memory — the law of the paper (section "Rate- and
state-dependent friction law"; Povirk & Needleman 1993, Prakash & Clifton 1993).

The law record: its equations are :mod:`.povirk_needleman_equations`
(parameters, state θ0 [s], θ1, θ2 [Pa], g(θ0), the slip rate, μ_ss, the
continuous rates), fricfem's integrator over a bulk step
:mod:`.povirk_needleman_integrator` (``advance`` on the elastic interface,
``rigid`` on a split-node pair).  The names of both are available here.

    friction.law = "povirk_needleman"
"""

from .base import Law
from .povirk_needleman_equations import (  # noqa: F401  (the law's names, in one place)
    B, C, D, GAMMA, L0, L1, L2, M, MU_D, MU_S, N_STORAGE, P, PARAMS, STATE, SUB_STIFF, SUB_TOL, THETA0_INIT, V0, V1,
    _g_plain, g_and_dg, initial_state, rates, slide, slip_rate, steady_mu, steady_state, strength_factor)
from .povirk_needleman_integrator import MAX_SUBSTEPS, advance, rigid  # noqa: F401


LAW = Law(
    name="povirk_needleman",
    doc="rate- and state-dependent friction with normal-stress memory "
    "(Povirk & Needleman 1993, Prakash & Clifton 1993; the paper's law)",
    params=PARAMS,
    state=STATE,
    advance=advance,
    steady_mu=steady_mu,
    initial_state=initial_state,
    slide=slide,
    memo=N_STORAGE - len(STATE),
    rates=rates,
    rigid=rigid,
)
