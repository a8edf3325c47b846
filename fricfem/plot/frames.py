"""An isochromatic frame series, as the experiments' high-speed camera records it
(``output.frames``: frames at a start time and an inter-frame interval, or at
given times): one figure of dark-field fringe pictures sin²(π N),
N = (σ1 − σ2) h / f_σ, with the specimen thickness h and fringe constant f_σ
of the scene (``output.thickness``, ``output.f_sigma``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..output.rundir import FieldReader, RunInfo, log
from .common import DPI, save, us
from .isochromatics import F_SIGMA, ISO_WINDOW, THICKNESS, fringe_image, sliding_zones


def frame_series(fields_path, path, times, *, info: RunInfo | None = None, itf=None, window=ISO_WINDOW,
                 thickness: float = THICKNESS, f_sigma: float = F_SIGMA, columns: int = 4,
                 width_px: int = 600) -> Path | None:
    """``path``: the written snapshots nearest to the frame ``times`` [s], in a grid of
    ``columns``, each panel labelled with its time (and, given the interface file
    ``itf``, the sliding zones on x2 = 0).  None if no snapshot was written."""
    reader = FieldReader(fields_path)
    if len(reader.times) == 0 or not len(times):
        log.warning("%s: no snapshots; frame series skipped", fields_path)
        return None
    idx = reader.nearest(times)
    n = len(idx)
    cols = min(columns, n)
    rows = math.ceil(n / cols)
    images, wins = [], []
    for i in idx:
        grid = reader.grid(i)
        b = grid.bounds
        win = (max(window[0], b[0]), min(window[1], b[1]), max(window[2], b[2]), min(window[3], b[3]))
        images.append(fringe_image(grid, win, thickness=thickness, f_sigma=f_sigma, width_px=width_px))
        wins.append(win)
    aspect = (wins[0][3] - wins[0][2]) / (wins[0][1] - wins[0][0])
    panel_w = 2.6
    fig = Figure(figsize=(panel_w * cols, panel_w * aspect * rows + 0.9), dpi=DPI)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax, i, image, win in zip(axes, idx, images, wins):
        t = float(reader.times[i])
        ext = tuple(v * 1e3 for v in win)
        ax.imshow(image, extent=ext, origin="upper", interpolation="antialiased")
        ax.axhline(0.0, color="C3", lw=0.6, ls="--")
        for a, b in sliding_zones(itf, t):
            ax.plot([a * 1e3, b * 1e3], [0.0, 0.0], color="C1", lw=2.5, solid_capstyle="butt")
        ax.set_title(f"{us(t)} µs", fontsize=8, pad=2)
        ax.tick_params(labelsize=6)
        ax.set_aspect("equal")
    for ax in axes[n:]:
        ax.set_visible(False)
    for ax in axes[(rows - 1) * cols:n]:
        ax.set_xlabel(r"$x_1$ [mm]", fontsize=7)
    for ax in axes[::cols]:
        ax.set_ylabel(r"$x_2$ [mm]", fontsize=7)
    asked = np.diff(np.sort(np.asarray(times, dtype=np.float64)))
    cadence = f", every {np.median(asked) * 1e6:.3g} µs (each at its nearest step)" if len(asked) else ""
    fig.suptitle(f"{info.title() if info else ''}\nisochromatic frames{cadence}: dark field sin²(πN), "
                 f"N = (σ1 − σ2) h/f_σ, h = {thickness * 1e3:.4g} mm, f_σ = {f_sigma / 1e3:.3g} kN/m; "
                 f"orange: sliding", fontsize=8)
    fig.tight_layout()
    return save(fig, Path(path))
