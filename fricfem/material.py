"""Isotropic linear elastic plate material: moduli and wave speeds (plane stress or strain)."""

from __future__ import annotations

import dataclasses
import math


@dataclasses.dataclass(frozen=True)
class Material:
    """Homalite by default (the paper's values).

    E [Pa], nu [-], rho [kg/m³]; ``plane`` is ``"stress"`` (the paper) or ``"strain"``.
    """

    E: float = 5.2e9
    nu: float = 0.34
    rho: float = 1230.0
    plane: str = "stress"

    def check(self) -> None:
        if not (math.isfinite(self.E) and self.E > 0):
            raise ValueError(f"material.E = {self.E!r} Pa: must be positive")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"material.nu = {self.nu!r}: must lie in (-1, 0.5)")
        if not (math.isfinite(self.rho) and self.rho > 0):
            raise ValueError(f"material.rho = {self.rho!r} kg/m^3: must be positive")
        if self.plane not in ("stress", "strain"):
            raise ValueError(f"material.plane = {self.plane!r}: allowed 'stress' or 'strain'")

    @property
    def mu(self) -> float:
        """Shear modulus [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lmbda(self) -> float:
        """In-plane Lamé λ [Pa]: 2λμ/(λ+2μ) in plane stress, λ in plane strain."""
        lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        if self.plane == "stress":
            return 2.0 * lam * self.mu / (lam + 2.0 * self.mu)
        return lam

    @property
    def c_l(self) -> float:
        """In-plane longitudinal (dilatational) wave speed [m/s]."""
        return math.sqrt((self.lmbda + 2.0 * self.mu) / self.rho)

    @property
    def c_s(self) -> float:
        """Shear wave speed [m/s]."""
        return math.sqrt(self.mu / self.rho)

    @property
    def c_R(self) -> float:
        """Rayleigh wave speed [m/s]: root of (2 - ξ)² = 4 √(1 - ξ k²) √(1 - ξ), ξ = (c/c_s)², k = c_s/c_l."""
        k2 = (self.c_s / self.c_l) ** 2

        def r(xi):
            return (2.0 - xi) ** 2 - 4.0 * math.sqrt(1.0 - xi * k2) * math.sqrt(1.0 - xi)

        # r < 0 just above the trivial root ξ = 0 and r(1) = 1 > 0; the Rayleigh
        # root lies in (0.5, 1) for every admissible ν.
        lo, hi = 0.5, 1.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if r(mid) < 0:
                lo = mid
            else:
                hi = mid
        return self.c_s * math.sqrt(0.5 * (lo + hi))

    def speeds(self) -> dict:
        return {"c_l": self.c_l, "c_s": self.c_s, "c_R": self.c_R, "sqrt2_c_s": math.sqrt(2.0) * self.c_s}
