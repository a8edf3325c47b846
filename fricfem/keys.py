"""What a scene key is: type, default, unit, allowed range and meaning — stated once.

The model's dataclasses (:class:`fricfem.model.mesh.MeshSpec`,
:class:`fricfem.model.material.Material`, :class:`fricfem.model.loading.ImpactPulse`)
declare their fields with :func:`field`, and the scene schema
(:mod:`fricfem.scene.schema`) is generated from them; keys that belong to no
dataclass are declared in the schema with :class:`Key` directly.  Nothing here
imports the rest of fricfem.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, NamedTuple

NUM = (int, float)


class Key(NamedTuple):
    """One scene key: type, default, unit, allowed range (closed unless marked open), meaning."""

    kind: type | tuple
    default: Any
    unit: str = ""
    low: float | None = None
    high: float | None = None
    doc: str = ""
    open_low: bool = False
    open_high: bool = False
    choices: tuple = ()  # allowed values of a string key (empty: any)
    band: tuple = ()  # (low, high): the physically plausible values; outside them a warning, not a refusal

    def implausible(self, where: str, v) -> str | None:
        """A warning when a number lies outside :attr:`band` (0, which means "off" for
        the keys that allow it, aside), with the value it was likely meant to be
        (``loading.sigma0 = 10 Pa: ... did you mean 10 MPa = 1e7?``); else None."""
        if not self.band or isinstance(v, bool) or not isinstance(v, (int, float)) or v == 0:
            return None
        lo, hi = self.band
        if lo <= abs(v) <= hi:
            return None
        text = f"{where} = {v:g} {self.unit}: outside the plausible {_short(lo)} … {_short(hi)} {self.unit}" \
            f" (a unit slip?)"
        centre = abs(self.default) if isinstance(self.default, NUM) and self.default else (lo * hi) ** 0.5
        fits = [(abs(math.log(abs(v) * f / centre)), f, name) for f, name in _PREFIXES.get(self.unit, ())
                if lo <= abs(v) * f <= hi]
        if fits:
            _, f, name = min(fits)
            text += f"; did you mean {v:g} {name} = {_short(v * f)}?"
        return text

    def range_text(self) -> str:
        """``[0, 1e+09]``, ``(0, inf)`` or ``''`` when unbounded on both sides."""
        if self.low is None and self.high is None:
            return ""
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        return f"{'(' if self.open_low or self.low is None else '['}{lo}, {hi}" \
               f"{')' if self.open_high or self.high is None else ']'}"


#: unit -> (factor to the unit, the prefixed unit) a value given in the wrong unit was likely meant in
_PREFIXES = {
    "Pa": ((1e3, "kPa"), (1e6, "MPa"), (1e9, "GPa")),
    "m/s": ((1e3, "km/s"), (1e-3, "mm/s")),
    "m": ((1e-3, "mm"), (1e-6, "µm")),
    "s": ((1e-6, "µs"), (1e-3, "ms")),
}


def _short(x: float) -> str:
    """``1e7`` rather than ``1e+07``."""
    t = f"{x:.6g}"
    mant, e, exp = t.partition("e")
    return f"{mant}e{int(exp)}" if e else t


def field(default, unit: str = "", low=None, high=None, doc: str = "", *, kind=NUM, open_low=False,
          open_high=False, choices=(), band=()):
    """A dataclass field that is also a scene key (its :class:`Key` in the metadata);
    ``band``: the physically plausible (low, high), warned about outside (:meth:`Key.implausible`)."""
    return dataclasses.field(default=default, metadata={"key": Key(kind, default, unit, low, high, doc, open_low,
                                                                   open_high, tuple(choices), tuple(band))})


def keys_of(cls) -> dict:
    """{field name: :class:`Key`} of a dataclass declared with :func:`field`."""
    return {f.name: f.metadata["key"] for f in dataclasses.fields(cls) if "key" in f.metadata}
