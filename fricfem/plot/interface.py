"""InterfaceFile distributions along x1 at chosen times (the paper's Figs. 8, 10, 12 and 14)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D

from ..output.regions import region_spans
from ..output.rundir import RunInfo, open_interface, run_info, sliding_sign
from .common import PLOTTED, SIGNED, color_axis, figure, label, markers, panel_letter, save, stress_unit, time_styles, us



def interface_distributions(src, times, path, *, info: RunInfo | None = None, sign: float | None = None,
                            xlim=None, full: bool = True) -> Path:
    """Distributions along x1 at ``times`` [s] (nearest stored rows) into ``path``.

    (a) Δu̇_slip [m/s] and T_s [MPa] at every time (earlier ones dashed);
    (b) Δu̇_s and the rate Ṫ_s [MPa/µs] at the last time; with ``full`` also
    (c) T_n and μ_app and (d) Δu_slip and Δu_s [µm] at the last time.
    ``src``: run directory, interface.h5, h5py.File or :class:`InterfaceFile`;
    ``xlim`` (x1_min, x1_max) [m], default from the impact edge to just past
    the loading wave front c_l t.
    """
    with open_interface(src) as itf:
        rows = itf.nearest(times)
        if len(rows) == 0:
            raise ValueError(f"{path}: no valid interface rows to plot")
        info = info or run_info(interface=itf)
        sign = sliding_sign(itf) if sign is None else sign
        t = itf.time[rows]
        x = itf.x1 * 1e3
        if xlim is None:
            c_l = info.speeds.get("c_l")
            hi = min(itf.x1[-1], 1.1 * c_l * t[-1]) if c_l and t[-1] > 0 else itf.x1[-1]
            xlim = (min(0.0, itf.x1[0]), hi)
        visible = int(np.count_nonzero((itf.x1 >= xlim[0]) & (itf.x1 <= xlim[1])))
        mk = markers(visible)
        last = rows[-1:]
        q = {n: itf.rows(n, last)[0] for n in PLOTTED if n != "slip_rate" and itf.has(n)}
        rate = itf.rows("slip_rate", rows)
        ts = itf.rows("shear_traction", rows)

        npanel = 4 if full else 2
        fig, axes = figure(7.0, 2.55 * npanel + 0.6, npanel)
        styles = time_styles(len(rows))
        ax, axr = axes[0], axes[0].twinx()
        for k in range(len(rows)):
            ax.plot(x, rate[k], "C0", ls=styles[k], lw=1.2, **(mk if k == len(rows) - 1 else {}))
            axr.plot(x, sign * ts[k] / 1e6, "C3", ls=styles[k], lw=1.2, **(mk if k == len(rows) - 1 else {}))
        color_axis(ax, "C0", label("slip_rate") + " [m/s]")
        color_axis(axr, "C3", label("shear_traction", sign) + " [MPa]")
        ax.legend(handles=[Line2D([], [], color="k", ls=s, label=f"t = {us(tk)} µs")
                           for s, tk in zip(styles, t)], loc="upper right", fontsize=8, framealpha=0.8)

        _host_on_top(ax, axr)
        tops = [ax, _twin_panel(axes[1], x, sign, q, "jump_rate_s", "shear_traction_increment", mk,
                                dt=_step(itf))]
        if full:
            tops.append(_twin_panel(axes[2], x, sign, q, "normal_traction", "mu_app", mk))
            _slip_panel(axes[3], x, sign, q, mk)
            tops.append(axes[3])
        _draw_regions(axes, region_spans(itf.file, itf.x1), xlim)
        c_l = info.speeds.get("c_l")
        for k, a in enumerate(axes):
            panel_letter(tops[k], k)  # on the axes drawn last (the host, over its twin)
            if k != 2:  # T_n > 0: no zero line squeezing panel (c)
                a.axhline(0.0, color="0.6", lw=0.5)
            if c_l:
                a.axvline(c_l * t[-1] * 1e3, color="0.5", ls=":", lw=0.9)
            a.grid(alpha=0.25)
        if c_l and xlim[0] < c_l * t[-1] < xlim[1]:
            axes[0].text(c_l * t[-1] * 1e3, 1.0, r" $c_l t$", transform=axes[0].get_xaxis_transform(),
                         va="bottom", ha="center", fontsize=8, color="0.4")
        axes[-1].set_xlim(xlim[0] * 1e3, xlim[1] * 1e3)
        axes[-1].set_xlabel(r"$x_1$ [mm]")
        when = ", ".join(us(tk) for tk in t)
        later = f"; {'(b)–(d)' if full else '(b)'} at t = {us(t[-1])} µs" if len(t) > 1 else ""
        fig.suptitle(f"{info.title()}\ninterface at t = {when} µs{later}", fontsize=10)
        fig.tight_layout()
        return save(fig, path)


def _draw_regions(axes, spans, xlim) -> None:
    """Shade each friction region (``friction.regions[k]``, from interface.h5) on every
    panel and name it R<k> above the first, with its parameter overrides."""
    for k, xa, xb, params in spans:
        if xb < xlim[0] or xa > xlim[1]:
            continue
        for a in axes:
            a.axvspan(xa * 1e3, xb * 1e3, color="C2", alpha=0.12, lw=0, zorder=0)
        text = ", ".join(f"{n} = {v:g}" for n, v in params.items())
        middle = 0.5 * (max(xa, xlim[0]) + min(xb, xlim[1])) * 1e3
        axes[0].text(middle, 0.98, f"R{k}" + (f"\n{text}" if text else ""), transform=axes[0].get_xaxis_transform(),
                     ha="center", va="top", fontsize=7, color="C2")


def _step(itf) -> float | None:
    """The run's time step [s]: summary.json's ``dt_s`` next to interface.h5, else the file's
    ``dt`` attribute; None if neither says."""
    try:
        summary = json.loads((Path(itf.file.filename).parent / "summary.json").read_text())
        dt = summary.get("dt_s")
    except (OSError, ValueError, AttributeError, TypeError):
        dt = None
    if dt is None:
        dt = itf.attrs.get("dt")
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        return None
    return dt if np.isfinite(dt) and dt > 0 else None


#: The rate of T_s in the figures: MPa/µs (= 10¹² Pa/s), whatever the run's step.
RATE_UNIT = (1e-12, "MPa/µs")


def _twin_panel(ax, x, sign, q, left: str, right: str, mk, dt: float | None = None):
    """``left`` on the left axis (C0), ``right`` on a twin right axis (C3), at one
    time, the left one drawn on top; returns the left (top) axes.  The step's shear-traction increment dT_s is drawn as
    the rate Ṫ_s = dT_s/dt [MPa/µs] when the step ``dt`` [s] is known (it then does not
    depend on dt, nor switch units between runs), else per step with its unit."""
    def scaled(name):
        v = q[name] * (sign if name in SIGNED else 1.0)
        if name == "shear_traction_increment" and dt:
            return v / dt * RATE_UNIT[0], f" [{RATE_UNIT[1]}]"
        if name in ("shear_traction", "normal_traction", "shear_traction_increment"):
            scale, unit = stress_unit(v)
            return v * scale, f" [{unit}]"
        if name in ("slip_rate", "jump_rate_s"):
            return v, " [m/s]"
        return v, ""

    axr = ax.twinx()
    for a, name, color in ((ax, left, "C0"), (axr, right, "C3")):
        if name not in q:
            a.text(0.5, 0.5, f"no {name} in interface.h5", transform=a.transAxes, ha="center")
            continue
        v, unit = scaled(name)
        # the twin's (red) curve wide and pale under the host's (blue): where they coincide (in stick
        # Ṫ_s = C_s Δu̇_s, Case I's panel (b)) both remain visible, red edging blue
        a.plot(x, v, color, **({"lw": 1.2} if a is ax else {"lw": 3.0, "alpha": 0.5}), **mk)
        text = label(name, sign)
        if name == "shear_traction_increment":
            text = (r"$-\dot T_s$" if sign < 0 else r"$\dot T_s$") if dt else text + " per step"
        color_axis(a, color, text + unit)
    _host_on_top(ax, axr)
    return ax


def _host_on_top(ax, twin) -> None:
    """Draw the host axes' (blue, left-axis) lines over the twin's (red): where the two curves
    coincide the blue one stays visible; the host's background is left out so the twin shows."""
    ax.set_zorder(twin.get_zorder() + 1)
    ax.patch.set_visible(False)


def _slip_panel(ax, x, sign, q, mk) -> None:
    """Δu_slip and sgn·Δu_s [µm] (the paper's Fig. 14)."""
    if "slip" in q:
        ax.plot(x, q["slip"] * 1e6, "C0", lw=1.2, label=label("slip"), **mk)
    if "jump_s" in q:
        ax.plot(x, sign * q["jump_s"] * 1e6, "C2", lw=1.2, ls="--", label=label("jump_s", sign))
    ax.set_ylabel(r"slip, jump [µm]")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.8)
