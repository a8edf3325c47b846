"""The impact: a trapezoidal normal-velocity pulse on the struck edge (paper eq. 2–3).

V(t) rises linearly to ``v_imp`` over ``t_rise``, holds until ``t_hold_end``
(the paper's t_p), and falls linearly to zero over ``t_fall``.  By default the
edge is pushed into the specimen (+x1, ``direction = "push"``); the paper's
eq. (2) read literally, u1 = −∫V with V > 0, pulls it out (``"pull"``).  The
paper fixes t_r = t_s = 10 µs and t_p − t_r = 50 µs.

How V(t) acts on the edge (``kind``; the edge's shear traction is zero in all):

* ``"velocity"`` (the paper): the normal velocity of the edge is V(t);
* ``"traction"``: the normal traction ρ c_l V(t), the one that launches a
  plane longitudinal wave of particle velocity V(t) (it equals the paper's
  loading until waves come back to the edge);
* ``"projectile"``: a long projectile of acoustic impedance ``impedance``
  [Pa·s/m] moving at V(t) presses on the edge: traction Z (V(t) − v_edge)
  while the two move together (a steel bar: Z = ρ c ≈ 4.6·10⁷ Pa·s/m; as
  Z → ∞ the edge velocity tends to V(t)).
"""

from __future__ import annotations

import dataclasses

from ..keys import field


KINDS = ("velocity", "traction", "projectile")


@dataclasses.dataclass(frozen=True)
class ImpactPulse:
    """The trapezoidal pulse V(t) and how it acts on the struck edge (module docstring)."""

    v_imp: float = field(2.0, "m/s", 0.0, 1e3, "impact velocity V_imp")
    t_rise: float = field(10e-6, "s", 0.0, 1.0, "rise time t_r", open_low=True)
    t_hold_end: float = field(60e-6, "s", 0.0, 1.0, "end of the plateau t_p (>= t_rise)", open_low=True)
    t_fall: float = field(10e-6, "s", 0.0, 1.0, "step-down time t_s", open_low=True)
    direction: str = field("push", doc="'push' (the edge moves into the specimen, u1 = +∫V) or 'pull' "
                                       "(u1 = −∫V)", kind=str, choices=("push", "pull"))
    kind: str = field("velocity", doc="how V(t) acts: 'velocity' (edge velocity, the paper), 'traction' "
                                      "(normal traction ρ c_l V) or 'projectile' (impedance Z, traction "
                                      "Z (V − v_edge))", kind=str, choices=KINDS)
    impedance: float = field(4.6e7, "Pa·s/m", 0.0, 1e10, "projectile impedance ρc (kind = 'projectile'; "
                                                          "steel ≈ 4.6e7)", open_low=True)

    @property
    def sign(self) -> float:
        return 1.0 if self.direction == "push" else -1.0

    def velocity(self, t: float) -> float:
        """V(t) [m/s] (magnitude; the edge moves with ``sign`` · V)."""
        if t <= 0.0:
            return 0.0
        if t < self.t_rise:
            return self.v_imp * t / self.t_rise
        if t <= self.t_hold_end:
            return self.v_imp
        if t < self.t_hold_end + self.t_fall:
            return self.v_imp * (1.0 - (t - self.t_hold_end) / self.t_fall)
        return 0.0

    @property
    def prescribed(self) -> bool:
        """The edge's normal velocity is V(t) itself (kind ``"velocity"``)."""
        return self.kind == "velocity"

    def impedances(self, rho_cl: float) -> tuple:
        """(Z_f, Z_d) [Pa·s/m] of a traction load Z_f·sign·V(t) − Z_d·v_edge, for a
        specimen of impedance ``rho_cl`` = ρ c_l (kinds other than velocity)."""
        if self.kind == "traction":
            return rho_cl, 0.0
        return self.impedance, self.impedance

    def displacement(self, t: float) -> float:
        """Edge displacement u1 = sign · ∫₀ᵗ V dt [m], exact for the trapezoid."""
        return self.sign * self._integral(t)

    def _integral(self, t: float) -> float:
        tr, tp, tf, v = self.t_rise, self.t_hold_end, self.t_fall, self.v_imp
        if t <= 0.0:
            return 0.0
        if t < tr:
            return 0.5 * v * t * t / tr
        if t <= tp:
            return 0.5 * v * tr + v * (t - tr)
        s = min(t - tp, tf)
        return 0.5 * v * tr + v * (tp - tr) + v * (s - 0.5 * s * s / tf)
