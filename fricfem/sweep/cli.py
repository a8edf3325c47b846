"""The command line of ``fricfem sweep`` (:mod:`fricfem.sweep`): arguments, the
cost check before any run, the printed table.  docs/sweep.md describes it."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from mpi4py import MPI

from ..analysis.modemap import table, tag
from ..model.mesh import preset_names
from ..scene import SceneError, cost
from .planning import DEFAULT_SIGMA0_MPA, DEFAULT_V_IMP, check_label, parse_axis, plan
from .running import sweep

#: ``--coarse`` default: values per axis of the adaptive map's first grid.
COARSE = 5


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are printed by rank 0 of ``comm`` only."""

    comm = MPI.COMM_WORLD

    def error(self, message):
        if self.comm.rank == 0:
            self.print_usage(sys.stderr)
            print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def parser(comm=MPI.COMM_WORLD) -> argparse.ArgumentParser:
    p = _Parser(prog="fricfem sweep", description="the sliding-mode map over Σ0 × V_imp (paper's Fig. 19); "
                "resumable, parallel over points under mpirun")
    p.add_argument("scene", metavar="BASE_SCENE", help="shipped scene name or .toml file every point starts from")
    p.add_argument("--sigma0", metavar="LIST",
                   help="Σ0 values in MPa: comma-separated (0.9,2,4) or LO:HI:N (N values even in log, 0.9:40:32)")
    p.add_argument("--v-imp", metavar="LIST",
                   help="V_imp values in m/s: comma-separated (1,2,4) or LO:HI:N (1:40:32)")
    p.add_argument("--grid", choices=["default"],
                   help="the default 8 × 8 grid (Σ0 0.9–40 MPa, V_imp 1–40 m/s) for any axis not given")
    p.add_argument("--adaptive", action="store_true",
                   help="compute a coarse grid (--coarse) and refine, by bisection in log Σ0 and log V_imp, only "
                        "the cells whose points differ in label, down to the grid given (the finest resolution)")
    p.add_argument("--coarse", type=int, metavar="M",
                   help=f"with --adaptive: values per axis of the first grid (default {COARSE}; both ends included)")
    p.add_argument("--set", action="extend", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a scene key for every point (repeatable; not loading.sigma0/v_imp)")
    p.add_argument("--preset", choices=list(preset_names()), help="mesh preset for every point")
    p.add_argument("--out", required=True, metavar="DIR", help="sweep directory (resumed if it holds points)")
    p.add_argument("--label", metavar="NAME",
                   help="the map's title (default: from the physics: law, mesh, end time, stiffnesses)")
    p.add_argument("--variants", action="store_true",
                   help="also the maps with C_n, C_s × 10 (DIR/stiff_x10) and ÷ 10 (DIR/stiff_div10)")
    p.add_argument("--overwrite", action="store_true",
                   help="recompute complete points whose stored inputs differ from this sweep's")
    p.add_argument("--rerun-stopped", action="store_true",
                   help="recompute the complete points the watchdog stopped (same inputs; e.g. after a change "
                        "of the watchdog's code)")
    p.add_argument("--ranks-per-scene", type=int, default=1, metavar="K",
                   help="run each point on K ranks (K divides the number of ranks; default 1)")
    p.add_argument("--no-reuse", action="store_true",
                   help="build every point's model afresh (for comparison; by default the points of a group share "
                        "one model per mesh and interface: same results, bit for bit)")
    p.add_argument("--quiet", action="store_true", help="no per-point progress lines on stderr")
    p.add_argument("--force", action="store_true",
                   help="run points (or a map) whose estimated cost is above the budget (docs/scenes.md)")
    p.comm = comm
    return p


def _check_cost(args, s, v, comm) -> tuple:
    """Every point's scene within the budget (each point, and the map's total dof·steps;
    an adaptive map counts as the full grid, its upper bound), unless ``--force``; the
    points' scale warnings once, on rank 0.  Nothing is built.  Returns the plan
    (maps, points), which the sweep then uses."""
    maps, points = plan(args.scene, s, v, args.set, args.preset, args.variants, Path(args.out))
    total = 0.0
    warned = []
    for p in points:
        try:
            est = cost.check(p.job.scene, force=args.force)
        except SceneError as err:
            raise SceneError(f"point Σ0 = {tag(p.sigma0_mpa)} MPa, V_imp = {tag(p.v_imp)} m/s: {err}") from None
        total += est.dof_steps
        warned += [w for w in p.job.scene.warnings if w not in warned]
    if total > cost.BUDGET["dof_steps"] and not args.force:
        raise SceneError(f"{len(points)} points: about {total:.3g} dof·steps in all, above the budget of "
                         f"{cost.BUDGET['dof_steps']:.3g}; pass --force to run them anyway")
    if comm.rank == 0:
        for w in warned[:3]:
            print(f"fricfem sweep: warning: {w}", file=sys.stderr)
        if len(warned) > 3:
            print(f"fricfem sweep: warning: ... and {len(warned) - 3} more", file=sys.stderr)
    return maps, points


def _axes(args, comm) -> tuple:
    """The checked axes (and the adaptive map's coarse grid), or a SceneError."""
    if args.sigma0 is None and args.grid is None:
        raise SceneError("--sigma0: give the Σ0 values (MPa), or --grid default")
    if args.v_imp is None and args.grid is None:
        raise SceneError("--v-imp: give the V_imp values (m/s), or --grid default")
    if args.grid and args.sigma0 is not None and args.v_imp is not None:
        raise SceneError("--grid default: not used when --sigma0 and --v-imp are both given")
    for opt in ("out", "label", "scene"):
        value = getattr(args, opt)
        if value is not None and not value.strip():
            raise SceneError(f"{'--' + opt if opt != 'scene' else 'BASE_SCENE'} {value!r}: empty")
    if args.label is not None:
        check_label(args.label)
    s = parse_axis(args.sigma0, "--sigma0", "MPa") if args.sigma0 is not None else DEFAULT_SIGMA0_MPA
    v = parse_axis(args.v_imp, "--v-imp", "m/s") if args.v_imp is not None else DEFAULT_V_IMP
    if args.ranks_per_scene < 1 or comm.size % args.ranks_per_scene:
        raise SceneError(f"--ranks-per-scene {args.ranks_per_scene}: must divide the number of ranks "
                         f"({comm.size})")
    if not args.adaptive:
        if args.coarse is not None:
            raise SceneError(f"--coarse {args.coarse}: only with --adaptive")
        return s, v, None
    m = COARSE if args.coarse is None else args.coarse
    if not 2 <= m <= min(len(s), len(v)):
        raise SceneError(f"--coarse {m}: must lie in [2, {min(len(s), len(v))}] (values per axis of the first "
                         f"grid, at most the {len(s)} × {len(v)} grid's)")
    return s, v, (m, m)


def main(argv=None, comm=MPI.COMM_WORLD) -> int:
    """``fricfem sweep ...`` (collective): 0 when every point is complete, 1 if some are not
    (failed or interrupted: rerun to resume), 2 on bad input (nothing run)."""
    try:
        args = parser(comm).parse_args(argv)
    except SystemExit as stop:
        return 2 if stop.code else 0
    try:
        s, v, coarse = _axes(args, comm)
        planned = _check_cost(args, s, v, comm)
        res = sweep(args.scene, s, v, args.out, args.set, args.preset, args.label, args.variants,
                    args.overwrite, args.quiet, comm, args.ranks_per_scene, adaptive=coarse,
                    reuse=not args.no_reuse, planned=planned, rerun_stopped=args.rerun_stopped)
    except SceneError as err:
        if comm.rank == 0:
            print(f"fricfem sweep: error: {err}", file=sys.stderr)
        return 2
    except RuntimeError as err:  # rank 0 failed planning or writing the map: raised on every rank alike
        if comm.rank == 0:
            print(f"fricfem sweep: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 1
    status_code = 0
    if comm.rank == 0:
        for doc in res["maps"].values():
            ad = doc.get("adaptive")
            if doc["incomplete"] or (ad and not ad["finished"]):
                status_code = 1
        try:
            _print_maps(res, s, v, args, comm)
        except BrokenPipeError:  # `fricfem sweep ... | head`: the reader left; the map is written, every rank ends
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return comm.bcast(status_code, root=0)


def _print_maps(res, s, v, args, comm) -> None:
    """Rank 0: each map's label table and counts, the combined figure, the wall time (stdout)."""
    for doc in res["maps"].values():
        print(f"{doc['title']}  ({doc['dir']}/modemap.json, .png)")
        print(table(s, v, doc["labels"]["values"]))
        bad = doc["incomplete"]
        ad = doc.get("adaptive")
        if ad:
            print(f"  adaptive: {ad['scenes']} scenes of {len(s) * len(v)} points in {len(ad['rounds'])} "
                  f"rounds {ad['rounds']}; the other labels inferred from their cells")
        print(f"  computed {len(doc['computed'])}, reused {len(doc['reused'])}, incomplete {len(bad)}"
              + (f": {', '.join(bad)} (see {doc['dir']}/sweep.log; rerun to resume)" if bad else ""))
        print()
    if len(res["maps"]) > 1:
        print(f"combined figure: {Path(args.out) / 'modemap_variants.png'}")
    print(f"total wall time {res['wall_s']:.1f} s on {comm.size} rank(s)", flush=True)


if __name__ == "__main__":
    sys.exit(main())
