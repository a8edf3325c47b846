"""The ``fricfem`` command: ``fricfem mesh --preset reference --info`` and friends.

Every sub-command works under ``mpirun -n N``; only rank 0 prints.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys


def _mesh(args) -> int:
    from mpi4py import MPI

    from . import scene as scene_mod
    from .model import mesh

    if args.scene:  # the mesh of a scene, its [mesh] table and --set mesh.* applied
        raw = scene_mod.apply_overrides(scene_mod.resolve(args.scene),
                                        [f"mesh.{item}" for item in args.set or []])
        if args.preset:
            raw.setdefault("mesh", {})["preset"] = args.preset
        spec = scene_mod.validate(raw).mesh
    else:
        table = {"preset": args.preset or "reference"}
        for item in args.set or []:
            keys, value = scene_mod.parse_override(f"mesh.{item}")
            table[keys[-1]] = value
        spec = scene_mod.validate({"mesh": table}).mesh  # every key checked by the schema
    if args.write and MPI.COMM_WORLD.rank == 0:
        folder = os.path.dirname(os.path.abspath(args.write))
        if not os.path.isdir(folder):
            raise scene_mod.SceneError(f"--write {args.write!r}: folder {folder!r} does not exist")
    pm = mesh.build(spec, MPI.COMM_WORLD, msh_file=args.write)
    info = mesh.info(pm)
    if MPI.COMM_WORLD.rank == 0:
        if args.info or not args.write:
            print(json.dumps(info, indent=2))
        if args.write:
            print(f"wrote {args.write}", file=sys.stderr)
    return 0


def _scenes(args) -> int:
    from . import scene as scene_mod

    if args.keys:
        print(scene_mod.describe_keys())
        return 0
    for name in scene_mod.shipped():
        scene = scene_mod.load(name)
        print(f"{name:12s} {scene.description}")
    return 0


def _run(args) -> int:
    from mpi4py import MPI

    from . import runner as run

    summary = run.resolve_and_run(args.scene, args.set, args.out, args.overwrite, args.quiet)
    if MPI.COMM_WORLD.rank == 0:
        mode = (summary.get("mode") or {}).get("label", "-")
        ini = summary.get("initiation")
        where = "no sliding" if not ini else f"sliding from t = {ini['time_s'] * 1e6:.2f} µs at x1 = {ini['x1_m'] * 1e3:.2f} mm"
        w = summary["wall_s"]
        print(f"{summary['scene']}: {summary['steps']} steps of {summary['dt_s'] * 1e9:.1f} ns on {summary['ranks']} "
              f"rank(s), {summary['dofs']} dofs; {where}; mode: {mode}; wall {w['total']:.1f} s "
              f"(setup {w['setup']:.1f}, loop {w['time_loop']:.1f}, output {w['output']:.1f})", file=sys.stderr)
        if summary.get("watchdog"):
            print(f"fricfem: {summary['watchdog']}", file=sys.stderr)
    return 0 if summary.get("complete") else 1


def _plot(args) -> int:
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank != 0:
        return 0
    from .plot import run as plot_run

    return plot_run.main([args.rundir] + (["--times", args.times] if args.times else [])
                         + (["--out", args.out] if args.out else []))


def _sweep(argv) -> int:
    from . import sweep

    return sweep.main(argv)


def main(argv=None) -> int:
    logging.getLogger().setLevel(logging.WARNING)  # keep ffcx's compiler chatter quiet
    parser = argparse.ArgumentParser(
        prog="fricfem", description="dynamic frictional sliding between two elastic plates struck at one edge")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("mesh", help="build a two-plate mesh; print its sizes as JSON")
    p.add_argument("scene", nargs="?", help="a scene (shipped name or .toml): its mesh")
    p.add_argument("--preset", help="a mesh of meshes/ (coarse, reference, half, fine, rupture_band) or a "
                                    ".toml mesh file (default: the scene's, else reference)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a mesh parameter in metres (e.g. --set fine_x1=0.08)")
    p.add_argument("--info", action="store_true", help="print JSON with cells, dofs, interface_facets, min_altitude_m")
    p.add_argument("--write", metavar="FILE.msh", help="also write the gmsh model")
    p.set_defaults(func=_mesh)
    p = sub.add_parser("scenes", help="list the shipped scenes (--keys: every scene key)")
    p.add_argument("--keys", action="store_true",
                   help="every key a scene may set: default, unit, allowed range, meaning")
    p.set_defaults(func=_scenes)
    p = sub.add_parser("run", help="run a scene (shipped name or .toml file); works under mpirun")
    p.add_argument("scene", help="shipped scene name (see `fricfem scenes`) or path to a .toml file")
    p.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="override a scene key, e.g. --set loading.v_imp=10 (repeatable)")
    p.add_argument("--out", help="run directory (default runs/<scene>)")
    p.add_argument("--overwrite", action="store_true", help="replace the run in a non-empty --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)
    p = sub.add_parser("plot", help="figures of a run directory")
    p.add_argument("rundir")
    p.add_argument("--times", help="comma-separated times in µs for the interface distributions")
    p.add_argument("--out", help="figure directory (default RUNDIR/plots)")
    p.set_defaults(func=_plot)
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "sweep":  # the sweep parses its own arguments
        return _sweep(argv[1:])
    sub.add_parser("sweep", help="run a Σ0 × V_imp grid of a scene and map the sliding modes "
                                 "(see `fricfem sweep --help`)")
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:
        print(f"fricfem: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
