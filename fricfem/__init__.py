"""fricfem — dynamic frictional sliding between two elastic plates under shear impact.

Explicit finite elements (dolfinx/PETSc) for the bulk, one numba kernel for the
rate- and state-dependent frictional interface, after Coker, Lykotrafitis,
Needleman & Rosakis, *Frictional sliding modes along an interface between
identical elastic plates subject to shear impact loading*.
"""

__version__ = "0.1.0"
