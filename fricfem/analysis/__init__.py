"""Interface diagnostics: the leading sliding tip and its speed, slipping
regions, rupture and healing fronts, the sliding mode.

Pure numpy, no dolfinx and no MPI: every function acts on gathered interface
histories (a run directory's ``interface.h5``, :mod:`fricfem.output.rundir`),
identical on every rank.  The paper's measures (Coker, Lykotrafitis, Needleman
& Rosakis, "Numerical Results"): the leading sliding tip is the point furthest
from the impact edge (x1 = 0) where Δu̇_slip > 0, and V_tip follows from its
positions by "a progressive least squares fit using five points"
(:func:`tip_speed`).  Definitions: docs/diagnostics.md.
"""

from .classify import LABELS, SNAPSHOT_TYPES, Criteria, classify
from . import rupture
from .fronts import Front, fronts
from .regions import Region, cell_lengths, slip_regions
from .speeds import SPEED_NAMES, mach_numbers, regime
from .tip import leading_tip, tip_history, tip_record, tip_speed

__all__ = ["LABELS", "SNAPSHOT_TYPES", "SPEED_NAMES", "Criteria", "Front", "Region", "cell_lengths", "classify",
           "fronts", "leading_tip", "mach_numbers", "regime", "rupture", "slip_regions", "tip_history", "tip_record",
           "tip_speed"]
