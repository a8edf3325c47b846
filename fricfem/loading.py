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
import math


KINDS = ("velocity", "traction", "projectile")


@dataclasses.dataclass(frozen=True)
class ImpactPulse:
    v_imp: float = 2.0  # [m/s]
    t_rise: float = 10e-6  # [s]
    t_hold_end: float = 60e-6  # t_p [s]
    t_fall: float = 10e-6  # [s]
    direction: str = "push"  # "push": u1 = +∫V (into the specimen); "pull": u1 = −∫V
    kind: str = "velocity"  # "velocity" | "traction" | "projectile", see the module docstring
    impedance: float = 4.6e7  # [Pa·s/m] of the projectile (kind = "projectile")

    @property
    def sign(self) -> float:
        return 1.0 if self.direction == "push" else -1.0

    def check(self) -> None:
        if self.direction not in ("push", "pull"):
            raise ValueError(f"loading.direction = {self.direction!r}: allowed 'push' or 'pull'")
        if self.kind not in KINDS:
            raise ValueError(f"loading.kind = {self.kind!r}: allowed {', '.join(map(repr, KINDS))}")
        if not (math.isfinite(self.impedance) and self.impedance > 0):
            raise ValueError(f"loading.impedance = {self.impedance!r} Pa·s/m: must be positive")
        if not (math.isfinite(self.v_imp) and self.v_imp >= 0):
            raise ValueError(f"loading.v_imp = {self.v_imp!r} m/s: must be >= 0")
        if not self.t_rise > 0:
            raise ValueError(f"loading.t_rise = {self.t_rise!r} s: must be > 0")
        if not self.t_hold_end >= self.t_rise:
            raise ValueError(f"loading.t_hold_end = {self.t_hold_end!r} s: must be >= t_rise = {self.t_rise!r} s")
        if not self.t_fall > 0:
            raise ValueError(f"loading.t_fall = {self.t_fall!r} s: must be > 0")

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
