"""The time integrator: the fused bulk step, the interface's verbs, the state,
``step`` and ``evolve``."""

from .state import State
from .stepper import evolve, step

__all__ = ["State", "evolve", "step"]
