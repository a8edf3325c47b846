"""``fricfem sweep``: the sliding-mode map over Σ0 × V_imp (the paper's Fig. 19).

Coker, Lykotrafitis, Needleman & Rosakis, "Dependence of the sliding mode on
the initial compressive stress and impact velocity": one calculation per
(Σ0, V_imp) on a grid, each classified as crack-like, pulse-like, a train of
pulses or mixed; a dashed line separates the crack-like from the pulse-like
region.  The paper also reports, without a map, that C_n, C_s × 10 gives only
crack-like sliding over the same range and ÷ 10 gives no trains; ``--variants``
computes those two maps too.

    fricfem sweep case1 --grid default --out runs/modemap
    mpirun -n 4 fricfem sweep case1 --sigma0 2,10,30 --v-imp 2,10,40 \\
        --preset coarse --set time.end=30e-6 --out runs/quick
    mpirun -n 2 fricfem sweep case1 --sigma0 0.9:40:32 --v-imp 1:40:32 --adaptive --out runs/adaptive

Every grid point is one scene, BASE + ``--preset`` + ``--set`` + the point's
``loading.sigma0``, ``loading.v_imp`` and ``output.fields = []``, run into
``DIR/points/s<Σ0 MPa>_v<V m/s>/`` (a normal run directory) by the batch
runner (:mod:`fricfem.batch`): resumable, heaviest first, taken by groups of
``--ranks-per-scene`` ranks as they free up, each group reusing one model for the scenes that
share a mesh and interface (:mod:`fricfem.model.reuse`).  ``--adaptive``
computes a coarse grid first and refines only where labels differ
(:mod:`.adaptive`).  Then rank 0 writes

- ``DIR/modemap.json``: the grid, the label table, the crack/pulse boundary and
  per point the label and its confidence, initiation, peak slip rate, median
  tip speed, wall time and the scene overrides;
- ``DIR/modemap.png`` (:mod:`fricfem.plot.modemap`);
- with ``--variants``: ``DIR/stiff_x10/`` and ``DIR/stiff_div10/`` (the same
  files) and ``DIR/modemap_variants.png`` with the three maps side by side.

Progress: rank 0 prints a line per point it finishes; every rank appends to
``DIR/sweep.log``.

Rooms: planning (:mod:`.planning`: axes, points, their scenes), one round of
points on the batch runner (:mod:`.rounds`), the adaptive map's rounds
(:mod:`.adaptive`), the records and ``modemap.json``/``.png``
(:mod:`.records`), the whole run (:mod:`.running`: :func:`sweep`) and the
command line (:mod:`.cli`: :func:`main`).
"""

from .cli import main
from .planning import DEFAULT_SIGMA0_MPA, DEFAULT_V_IMP, SWEPT_KEYS, VARIANTS, Point, check_label, parse_axis, plan
from .running import sweep

__all__ = ["DEFAULT_SIGMA0_MPA", "DEFAULT_V_IMP", "SWEPT_KEYS", "VARIANTS", "Point", "check_label", "main",
           "parse_axis", "plan", "sweep"]
