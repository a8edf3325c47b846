"""The ``fricfem`` command: ``fricfem mesh --preset reference --info`` and friends.

Every sub-command works under ``mpirun -n N``; only rank 0 prints.  Bad input
(a scene, a ``--set``, an argument) ends every rank with status 2 and one
line ``fricfem: error: ...`` from rank 0, before any mesh is built.

Each command imports what it needs inside its function, not here at the top:
start-up time (``fricfem scenes`` or ``fricfem show`` load neither MPI nor dolfinx).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import sys
from pathlib import Path


def _rank() -> int:
    """This process's MPI rank, without starting MPI when it is not running yet."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None:
        return mpi.COMM_WORLD.rank
    for var in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if os.environ.get(var, "").isdigit():
            return int(os.environ[var])
    return 0


def _error(msg: str, prog: str = "fricfem") -> int:
    if _rank() == 0:
        print(f"{prog}: error: {' '.join(str(msg).split())}", file=sys.stderr)
    return 2


def _collective(fn):
    """``fn()`` on every rank; if it fails on any rank with bad input, a SceneError
    (the first rank's message) on every rank — so no rank goes on alone."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from mpi4py import MPI

    from .scene import SceneError

    try:
        result, problem = fn(), None
    except ValueError as err:  # SceneError is a ValueError
        result, problem = None, str(err)
    problems = MPI.COMM_WORLD.allgather(problem)
    first = next((p for p in problems if p), None)
    if first:
        raise SceneError(first)
    return result


def _given(args, *names) -> None:
    """Refuse an option given as an empty string (it would otherwise fall back to a default)."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .scene import SceneError

    for name in names:
        v = getattr(args, name.lstrip("-").replace("-", "_"))
        if v is not None and not str(v).strip():
            raise SceneError(f"{name} {v!r}: empty")


def _warn(lines) -> None:
    if _rank() == 0:
        for line in lines:
            print(f"fricfem: warning: {line}", file=sys.stderr)


def _mesh(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from mpi4py import MPI

    from . import scene as scene_mod
    from .model import mesh
    from .scene import SceneError, cost

    _given(args, "--preset", "--write")
    items = [i[len("mesh."):] if i.startswith("mesh.") else i for i in args.set or []]  # both spellings

    def load():
        if args.preset and any(i.partition("=")[0].strip() == "preset" for i in items):
            raise SceneError(f"--preset {args.preset} and --set preset=...: give the mesh preset once")
        if args.scene:  # the mesh of a scene, its [mesh] table and --set mesh.* applied
            raw = scene_mod.apply_overrides(scene_mod.resolve(args.scene), [f"mesh.{item}" for item in items])
            if args.preset:
                raw.setdefault("mesh", {})["preset"] = args.preset
            return scene_mod.validate(raw).mesh
        table = {"preset": args.preset or "reference"}
        for item in items:
            keys, value = scene_mod.parse_override(f"mesh.{item}")
            table[keys[-1]] = value
        return scene_mod.validate_mesh(table)  # every key checked by the schema

    spec = _collective(load)

    def size():
        xs, ys = cost.axes(spec)  # validation bounded the size: cheap
        quads = 2.0 * (len(xs) - 1) * (len(ys) - 1)
        if quads > cost.BUDGET["quads"] and not args.force:
            raise SceneError(f"mesh: about {quads:.3g} quadrilaterals, above the budget of "
                             f"{cost.BUDGET['quads']:.3g}; pass --force to build it anyway")
        if args.write:
            folder = os.path.dirname(os.path.abspath(args.write))
            if not args.write.endswith(".msh"):
                raise SceneError(f"--write {args.write!r}: expected a file name ending in .msh (a gmsh model)")
            if not os.path.isdir(folder):
                raise SceneError(f"--write {args.write!r}: folder {folder!r} does not exist")
            if os.path.isdir(args.write):
                raise SceneError(f"--write {args.write!r}: is a directory")
            if not os.access(folder, os.W_OK):
                raise SceneError(f"--write {args.write!r}: folder {folder!r} is not writable")

    _collective(size)
    pm = mesh.build(spec, MPI.COMM_WORLD, msh_file=args.write)
    info = mesh.info(pm)
    if MPI.COMM_WORLD.rank == 0:
        if args.info or not args.write:
            print(json.dumps(info, indent=2))
        if args.write:
            print(f"wrote {args.write}", file=sys.stderr)
    return 0


def _scenes(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from . import scene as scene_mod

    if args.keys:
        print(scene_mod.describe_keys())
        return 0
    names = list(scene_mod.shipped())
    width = max(map(len, names), default=0)
    for name in names:
        print(f"{name:{width}s}  {scene_mod.load(name).description}")
    return 0


def _show(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .show import show

    text = show(args.scene, args.set)  # validated first: a bad scene or --set is one error line
    if _rank() == 0:
        print(text, end="")
    return 0


def _run_dirs(*paths) -> None:
    """Refuse, on every rank alike, a path that is not a run directory (rank 0 then does the reading)."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .scene import SceneError

    for path in paths:
        if not (Path(path) / "interface.h5").is_file():
            raise SceneError(f"{path}: not a run directory (no interface.h5)")


def _export(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .output.export import export

    _given(args, "rundir", "--out")
    _run_dirs(args.rundir)
    if _rank() != 0:
        return 0
    for path in export(args.rundir, args.format, args.out, args.author or ""):
        print(path)
    return 0


def _compare(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .analysis import compare

    _given(args, "run_a", "run_b")
    _run_dirs(args.run_a, args.run_b)
    if _rank() != 0:
        return 0
    result = compare.compare(args.run_a, args.run_b)
    if args.json:
        # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
        from .output.record import jsonable

        print(json.dumps(jsonable(result), indent=2))
    else:
        print(compare.text(result))
    return 0


def _check_text(scene, est, ranks: int = 1) -> str:
    """What ``fricfem run --check`` prints: the scene is valid, its size and cost against the budget."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .scene import cost

    dt = (f"time.dt = {est.dt_low:.3g} s" if est.dt_fixed else
          f"{est.dt_low:.3g} … {est.dt_high:.3g} s (time.dt_safety = {scene.dt_safety:g} of the stable step "
          f"{est.dt_crit[0]:.3g} … {est.dt_crit[1]:.3g} s)")
    over = est.over(cost.BUDGET)
    budget = ", ".join(f"{k} {v:.3g}" for k, v in cost.BUDGET.items())
    return "\n".join([
        f"scene {scene.name}: valid (law {scene.law}, mesh {scene.raw.get('mesh', {}).get('preset', 'reference')})",
        f"mesh: {est.quads:,.0f} quadrilaterals, {est.dofs:,.0f} dofs, {est.interface_points:,.0f} interface points;"
        f" smallest cell {est.h_min[0]:.3g} × {est.h_min[1]:.3g} m",
        f"step: {dt}",
        f"steps: at most {est.steps:,.0f} to time.end = {scene.t_end:g} s; {est.dof_steps:.3g} dof·steps "
        f"(time loop roughly {est.dof_steps / cost.RATE / ranks:.3g} s on {ranks} rank(s)); interface output "
        f"about {est.output_bytes / 1e6:.3g} MB",
        f"memory: about {est.memory_bytes / 1e9:.3g} GB at the set-up's peak on {est.ranks} rank(s) "
        f"(docs/running.md, Memory); {cost.memory_text()}",
        f"budget ({budget}): " + ("within" if not over else
                                  "above (" + ", ".join(k for k, _, _ in over) + "): runs with --force"),
    ])


def _run(args) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from mpi4py import MPI

    from . import scene as scene_mod
    from .scene import SceneError, cost

    _given(args, "--out")
    if args.resume is not None:
        return _resume(args)
    if args.scene is None:
        raise SceneError("fricfem run: give a scene (a shipped name or a .toml file), or --resume DIR")
    if args.check:
        extra = [n for n, v in (("--out", args.out), ("--overwrite", args.overwrite), ("--quiet", args.quiet))
                 if v not in (None, False)]
        if extra:
            raise SceneError(f"{', '.join(extra)}: not used with --check (it validates and estimates only)")
    scene = _collective(lambda: scene_mod.load(args.scene, args.set))
    est = _collective(lambda: cost.check(scene, force=args.force))
    _warn(list(scene.warnings) + [n for n in [cost.notice(est, MPI.COMM_WORLD.size)] if n and not args.check])
    if args.check:
        if MPI.COMM_WORLD.rank == 0:
            print(_check_text(scene, est, MPI.COMM_WORLD.size))
        return 0

    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from . import runner as run

    summary = run.resolve_and_run(args.scene, args.set, args.out, args.overwrite, args.quiet)
    return _report(summary)


def _resume(args) -> int:
    """``fricfem run [SCENE] --resume DIR``: continue the killed or stopped run in DIR from its
    checkpoint; the scene is the checkpoint's own (``--set`` may change output-only keys such as
    output.checkpoint_wall), or SCENE, which must be the same run."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from mpi4py import MPI

    from . import runner as run
    from . import scene as scene_mod
    from .output import checkpoint
    from .scene import SceneError

    _given(args, "--resume")
    extra = [n for n, v in (("--out", args.out), ("--overwrite", args.overwrite), ("--check", args.check))
             if v not in (None, False)]
    if extra:
        raise SceneError(f"{', '.join(extra)}: not used with --resume (the run goes on in its own directory)")
    out = Path(args.resume)
    if args.scene is not None:
        scene = _collective(lambda: scene_mod.load(args.scene, args.set))
    else:
        header = checkpoint.check_resume(out, MPI.COMM_WORLD)
        scene = _collective(lambda: scene_mod.validate(scene_mod.apply_overrides(header["input"], args.set)))
    return _report(run.run_scene(scene, out, MPI.COMM_WORLD, quiet=args.quiet, resume=True))


def _report(summary) -> int:
    """The run's one line on stderr (rank 0); the exit status: 0 for a complete run."""
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from mpi4py import MPI

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
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .scene import SceneError

    _given(args, "rundir", "--times", "--out")
    if args.times is not None:
        for item in args.times.split(","):
            try:
                t = float(item)
            except ValueError:
                t = math.nan
            if not (math.isfinite(t) and t >= 0):
                raise SceneError(f"--times {args.times!r}: {item.strip()!r} is not a time in µs >= 0; expected "
                                 f"comma-separated numbers, e.g. 22,32")

    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .plot import modemap as plot_modemap

    if plot_modemap.is_sweep(args.rundir):  # a sweep directory: its mode map(s), or why there is none yet
        if args.times is not None:
            raise SceneError(f"--times {args.times!r}: not used on a sweep directory ({args.rundir} holds a mode map)")
        plot_modemap.sweep_maps(args.rundir)  # no map yet: the same error on every rank
        if _rank() != 0:
            return 0
        for path in plot_modemap.from_sweep(args.rundir, args.out):
            print(path)
        return 0
    found = [f for f in ("interface.h5", "summary.json", "fields.xdmf", ".fricfem-manifest.json")
             if (Path(args.rundir) / f).exists()]
    if Path(args.rundir).is_dir() and not found:
        raise SceneError(f"{args.rundir}: neither a run directory (no interface.h5, summary.json or fields.xdmf) "
                         f"nor a sweep directory (no modemap.json or points/): nothing to plot")
    if _rank() != 0:
        return 0
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from .plot import run as plot_run

    return plot_run.main([args.rundir] + (["--times", args.times] if args.times is not None else [])
                         + (["--out", args.out] if args.out is not None else [])
                         + ["--max-figures", str(args.max_figures)])


def _sweep(argv) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from . import sweep

    return sweep.main(argv)


class _Parser(argparse.ArgumentParser):
    """argparse whose messages come from rank 0 only (every rank exits 2 on an error)."""

    def error(self, message):
        if _rank() == 0:
            self.print_usage(sys.stderr)
            print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)

    def _print_message(self, message, file=None):
        if _rank() == 0:
            super()._print_message(message, file)


def _stdout_to_devnull() -> None:
    """The reader of stdout left (``fricfem ... | head``): point stdout's descriptor at /dev/null, so that the
    interpreter's final flush of what is still buffered goes nowhere instead of reporting the closed pipe."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def main(argv=None) -> int:
    """The ``fricfem`` command. stdout is flushed here, inside the try: left to the interpreter's exit, the
    last buffered block met the closed pipe there (``fricfem scenes --keys | head -c 10``, ``fricfem show
    case1 | true``), which printed "Exception ignored on flushing sys.stdout: BrokenPipeError" and exited 120."""
    try:
        code = _main(argv)
        sys.stdout.flush()
        return code
    except BrokenPipeError:  # the reader left; quietly, as other tools do
        _stdout_to_devnull()
        return 0


def _main(argv) -> int:
    # lazy: start-up time (each subcommand loads only what it needs: fricfem scenes/show no MPI or dolfinx)
    from ._startup import lighten_imports

    lighten_imports()  # ufl's and ffcx's version lookups without pkg_resources' scan (fricfem/_startup.py)
    logging.getLogger().setLevel(logging.WARNING)  # keep ffcx's compiler chatter quiet
    parser = _Parser(
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
    p.add_argument("--force", action="store_true", help="build a mesh above the budget of 5e6 quadrilaterals")
    p.set_defaults(func=_mesh)
    p = sub.add_parser("scenes", help="list the shipped scenes (--keys: every scene key)")
    p.add_argument("--keys", action="store_true",
                   help="every key a scene may set: default, unit, allowed range, meaning")
    p.set_defaults(func=_scenes)
    p = sub.add_parser("show", help="print a scene resolved through its base chain (and --set) as TOML that "
                                    "`fricfem run` accepts back")
    p.add_argument("scene", help="shipped scene name (see `fricfem scenes`) or path to a .toml file")
    p.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="override a scene key, e.g. --set loading.v_imp=10 (repeatable)")
    p.set_defaults(func=_show)
    p = sub.add_parser("run", help="run a scene (shipped name or .toml file); works under mpirun")
    p.add_argument("scene", nargs="?",
                   help="shipped scene name (see `fricfem scenes`) or path to a .toml file (with --resume: optional)")
    p.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                   help="override a scene key, e.g. --set loading.v_imp=10 (repeatable)")
    p.add_argument("--out", help="run directory (default runs/<scene>)")
    p.add_argument("--resume", metavar="DIR",
                   help="continue the killed or stopped run in DIR from its last checkpoint "
                        "(output.checkpoint_every / output.checkpoint_wall), bit-identical to a run never stopped")
    p.add_argument("--overwrite", action="store_true", help="replace the run in a non-empty --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--check", action="store_true",
                   help="validate the scene and print its size and cost estimate; run nothing (exit 0: valid "
                        "and within the budget, or --force)")
    p.add_argument("--force", action="store_true",
                   help="run a scene whose estimated cost is above the budget (docs/scenes.md)")
    p.set_defaults(func=_run)
    p = sub.add_parser("plot", help="figures of a run directory (of a sweep directory: its mode map)")
    p.add_argument("rundir")
    p.add_argument("--times", help="comma-separated times in µs for the interface distributions")
    p.add_argument("--out", help="figure directory (default RUNDIR/plots)")
    p.add_argument("--max-figures", type=int, default=24, metavar="N",
                   help="at most N isochromatic figures and frame-series panels, evenly spaced in time "
                        "(default 24; 0: every snapshot; the others are named in a warning)")
    p.set_defaults(func=_plot)
    p = sub.add_parser("export", help="station time series of a run: SCEC code-verification ASCII (one file "
                                      "per station) or CSV")
    p.add_argument("rundir")
    p.add_argument("--format", choices=("scec", "csv"), default="scec",
                   help="scec: <station>.dat, stresses in MPa; csv: stations.csv, SI (default scec)")
    p.add_argument("--out", help="folder for the files (default RUNDIR/export/<format>)")
    p.add_argument("--author", help="the author line of the SCEC header")
    p.set_defaults(func=_export)
    p = sub.add_parser("compare", help="two runs of one problem: one line per station (rupture time, final slip, "
                                       "peak slip rate, slip-rate L2) and the tip speed; B is the reference")
    p.add_argument("run_a")
    p.add_argument("run_b")
    p.add_argument("--json", action="store_true", help="the comparison as JSON (SI units)")
    p.set_defaults(func=_compare)
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "sweep":  # the sweep parses its own arguments
        return _sweep(argv[1:])
    sub.add_parser("sweep", help="run a Σ0 × V_imp grid of a scene and map the sliding modes "
                                 "(see `fricfem sweep --help`)")
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:
        return int(stop.code or 0) if not isinstance(stop.code, str) else 2
    try:
        return args.func(args)
    except ValueError as err:  # SceneError, RunDirError and every other bad-input error
        return _error(str(err))
    except BrokenPipeError:  # `fricfem ... | head`: the reader left; quietly, as other tools (before OSError)
        _stdout_to_devnull()  # the exit's flush goes nowhere
        return 0
    except OSError as err:  # the file system failed under a run (no space, ...): one line naming the path
        _error(f"{err.filename}: {err.strerror}" if err.filename and err.strerror else f"{type(err).__name__}: {err}")
        return 1


if __name__ == "__main__":
    sys.exit(main())
