"""Independent references for the point laws, with scipy.

Nothing here calls fricfem's integrators: the ODE references integrate each
law's continuous equations (``law.rates``, written from the papers in plain
Python) with scipy's stiff Radau IIA method, and the slip-weakening
references are exact piecewise (event-located) solutions.

:func:`spring_slider`
    the elastic-interface point that ``law.advance`` integrates:
    Ṫ_s = C_s (Δu̇_s(t) − sgn(T_s) v), v and the state's rate from
    ``law.rates``, slip' = v, work' = |T_s| v.  For a law with a stick/slip
    switch (``rates(..., branch=...)``, Povirk–Needleman) each regime is
    integrated with its own smooth right-hand side and the switch is located
    as an event of the sliding branch's continued slip rate (zero at β = 1),
    after which the integration restarts in the other regime; the right-hand
    side is continuous across the switch (v = 0 there), so the solution is
    C¹ and each segment smooth.
:func:`block_slider`
    the rigid (split-node) verb's continuous problem: a rigid block of mass
    per unit area m on the frictional contact, driven by a force per unit area
    F(t): m V̇ = F(t) − sgn(V) τ(|V|, state), state' from ``rates``, with τ
    the traction at which ``rates`` gives the slip rate |V| (found by brentq:
    the references only ever evaluate ``rates``).  A switching law sticks
    (V = 0) while |F| <= τ(0, state); slip weakening is solved exactly
    (:func:`slip_weakening_block`).
:func:`slip_weakening_spring`
    the exact solution of the slip-weakening elastic point for a
    non-decreasing imposed jump and constant T_n.

All return arrays at the requested times; the ODE references also return the
largest slip rate of the continuous solution (dense output between the
solver's steps), which can fall between the requested times.
"""

from __future__ import annotations

from .block import block_slider, drive_rigid, slip_weakening_block
from .common import Reference, mode_at
from .spring import slip_weakening_spring, spring_slider

__all__ = ["Reference", "block_slider", "drive_rigid", "mode_at", "slip_weakening_block", "slip_weakening_spring",
           "spring_slider"]
