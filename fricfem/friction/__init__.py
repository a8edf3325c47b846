"""Friction laws: one module each, the same contract (see :mod:`.base`), a registry by name."""

from .base import Law, Param, defaults, pack, param_names, storage, validate
from . import povirk_needleman, povirk_needleman_rate_tangent, rate_state_aging, rate_state_slip, slip_weakening, stuck

LAWS = {law.name: law for law in (povirk_needleman.LAW, povirk_needleman_rate_tangent.LAW, slip_weakening.LAW,
                                   stuck.LAW, rate_state_aging.LAW, rate_state_slip.LAW)}


def get_law(name: str) -> Law:
    """The registered law called ``name``; a clear error lists the known ones."""
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(
            f"friction.law = {name!r}: unknown friction law; allowed: {', '.join(sorted(LAWS))}"
        ) from None


__all__ = ["Law", "Param", "LAWS", "get_law", "defaults", "pack", "param_names", "storage", "validate"]
