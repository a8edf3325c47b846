"""Screenshots of a fricfem run's fields in ParaView, colored by σ1 − σ2 and by the velocity.

Run with ParaView's batch interpreter under a virtual X display (docs/paraview.md)::

    xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvbatch scripts/paraview_snapshot.py runs/case3/fields.xdmf --out runs/case3/plots

(``pvbatch --force-offscreen-rendering`` aborts in Debian's ParaView 5.11; without ``-noreset``
Xvfb may be resetting when pvbatch opens the display and pvbatch aborts.)  Writes
``paraview_stress_<t>us.png`` and ``paraview_velocity_<t>us.png`` at the snapshot
nearest ``--time`` [µs] (default: the last), and prints one line per file with the
snapshot's time and the range of the colored array.

σ1 − σ2 is the total stress (prestress included), drawn from the nodal array
``stress_difference_nodal`` (smooth); ``--cells`` draws the cell values
``stress_difference`` instead.  The velocity is the dynamic particle velocity
(its magnitude).  The time label is in µs (fields.xdmf stores seconds).
"""

import argparse
import os
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, GetColorTransferFunction,
                             GetScalarBar, Render, ResetCamera, SaveScreenshot, Show, Text,
                             Xdmf3ReaderS)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="paraview_snapshot.py", description=__doc__.splitlines()[0])
    parser.add_argument("xdmf", help="a run's fields.xdmf")
    parser.add_argument("--time", type=float, help="snapshot time in µs (nearest written; default: the last)")
    parser.add_argument("--out", help="folder of the PNGs (default: beside fields.xdmf)")
    parser.add_argument("--cells", action="store_true", help="σ1 − σ2 per cell instead of at the nodes")
    parser.add_argument("--size", default="1200,700", help="image size in pixels, WIDTH,HEIGHT")
    args = parser.parse_args(argv)
    if not os.path.isfile(args.xdmf):
        print(f"paraview_snapshot.py: error: {args.xdmf}: no such file", file=sys.stderr)
        return 2
    out = args.out or os.path.dirname(os.path.abspath(args.xdmf))
    os.makedirs(out, exist_ok=True)
    size = [int(v) for v in args.size.split(",")]

    reader = Xdmf3ReaderS(FileName=[args.xdmf])
    times = list(reader.TimestepValues) if hasattr(reader.TimestepValues, "__len__") else [reader.TimestepValues]
    if not times:
        print(f"paraview_snapshot.py: error: {args.xdmf}: no snapshot", file=sys.stderr)
        return 2
    t = times[-1] if args.time is None else min(times, key=lambda s: abs(s - args.time * 1e-6))
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = size
    view.ViewTime = t
    view.OrientationAxesVisibility = 0
    reader.UpdatePipeline(t)
    shown = Show(reader, view)
    view.InteractionMode = "2D"
    ResetCamera(view)
    label = Text(Text=f"t = {t * 1e6:.2f} µs")  # fields.xdmf's times are seconds: shown in µs
    label_shown = Show(label, view)
    label_shown.FontSize = 14
    label_shown.WindowLocation = "Upper Center"

    stress = "stress_difference" if args.cells else "stress_difference_nodal"
    panels = [(("CELLS" if args.cells else "POINTS", stress), None, "sigma1 - sigma2 [Pa] (prestress included)", "stress"),
              (("POINTS", "velocity"), "Magnitude", "|v| [m/s] (dynamic part)", "velocity")]
    tag = f"{round(t * 1e6, 2):g}us"
    for (assoc, name), component, title, stem in panels:
        ColorBy(shown, (assoc, name, component) if component else (assoc, name))
        lut = GetColorTransferFunction(name)
        if component:
            lut.VectorMode = "Magnitude"
        shown.RescaleTransferFunctionToDataRange(False, True)
        bar = GetScalarBar(lut, view)
        bar.Title = title
        bar.ComponentTitle = ""
        shown.SetScalarBarVisibility(view, True)
        Render(view)
        path = os.path.join(out, f"paraview_{stem}_{tag}.png")
        SaveScreenshot(path, view, ImageResolution=size)
        lo, hi = lut.RGBPoints[0], lut.RGBPoints[-4]
        print(f"{path}: t = {t * 1e6:.2f} µs, {name} from {lo:.4g} to {hi:.4g}")
        shown.SetScalarBarVisibility(view, False)
    return 0


if __name__ == "__main__":
    status = main()
    sys.stdout.flush()
    sys.stderr.flush()
    # pvbatch's own teardown under Xvfb ends with "X Error ... GLXBadContext" and status 1 after
    # the screenshots are written (Debian's ParaView 5.11): leave before it, with main()'s status
    os._exit(status)
