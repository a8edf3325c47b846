"""Figures of run directories and mode maps (matplotlib; isochromatics with
pyvista).  Nothing in a run imports this package."""
