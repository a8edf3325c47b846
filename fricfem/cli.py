"""The ``fricfem`` command: ``fricfem mesh --preset reference --info`` and friends.

Every sub-command works under ``mpirun -n N``; only rank 0 prints.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys


def _mesh(args) -> int:
    import dataclasses

    from mpi4py import MPI

    from . import mesh

    spec = mesh.preset(args.preset)
    overrides = {}
    for item in args.set or []:
        key, _, value = item.partition("=")
        fields = {f.name for f in dataclasses.fields(mesh.MeshSpec)}
        if key not in fields:
            raise ValueError(f"mesh.{key}: unknown mesh parameter; allowed: {', '.join(sorted(fields))}")
        try:
            overrides[key] = float(value)
        except ValueError:
            raise ValueError(f"mesh.{key} = {value!r}: expected a number in metres") from None
    spec = dataclasses.replace(spec, **overrides)
    spec.check()
    pm = mesh.build(spec, MPI.COMM_WORLD, msh_file=args.write)
    info = mesh.info(pm)
    if MPI.COMM_WORLD.rank == 0:
        if args.info or not args.write:
            print(json.dumps(info, indent=2))
        if args.write:
            print(f"wrote {args.write}", file=sys.stderr)
    return 0


def main(argv=None) -> int:
    logging.getLogger().setLevel(logging.WARNING)  # keep ffcx's compiler chatter quiet
    parser = argparse.ArgumentParser(prog="fricfem", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("mesh", help="build a two-plate mesh; print its sizes as JSON")
    p.add_argument("--preset", default="reference", help="coarse, reference, half or fine")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a mesh parameter in metres (e.g. --set fine_x1=0.08)")
    p.add_argument("--info", action="store_true", help="print JSON with cells, dofs, interface_facets, min_altitude_m")
    p.add_argument("--write", metavar="FILE.msh", help="also write the gmsh model")
    p.set_defaults(func=_mesh)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:
        print(f"fricfem: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
