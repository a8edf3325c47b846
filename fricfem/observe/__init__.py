"""What a run does after every step, as observers of the one time loop
(:func:`fricfem.step.evolve`): watch it (:mod:`.watch`: the interface points'
one pass, the watchdog, spikes, the tip, signals) and write it
(:mod:`.outputs`: stations, energies, snapshots, fields, gauges, flushes,
the progress line).

The contract, one small object each:

* ``observe(state, energy) -> stop reason or None``, after every step
  (``energy``: the step's energies at t^n, or None when it took none);
* optionally ``slots`` (names), ``bind(reduction)`` and
  ``contribute(state, energy)``: an observer that needs a value over all
  ranks takes named slots of the loop's one reduction a step
  (:class:`fricfem.step.Reduction`), writes this rank's value in
  ``contribute`` (before any observer observes) and reads the result in
  ``observe``;
* optionally ``finish(state) -> dict``: after the loop, close what it
  writes; the entries it gives summary.json;
* ``part``: where its time goes in summary.json's ``loop_cost``
  (:data:`.outputs.LOOP_PARTS`).

Everything an observer accumulates is its own attribute, nothing set from
outside; the runner makes the observers of a run in one place
(:func:`fricfem.runner.observers`) and finishes them in order.

This package sits above :mod:`fricfem.step` and beside :mod:`fricfem.output`
(it decides when the writers write, they know the files), so that the
integrator below knows nothing of outputs.
"""

from .outputs import (FLUSH_ROWS, LOOP_PARTS, Background, Callback, Energies, Fields, Flusher, Gauges, Progress,
                      ProgressLine, Snapshots, Stations, loop_cost)
from .watch import (LawWatch, Look, Signals, Spikes, Tip, Watchdog, closure_bound, energy_scale, spike_threshold,
                    watchdog_code)

__all__ = ["FLUSH_ROWS", "LOOP_PARTS", "Background", "Callback", "Energies", "Fields", "Flusher", "Gauges",
           "LawWatch", "Look", "Progress", "ProgressLine", "Signals", "Snapshots", "Spikes", "Stations", "Tip",
           "Watchdog", "closure_bound", "energy_scale", "loop_cost", "spike_threshold", "watchdog_code"]
