"""The run directory: its one table of quantities (:mod:`.quantities`), the
writers (:mod:`.recorder`, :mod:`.fields`) and the reader (:mod:`.rundir`)."""
