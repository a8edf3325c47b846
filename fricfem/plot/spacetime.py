"""The slip rate over space and time, with the tracked fronts and the wave lines."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..output.rundir import RunInfo, open_interface, run_info
from .common import DPI, SPEED_LABEL, has_impact, label, save, sliding_extent



def _max_pool(a: np.ndarray, k: int, axis: int) -> np.ndarray:
    """Maximum over consecutive groups of ``k`` along ``axis`` (the last group may be short)."""
    if k <= 1:
        return a
    n = a.shape[axis]
    pad = (-n) % k
    if pad:
        widths = [(0, 0)] * a.ndim
        widths[axis] = (0, pad)
        a = np.pad(a, widths, mode="edge")
    shape = list(a.shape)
    shape[axis : axis + 1] = [shape[axis] // k, k]
    return a.reshape(shape).max(axis=axis + 1)


def spacetime(src, path, *, summary: dict | None = None, info: RunInfo | None = None,
              decades: float = 3.0, max_cells: tuple[int, int] = (2000, 1500)) -> Path:
    """Δu̇_slip over x1 (horizontal, mm) and t (vertical, µs) on a log colour
    scale spanning ``decades`` below the peak; stick (Δu̇_slip = 0) white.
    Over it: fronts from ``summary["fronts"]`` (rupture solid, healing dashed;
    the tip track if there are no fronts), the lines x1 = c_l t, x1 = c_s t, and
    for a nucleated rupture (``summary["rupture"]``,
    :mod:`fricfem.analysis.rupture`) the rupture-time front t_r(x1), the
    nucleation point and where V_r first exceeds c_s and √2 c_s.
    Larger maps are max-pooled to at most ``max_cells`` = (n_x, n_t) cells so
    narrow pulses survive.
    """
    summary = summary or {}
    with open_interface(src) as itf:
        info = info or run_info(interface=itf, summary=summary)
        rate = itf.all("slip_rate")
        x, t = itf.x1.copy(), itf.time.copy()
    kx = max(1, math.ceil(len(x) / max_cells[0]))
    kt = max(1, math.ceil(len(t) / max_cells[1]))
    rate = _max_pool(_max_pool(rate, kx, 1), kt, 0)
    x = _max_pool(x[None, :], kx, 1)[0] if kx > 1 else x
    t = _max_pool(t[:, None], kt, 0)[:, 0] if kt > 1 else t

    fig = Figure(figsize=(7.5, 5.5), dpi=DPI)
    ax = fig.subplots()
    peak = float(rate.max()) if rate.size else 0.0
    cmap = _viridis_with_white()
    if peak > 0:
        norm = LogNorm(vmin=peak * 10.0 ** (-decades), vmax=peak, clip=False)
        shown = np.ma.masked_less_equal(rate, 0.0)
        im = ax.pcolormesh(x * 1e3, t * 1e6, shown, cmap=cmap, norm=norm, shading="nearest", rasterized=True)
        bar = fig.colorbar(im, ax=ax, extend="min", pad=0.02)
        bar.set_label(label("slip_rate") + " [m/s] (white: stick)")
    else:
        ax.text(0.5, 0.5, "no sliding in the rows written", transform=ax.transAxes, ha="center")
    tmax = float(t[-1]) if len(t) else 1e-6
    struck = has_impact(info)  # no impact (a rupture problem): no lines from a struck corner
    if struck:
        _reference_lines(ax, info.speeds, tmax, float(x[-1]) if len(x) else 0.1)
    handles = _front_lines(ax, summary)
    handles += _rupture_lines(ax, summary)
    handles += [Line2D([], [], color="k", ls=ls, lw=1, label=rf"$x_1 = {SPEED_LABEL[key][1:-1]}\,t$")
                for key, ls in (("c_l", "-."), ("c_s", ":")) if struck and info.speeds.get(key)]
    # x1: where the interface slid (from the struck edge when struck), not the whole plate
    extent = sliding_extent(x, rate) if peak > 0 else None
    if extent is None:
        ax.set_xlim(min(0.0, x[0] * 1e3) if len(x) else 0, x[-1] * 1e3 if len(x) else 1)
    else:
        ax.set_xlim((min(0.0, x[0]) if struck else extent[0]) * 1e3, extent[1] * 1e3)
    ax.set_ylim(min(0.0, t[0] * 1e6) if len(t) else 0, tmax * 1e6)
    ax.set_xlabel(r"$x_1$ [mm]")
    ax.set_ylabel(r"$t$ [µs]")
    if handles:
        ax.legend(handles=handles, loc="lower right", fontsize=8, framealpha=0.85)
    mode = f"; mode: {info.mode}" if info.mode else ""
    ax.set_title(f"{info.title()}\nsliding rate over space and time{mode}", fontsize=10)
    fig.tight_layout()
    return save(fig, path)


def _viridis_with_white():
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_bad("white")
    return cmap


def _reference_lines(ax, speeds: dict, tmax: float, xmax: float) -> None:
    """x1 = c t from the impact (t = 0, x1 = 0) for c_l and c_s (named in the legend)."""
    for key, style in (("c_l", "-."), ("c_s", ":")):
        c = speeds.get(key)
        if not c:
            continue
        t_end = min(tmax, xmax / c)
        ax.plot([0.0, c * t_end * 1e3], [0.0, t_end * 1e6], color="k", ls=style, lw=1.0)


#: The tracked fronts: thin and half-transparent, so that the pulses they outline stay visible
#: (at 1.6 pt they covered pulses a few cells wide).
FRONT_LW, FRONT_ALPHA = 1.0, 0.85


def _front_lines(ax, summary: dict) -> list:
    """Draw the tracked fronts (or the tip) of summary.json; return legend handles."""
    style = {"rupture": {"color": "C3", "ls": "-"}, "healing": {"color": "C1", "ls": "--"}}
    handles, seen = [], set()
    for front in summary.get("fronts") or []:
        kind = front.get("kind", "rupture")
        tt = np.asarray(front.get("t", []), dtype=float)
        xx = np.asarray(front.get("x", []), dtype=float)
        if len(tt) < 1 or len(tt) != len(xx):
            continue
        st = style.get(kind, {"color": "C4", "ls": "-."})
        ax.plot(xx * 1e3, tt * 1e6, lw=FRONT_LW, alpha=FRONT_ALPHA, **st)
        if kind not in seen:
            seen.add(kind)
            handles.append(Line2D([], [], lw=1.6, label=f"{kind} front", **st))
    tip = summary.get("tip") or {}
    if not handles and tip.get("time_s") and len(tip.get("time_s")) == len(tip.get("x1_m", [])):
        ax.plot(np.asarray(tip["x1_m"]) * 1e3, np.asarray(tip["time_s"]) * 1e6, "C3-", lw=1.4)
        handles.append(Line2D([], [], color="C3", lw=1.4, label="leading tip"))
    return handles


#: artist ids of the rupture block's marks (tests find them by these)
RUPTURE_GIDS = {"front": "rupture_time", "nucleation": "nucleation", "supershear": "supershear",
                "above_sqrt2_c_s": "above_sqrt2_c_s"}


def _numbers(values) -> np.ndarray:
    """float64 of a JSON list (null: NaN)."""
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def _rupture_lines(ax, summary: dict) -> list:
    """The rupture-time front t_r(x1) of summary.json's ``rupture`` block (a gap
    where a point never ruptured), the nucleation point and the supershear
    transitions of each direction; return legend handles."""
    rup = summary.get("rupture") or {}
    field = rup.get("field") or {}
    x = _numbers(field.get("x1_m", []))
    t = _numbers(field.get("time_s", []))
    if not len(x) or len(x) != len(t) or not np.isfinite(t).any():
        return []
    thr = rup.get("threshold_m_s")
    what = rf"$t_r$ (first $|\dot{{\Delta u}}_{{slip}}| \geq$ {thr * 1e3:g} mm/s)" if thr else r"$t_r$"
    ax.plot(x * 1e3, t * 1e6, color="w", lw=2.2, alpha=0.9, gid=RUPTURE_GIDS["front"] + "_halo")
    ax.plot(x * 1e3, t * 1e6, color="C6", lw=1.0, gid=RUPTURE_GIDS["front"])
    handles = [Line2D([], [], color="C6", lw=1.0, label=what)]
    nuc = rup.get("nucleation")
    if nuc:
        ax.plot([nuc["x1_m"] * 1e3], [nuc["time_s"] * 1e6], "*", color="C6", mec="k", ms=11,
                gid=RUPTURE_GIDS["nucleation"])
        handles.append(Line2D([], [], marker="*", color="C6", mec="k", ls="", ms=9,
                              label=f"nucleation ({nuc['x1_m'] * 1e3:.4g} mm, {nuc['time_s'] * 1e6:.3g} µs)"))
    for key, marker, text in (("supershear", "^", r"$V_r > c_s$"), ("above_sqrt2_c_s", "D", r"$V_r > \sqrt{2}\,c_s$")):
        points = [d[key] for d in rup.get("directions") or [] if d.get(key)]
        if not points:
            continue
        ax.plot([p["x1_m"] * 1e3 for p in points], [p["time_s"] * 1e6 for p in points], marker, color="w",
                mec="k", ms=7, ls="", gid=RUPTURE_GIDS[key])
        handles.append(Line2D([], [], marker=marker, color="w", mec="k", ls="", ms=6,
                              label=text + " from " + ", ".join(f"{p['x1_m'] * 1e3:.4g} mm" for p in points)))
    return handles
