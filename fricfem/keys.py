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

    def range_text(self) -> str:
        """``[0, 1e+09]``, ``(0, inf)`` or ``''`` when unbounded on both sides."""
        if self.low is None and self.high is None:
            return ""
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        return f"{'(' if self.open_low or self.low is None else '['}{lo}, {hi}" \
               f"{')' if self.open_high or self.high is None else ']'}"


def field(default, unit: str = "", low=None, high=None, doc: str = "", *, kind=NUM, open_low=False,
          open_high=False, choices=()):
    """A dataclass field that is also a scene key (its :class:`Key` in the metadata)."""
    return dataclasses.field(default=default, metadata={"key": Key(kind, default, unit, low, high, doc, open_low,
                                                                   open_high, tuple(choices))})


def keys_of(cls) -> dict:
    """{field name: :class:`Key`} of a dataclass declared with :func:`field`."""
    return {f.name: f.metadata["key"] for f in dataclasses.fields(cls) if "key" in f.metadata}
