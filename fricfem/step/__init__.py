"""The time integrator: the fused bulk step, the interface's verbs, the state,
``step`` and ``evolve``."""

from .state import State
from .stepper import Reduction, Timing, evolve, n_steps, run, step

__all__ = ["Reduction", "State", "Timing", "evolve", "n_steps", "run", "step"]
