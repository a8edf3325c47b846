"""What a run is made of and assembles once: material, loading, the two-plate
mesh, K and the lumped mass, the interface geometry and points, and the
:class:`~fricfem.model.build.Model` that holds them."""
