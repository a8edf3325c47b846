"""numba kernels: arrays and scalars only, no PETSc or dolfinx (the bulk sweep,
:mod:`.bulk`; the interface loop, :mod:`.interface`)."""
