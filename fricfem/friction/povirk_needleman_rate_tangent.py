"""The Povirk–Needleman law integrated as the paper does: one plain
rate-tangent update per bulk step (Peirce, Shih & Needleman 1984; the paper's
Appendix, steps 3–7), for comparison with fricfem's converged integration.

The law itself — parameters, state θ0, θ1, θ2, initial state, steady-state
μ_ss(v) and the slip-driven ``slide`` — is :mod:`.povirk_needleman`'s; only
``advance`` differs: :func:`.povirk_needleman.rate_tangent_advance`, with no
sub-steps, no located onset of slip and no implicit solve.  The paper's
automatic step control is not reproduced: the step is the bulk's.  Where this
update is unstable (slip rates of hundreds of m/s at a 20–100 ns step,
docs/friction.md) a run is stopped by the watchdog (NaN or a slip rate above
c_l).  ``gamma``, ``substep_tol`` and ``substep_stiff`` keep their names;
only ``gamma`` (the rate-tangent parameter γ) is read.

    friction.law = "povirk_needleman_rate_tangent"
"""

from . import povirk_needleman as pn
from .base import Law

LAW = Law(
    name="povirk_needleman_rate_tangent",
    doc="the Povirk–Needleman law with the paper's plain rate-tangent update, one per bulk step "
    "(for comparison; unstable at large slip rates)",
    params=pn.PARAMS,
    state=pn.STATE,
    advance=pn.rate_tangent_advance,
    steady_mu=pn.steady_mu,
    initial_state=pn.initial_state,
    slide=pn.slide,
)
