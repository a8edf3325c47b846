"""numba kernels: arrays and scalars only, no PETSc or dolfinx (the bulk sweep,
:mod:`.bulk`; the interface loop, :mod:`.interface`).

Importing the package first checks numba's disk cache against fricfem's
numba sources (:func:`.cache.ensure_fresh`), before any of them is compiled
or loaded: a function compiled (and cached) before the check would be removed
by it and compiled again by the next process."""

from .cache import ensure_fresh

ensure_fresh()
