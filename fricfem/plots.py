"""Constants shared by the figures (the run figures themselves are in :mod:`fricfem.runplots`)."""

#: Homalite-100: stress-optic constant f_σ [N/m] and specimen thickness [m] (the experiments'),
#: for isochromatic fringe orders N = (σ1 − σ2) h / f_σ.
F_SIGMA = 22.6e3
THICKNESS = 9.525e-3
