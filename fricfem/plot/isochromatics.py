"""Isochromatic fringe pictures of σ1 − σ2 (the paper's Figs. 9, 11, 13, 16, 18),
rendered off-screen with pyvista: sin²(π N), N = (σ1 − σ2) h / f_σ."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..output.rundir import FieldReader, InterfaceFile, RunInfo, pyvista_module, log, time_tag
from .common import DPI, has_impact, save, us

#: Defaults of the fringe order N = (σ1 − σ2) h / f_σ (a scene's ``output.f_sigma``, ``output.thickness``):
#: the stress-optic constant commonly quoted for Homalite-100 [N/m] (the paper gives none: docs/model.md §10)
#: and the paper's specimen thickness [m].
F_SIGMA = 22.6e3
THICKNESS = 9.525e-3


#: Default isochromatic window (x1_min, x1_max, x2_min, x2_max) [m] of a struck run: the impact
#: region.  A run with no impact (a rupture problem) is shown whole.
ISO_WINDOW = (0.0, 0.080, -0.030, 0.030)
#: Height of the sliding-zone strip above the picture, in axes fractions.
SLIDING_STRIP = 1.012


#: Each picture's pixel is the mean of SUPERSAMPLE × SUPERSAMPLE rendered samples: where the
#: fringes are finer than a pixel (near the struck corner) it turns the grey they average to,
#: not a moiré of sampled fringes.
SUPERSAMPLE = 3


def downsample(image: np.ndarray, k: int) -> np.ndarray:
    """uint8[h // k, w // k, c]: the mean of each k × k block of ``image`` (a box filter)."""
    if k <= 1:
        return image
    h, w = image.shape[0] // k * k, image.shape[1] // k * k
    blocks = image[:h, :w].astype(np.float64).reshape(h // k, k, w // k, k, -1)
    return np.round(blocks.mean(axis=(1, 3))).astype(np.uint8)


def fringe_image(grid, window=ISO_WINDOW, *, name: str = "stress_difference", width_px: int = 1200,
                 thickness: float = THICKNESS, f_sigma: float = F_SIGMA,
                 supersample: int = SUPERSAMPLE) -> np.ndarray:
    """uint8[h, w, 3] picture of sin²(π N), N = |σ1 − σ2| h / f_σ, over ``window`` [m].

    The cell values are averaged to the nodes (the two plates' duplicated
    interface nodes keep them apart) and N is interpolated across each
    triangle before the periodic colour map is applied
    (``interpolate_before_map``), so every pixel gets its own fringe order.
    Dark field: N = 0, 1, 2, … are black. View from +z, parallel projection;
    pixel columns span x1_min…x1_max and rows x2_max…x2_min.  Rendered at
    ``supersample`` times the size and box-filtered down (:func:`downsample`):
    fringes finer than a pixel average to grey instead of aliasing into moiré.
    """
    pv = pyvista_module()
    x0, x1, y0, y1 = window
    centers = grid.cell_centers().points
    # keep the cells touching the window, with a margin of a few cells
    margin = 0.05 * max(x1 - x0, y1 - y0)
    keep = ((centers[:, 0] > x0 - margin) & (centers[:, 0] < x1 + margin)
            & (centers[:, 1] > y0 - margin) & (centers[:, 1] < y1 + margin))
    part = grid.extract_cells(np.flatnonzero(keep)) if not keep.all() else grid.copy()
    order = np.abs(np.asarray(part.cell_data[name], dtype=np.float64)) * thickness / f_sigma
    part.clear_data()
    part.cell_data["N"] = order
    part = part.cell_data_to_point_data()
    n_max = max(1.0, math.ceil(float(order.max()) if order.size else 1.0))
    n_colors = int(min(16384, max(512, 128 * n_max)))  # ≥ 128 table entries per fringe
    s = np.sin(np.pi * np.linspace(0.0, n_max, n_colors)) ** 2
    cmap = ListedColormap(np.column_stack([s, s, s]))

    height_px = max(2, int(round(width_px * (y1 - y0) / (x1 - x0))))
    k = max(1, int(supersample))
    plotter = pv.Plotter(off_screen=True, window_size=(width_px * k, height_px * k))
    try:
        plotter.set_background("white")
        plotter.add_mesh(part, scalars="N", cmap=cmap, clim=(0.0, n_max), n_colors=n_colors,
                         interpolate_before_map=True, lighting=False, show_scalar_bar=False)
        plotter.enable_parallel_projection()
        cam = plotter.camera
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        cam.focal_point = (cx, cy, 0.0)
        cam.position = (cx, cy, 1.0)
        cam.up = (0.0, 1.0, 0.0)
        cam.parallel_scale = 0.5 * (y1 - y0)
        plotter.reset_camera_clipping_range()
        return downsample(plotter.screenshot(return_img=True), k)
    finally:
        plotter.close()


def isochromatic_figure(image: np.ndarray, window, path, *, title: str = "", sliding=None,
                        thickness: float = THICKNESS, f_sigma: float = F_SIGMA) -> Path:
    """Frame a fringe ``image`` of ``window`` [m] with axes in mm, the interface
    (x2 = 0) marked and, if given, the sliding zones ``sliding`` = [(x_a, x_b), ...] [m]."""
    x0, x1, y0, y1 = (v * 1e3 for v in window)
    width = 7.0
    fig = Figure(figsize=(width, width * (y1 - y0) / (x1 - x0) + 0.9), dpi=DPI)
    ax = fig.subplots()
    ax.imshow(image, extent=(x0, x1, y0, y1), origin="upper", interpolation="antialiased")
    handles = [Line2D([], [], color="C3", lw=0.8, ls="--", label=r"interface $x_2 = 0$")]
    ax.axhline(0.0, color="C3", lw=0.8, ls="--", alpha=0.9)
    # the sliding zones as a strip just above the picture, at their x1: off the fringes at the interface
    for k, (a, b) in enumerate(sliding or []):
        ax.plot([a * 1e3, b * 1e3], [SLIDING_STRIP, SLIDING_STRIP], color="C1", lw=3.5, solid_capstyle="butt",
                transform=ax.get_xaxis_transform(), clip_on=False)
        if k == 0:
            handles.append(Line2D([], [], color="C1", lw=3.5,
                                  label=r"sliding, $\Delta\dot u_{\rm slip} > 0$ (strip above)"))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$x_1$ [mm]")
    ax.set_ylabel(r"$x_2$ [mm]")
    ax.legend(handles=handles, loc="lower right", fontsize=8, framealpha=0.85)
    ax.set_title(title, fontsize=10, pad=12)  # clear of the sliding strip
    ax.annotate(rf"dark field $\sin^2(\pi N)$, $N = (\sigma_1-\sigma_2)\,h/f_\sigma$, "
            rf"$h$ = {thickness * 1e3:.4g} mm, $f_\sigma$ = {f_sigma / 1e3:.3g} kN/m",
            xy=(1.0, 0.0), xycoords="axes fraction", xytext=(0, -36), textcoords="offset points",
            ha="right", va="top", fontsize=7, color="0.3")
    return save(fig, path, bbox_inches="tight", pad_inches=0.08)


def sliding_zones(itf: InterfaceFile | None, t: float) -> list:
    """[(x_a, x_b), ...] [m]: stretches of the interface with Δu̇_slip > 0 in the
    stored row nearest to ``t``, if that row is within one output interval."""
    if itf is None or itf.n_time == 0 or not itf.has("slip_rate"):
        return []
    row = int(itf.nearest([t])[0])
    dt = float(np.max(np.diff(itf.time))) if itf.n_time > 1 else 0.0
    if abs(itf.time[row] - t) > max(dt, 1e-9):
        return []
    on = itf.rows("slip_rate", [row])[0] > 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.view(np.int8), [0]])))
    return [(itf.x1[a], itf.x1[b - 1]) for a, b in zip(edges[::2], edges[1::2])]


def isochromatics(fields_path, out_dir, *, times=None, info: RunInfo | None = None, itf=None,
                  window=None, thickness: float = THICKNESS, f_sigma: float = F_SIGMA) -> list[Path]:
    """``isochromatics_<t>us.png`` for every written time (or the nearest to ``times`` [s]).

    ``window`` (x1_min, x1_max, x2_min, x2_max) [m], cut to the mesh; by default
    :data:`ISO_WINDOW` on a struck run and the whole mesh on one with no impact;
    ``itf`` (an :class:`InterfaceFile`) adds the sliding zones of the nearest interface row.
    """
    info = info or RunInfo()
    if window is None:
        window = ISO_WINDOW if has_impact(info) else (-math.inf, math.inf, -math.inf, math.inf)
    reader = FieldReader(fields_path)
    if len(reader.times) == 0:
        log.warning("%s: no snapshots; isochromatics skipped", fields_path)
        return []
    written = []
    for i in reader.nearest(times):
        t = float(reader.times[i])
        grid = reader.grid(i)
        b = grid.bounds
        win = (max(window[0], b[0]), min(window[1], b[1]), max(window[2], b[2]), min(window[3], b[3]))
        image = fringe_image(grid, win, thickness=thickness, f_sigma=f_sigma)
        title = f"{info.title()}\nisochromatics at t = {us(t)} µs"
        written.append(isochromatic_figure(image, win, Path(out_dir) / f"isochromatics_{time_tag(t)}.png",
                                           title=title, sliding=sliding_zones(itf, t),
                                           thickness=thickness, f_sigma=f_sigma))
    return written
