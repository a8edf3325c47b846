"""Every figure of a run directory: ``fricfem plot RUNDIR``.

The figure kinds are the paper's (Coker, Lykotrafitis, Needleman & Rosakis,
"Numerical Results"):

- ``interface_<t>us.png``   distributions along the interface at chosen times
  (Figs. 8, 10, 12 and 14; :mod:`.interface`);
- ``tip_speed.png``         leading sliding tip position and speed V_tip versus
  time with c_R, c_s, √2 c_s and c_l marked (Fig. 6; :mod:`.tip`);
- ``station_<name>.png``    histories at an interface station (Figs. 20 and 21;
  :mod:`.station`);
- ``spacetime.png``         Δu̇_slip over (x1, t) with the tracked fronts
  (:mod:`.spacetime`);
- ``isochromatics_<t>us.png`` fringe pictures of σ1 − σ2 (Figs. 9, 11, 13, 16,
  18; :mod:`.isochromatics`);
- ``gauges.png``            velocity, σ1 − σ2 and strain at the gauges inside the
  plates (``output.gauges``; :mod:`.gauges`).

At most :data:`MAX_FIGURES` (24) isochromatic figures and frame-series panels
are drawn, evenly spaced in time, and a warning names what was skipped: a run
with 1000 frames would otherwise write 1000 PNGs.  ``--max-figures N`` changes
the limit (0: every snapshot); ``--times`` chooses them.

Python API: times are in seconds. Command line: times are in µs.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import logging
import os
import sys
from pathlib import Path

from ..output.gauges import GAUGES_FILE, open_gauges
from ..output.quantities import FIELDS_FILE, INTERFACE_FILE
from ..output.recorder import h5_error
from ..output.rundir import FieldReader, InterfaceFile, RunInfo, pyvista_module, log, open_interface, read_summary, \
    run_info, sliding_sign, time_tag
from ..analysis.tip import tip_record
from .interface import interface_distributions
from .frames import frame_series
from .gauges import gauge_histories
from .common import mode_text, round_times, us
from .isochromatics import F_SIGMA, THICKNESS, isochromatics
from .spacetime import spacetime
from .station import station_history
from .tip import tip_speed


#: Most isochromatic figures (one PNG per field snapshot) and most panels of the frame series
#: drawn by default: a run with 1000 snapshots gets this many, evenly spaced in time (the first
#: and the last among them), and a warning naming what was skipped; ``--max-figures 0`` lifts it.
MAX_FIGURES = 24


def evenly(values, limit: int) -> list:
    """At most ``limit`` of ``values`` (sorted), evenly spaced by index, the first and last kept;
    all of them when ``limit`` <= 0 (no limit) or they are few enough."""
    values = list(values)
    n = len(values)
    if limit <= 0 or n <= limit:
        return values
    if limit == 1:
        return [values[-1]]
    return [values[round(k * (n - 1) / (limit - 1))] for k in range(limit)]


def plot_run(rundir, times=None, out=None, max_figures: int = MAX_FIGURES) -> list[Path]:
    """Write every figure a run directory supports; return the PNG paths.

    ``times`` [s]: interface distributions and isochromatics at the stored
    times nearest to these (default: 3 round times, e.g. 10, 20, 30 µs, plus
    the last row for the interface; every written snapshot for the
    isochromatics).  Each figure is labelled with the time of the row or
    snapshot it draws (to 0.01 µs); an asked time more than 1 % from its
    nearest stored one is named in a warning, and with ``times`` the
    snapshots left out are named too.
    ``out``: output directory (default ``RUNDIR/plots``). What a run did not
    write (interface.h5, summary.json keys, fields.xdmf, pyvista) is skipped
    with a warning on the ``fricfem.output`` logger.
    ``max_figures``: at most this many isochromatic figures and frame-series
    panels (:data:`MAX_FIGURES`, evenly spaced; the others are named in a
    warning); 0: every one.
    """
    rundir = Path(rundir)
    if not rundir.is_dir():
        raise FileNotFoundError(f"{rundir}: not a run directory")
    out = Path(out) if out is not None else rundir / "plots"
    out.mkdir(parents=True, exist_ok=True)
    summary = read_summary(rundir)
    written: list[Path] = []
    h5path = rundir / INTERFACE_FILE
    with contextlib.ExitStack() as stack:
        try:
            itf = stack.enter_context(open_interface(h5path)) if h5path.is_file() else None
        except (OSError, KeyError) as err:  # not HDF5, or not fricfem's layout
            raise ValueError(f"{h5path}: not readable as a run's interface.h5 ({h5_reason(err)})") from None
        info = run_info(rundir, interface=itf, summary=summary)
        if mode_text(summary.get("mode")):  # the label, and whether the mesh resolves its pulses
            info = dataclasses.replace(info, mode=mode_text(summary.get("mode")))
        if itf is None:
            log.warning("%s: absent; interface figures skipped", h5path)
        elif itf.n_time == 0:
            log.warning("%s: no valid rows yet; interface figures skipped", h5path)
        else:
            written += _interface_figures(itf, out, times, info, summary)
        tip = summary.get("tip")
        if not (tip and len(tip.get("time_s", ()))) and itf is not None and itf.n_time and itf.has("slip_rate"):
            tip = tip_record(itf.time, itf.x1, itf.all("slip_rate"))  # a run without diagnostics
        if tip and len(tip.get("time_s", ())):
            written.append(tip_speed(tip, out / "tip_speed.png", info=info))
        else:
            log.warning("no sliding tip in summary.json or interface.h5; tip_speed.png skipped")
        written += _isochromatic_figures(rundir, out, times, info, itf, max_figures)
        written += _gauge_figure(rundir, out, info)
    return written


def _gauge_figure(rundir: Path, out: Path, info: RunInfo) -> list[Path]:
    """``gauges.png`` when the run wrote gauges (``output.gauges``) with rows."""
    try:
        gauges = open_gauges(rundir)
    except OSError as err:
        log.warning("%s: not readable (%s); gauges.png skipped", rundir / GAUGES_FILE, err.strerror or err)
        return []
    if gauges is None:
        return []
    if not len(gauges) or not len(gauges.time):
        log.warning("%s: no gauge rows yet; gauges.png skipped", rundir / GAUGES_FILE)
        return []
    return [gauge_histories(gauges, out / "gauges.png", info=info)]


def default_interface_times(itf: InterfaceFile) -> list:
    """The times [s] the interface figures ask for by default: 3 round times (10, 20,
    30 µs for a 40 µs run: :func:`~.common.round_times`) and the last row's, each
    drawn at its nearest row and labelled with that row's time."""
    return [*round_times(float(itf.time[0]), float(itf.time[-1])), float(itf.time[-1])]


def _interface_figures(itf: InterfaceFile, out: Path, times, info: RunInfo, summary: dict) -> list[Path]:
    written = []
    sign = sliding_sign(itf)
    asked = default_interface_times(itf) if times is None else list(times)
    rows = itf.nearest(asked)
    _say_nearest("interface figures", asked, itf.time, rows)
    for k, row in enumerate(rows):
        pair = itf.time[rows[max(0, k - 1) : k + 1]]  # the previous chosen time dashed, as the paper
        path = out / f"interface_{time_tag(itf.time[row])}.png"
        written.append(interface_distributions(itf, pair, path, info=info, sign=sign))
    for name, station in itf.stations().items():
        if len(station.time):
            written.append(station_history(station, out / f"station_{name}.png", info=info, sign=sign))
    if itf.has("slip_rate"):
        written.append(spacetime(itf, out / "spacetime.png", summary=summary, info=info))
    return written


def _say_nearest(what: str, asked, stored, rows) -> None:
    """A warning for each asked time [s] whose nearest stored row is off by more
    than 1 % of it (or outside the run), naming the time drawn instead."""
    off = [(float(a), float(stored[r])) for a, r in zip(asked, rows)
           if abs(float(stored[r]) - float(a)) > 0.01 * max(abs(float(a)), 1e-9)]
    if off:
        log.warning("%s: %s", what, "; ".join(f"asked {us(a)} µs, drew the nearest stored time {us(t)} µs"
                                              for a, t in off))


def _capped(what: str, times, limit: int) -> list:
    """``times`` [s] cut to ``limit`` evenly spaced (:func:`evenly`), with a warning saying what was skipped."""
    chosen = evenly(sorted(times), limit)
    if len(chosen) < len(times):
        log.warning("%d %s: drew %d evenly spaced (%.3g … %.3g µs), skipped %d; pass --max-figures 0 for every "
                    "one, or --times to choose", len(times), what, len(chosen), chosen[0] * 1e6, chosen[-1] * 1e6,
                    len(times) - len(chosen))
    return chosen


def _isochromatic_figures(rundir: Path, out: Path, times, info: RunInfo, itf,
                          max_figures: int = MAX_FIGURES) -> list[Path]:
    fields = rundir / FIELDS_FILE
    if not fields.is_file():
        log.warning("%s: absent (the scene wrote no fields); isochromatics skipped", fields)
        return []
    if pyvista_module() is None:
        log.warning("pyvista is not installed; isochromatics skipped")
        return []
    try:  # a run killed or stopped before its first snapshot lists none
        reader = FieldReader(fields)
        if len(reader.times) == 0:
            log.warning("%s: no snapshot written yet; isochromatics skipped", fields)
            return []
    except (OSError, ValueError, KeyError) as err:
        log.warning("%s: not readable (%s); isochromatics skipped", fields, err)
        return []
    # one figure per snapshot (or per snapshot nearest a time asked for), at most max_figures of them
    nearest = reader.nearest(times)
    stored = [float(reader.times[i]) for i in sorted(set(nearest))]
    if times is not None:  # say what --times drew and which snapshots it left out
        _say_nearest("isochromatic figures", times, reader.times, nearest)
        left = [float(t) for i, t in enumerate(reader.times) if i not in set(nearest)]
        log.warning("isochromatic figures: --times %s µs drew the snapshots at %s µs; not drawn: %s",
                    ", ".join(us(t) for t in times), ", ".join(us(t) for t in stored),
                    (", ".join(us(t) for t in left) + " µs (no asked time nearest to them; "
                     "omit --times for every snapshot)") if left else "none")
    times = _capped("isochromatic figures (snapshots)", stored, max_figures)
    # the scene's specimen thickness and fringe constant; its camera frames as one series
    photo = read_summary(rundir).get("photoelastic") or {}
    optics = {"thickness": photo.get("thickness_m") or THICKNESS, "f_sigma": photo.get("f_sigma_N_per_m") or F_SIGMA}
    written = isochromatics(fields, out, times=times, info=info, itf=itf, **optics)
    if photo.get("frames_s"):
        frames = _capped("camera frames in the frame series", photo["frames_s"], max_figures)
        series = frame_series(fields, out / "isochromatics_frames.png", frames, info=info, itf=itf, **optics)
        written += [series] if series else []
    return written


def h5_reason(err: Exception) -> str:
    """The short reason of an h5py error."""
    if isinstance(err, OSError):
        e = h5_error(err, "")
        return e.strerror or str(err)
    return str(err)


def _mpi_rank() -> int:
    """This process's rank when started by mpirun (OpenMPI or MPICH), else 0."""
    for key in ("OMPI_COMM_WORLD_RANK", "PMI_RANK"):
        if key in os.environ:
            return int(os.environ[key])
    return 0


def main(argv=None) -> int:
    """``fricfem plot RUNDIR [--times 22,32] [--out DIR]`` (times in µs)."""
    parser = argparse.ArgumentParser(prog="fricfem plot", description="Figures of a fricfem run directory.")
    parser.add_argument("rundir", help="directory written by `fricfem run`")
    parser.add_argument("--times", help="comma-separated times in µs (nearest stored ones are used)")
    parser.add_argument("--out", help="output directory (default RUNDIR/plots)")
    parser.add_argument("--max-figures", type=int, default=MAX_FIGURES, metavar="N",
                        help=f"at most N isochromatic figures and frame-series panels, evenly spaced in time "
                             f"(default {MAX_FIGURES}; 0: every snapshot)")
    args = parser.parse_args(argv)
    if _mpi_rank() != 0:  # under mpirun only rank 0 draws
        return 0
    try:
        times = None
        if args.times:
            times = [float(s) * 1e-6 for s in args.times.split(",") if s.strip()]
    except ValueError:
        print(f"fricfem plot: error: --times {args.times!r}: expected numbers in µs, e.g. 22,32", file=sys.stderr)
        return 2
    if args.max_figures < 0:
        print(f"fricfem plot: error: --max-figures {args.max_figures}: must be >= 0 (0: no limit)", file=sys.stderr)
        return 2
    if not logging.getLogger().handlers:
        logging.basicConfig(level=logging.WARNING, format="fricfem plot: %(message)s")
    try:
        paths = plot_run(args.rundir, times=times, out=args.out, max_figures=args.max_figures)
    except (FileNotFoundError, ValueError, KeyError) as err:
        print(f"fricfem plot: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except OSError as err:  # the file system: the figure folder not writable, no space, ...
        print(f"fricfem plot: error: {err.filename or args.rundir}: {err.strerror or err}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
