"""The impact: a trapezoidal normal-velocity pulse on the struck edge (paper eq. 2–3).

V(t) rises linearly to ``v_imp`` over ``t_rise``, holds until ``t_hold_end``
(the paper's t_p), and falls linearly to zero over ``t_fall``.  By default the
edge is pushed into the specimen (+x1, ``direction = "push"``); the paper's
eq. (2) read literally, u1 = −∫V with V > 0, pulls it out (``"pull"``).  The
paper fixes t_r = t_s = 10 µs and t_p − t_r = 50 µs.
"""

from __future__ import annotations

import dataclasses
import math


@dataclasses.dataclass(frozen=True)
class ImpactPulse:
    v_imp: float = 2.0  # [m/s]
    t_rise: float = 10e-6  # [s]
    t_hold_end: float = 60e-6  # t_p [s]
    t_fall: float = 10e-6  # [s]
    direction: str = "push"  # "push": u1 = +∫V (into the specimen); "pull": u1 = −∫V

    @property
    def sign(self) -> float:
        return 1.0 if self.direction == "push" else -1.0

    def check(self) -> None:
        if self.direction not in ("push", "pull"):
            raise ValueError(f"loading.direction = {self.direction!r}: allowed 'push' or 'pull'")
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
