"""Isotropic linear elastic plate material: moduli and wave speeds (plane stress or strain)."""

from __future__ import annotations

import dataclasses
import math

from ..keys import field


@dataclasses.dataclass(frozen=True)
class Material:
    """Homalite by default (the paper's values).

    E [Pa], nu [-], rho [kg/m³]; ``plane`` is ``"stress"`` (the paper) or ``"strain"``.
    """

    E: float = field(5.2e9, "Pa", 1e3, 1e13, "Young's modulus (a soft gel to stiffer than diamond)")
    nu: float = field(0.34, "", -1.0, 0.5, "Poisson's ratio (near 0.5 in plane strain, or near -1, the "
                                          "stable step shrinks: see the cost estimate)", open_low=True,
                      open_high=True)
    rho: float = field(1230.0, "kg/m^3", 1.0, 1e5, "density")
    plane: str = field("stress", doc="in-plane state: 'stress' (the paper) or 'strain'", kind=str,
                       choices=("stress", "strain"))

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
