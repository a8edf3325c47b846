"""Histories at an interface station (the paper's Figs. 20 and 21)."""

from __future__ import annotations

from pathlib import Path

from ..output.rundir import RunInfo, Station
from .common import SIGNED, figure, label, panel_letter, save



def station_history(station: Station, path, *, info: RunInfo | None = None, sign: float = 1.0) -> Path:
    """(a) Δu̇_s, (b) Δu̇_slip, (c) T_s and T_n, (d) μ_app against time at one station."""
    info = info or RunInfo()
    t = station.time * 1e6
    d = station.data
    fig, axes = figure(7.0, 8.0, 4)
    panels = (("jump_rate_s", "C0", " [m/s]"), ("slip_rate", "C1", " [m/s]"),
              ("shear_traction", "C3", " [MPa]"), ("mu_app", "C2", ""))
    for k, (name, color, unit) in enumerate(panels):
        ax = axes[k]
        if name in d:
            v = d[name] * (sign if name in SIGNED else 1.0)
            v = v / 1e6 if unit == " [MPa]" else v
            ax.plot(t, v, color, lw=1.1, label=label(name, sign))
        else:
            ax.text(0.5, 0.5, f"no {name} at this station", transform=ax.transAxes, ha="center")
        ax.set_ylabel(label(name, sign) + unit)
        if name == "shear_traction" and "normal_traction" in d:
            ax.plot(t, d["normal_traction"] / 1e6, "0.35", ls="--", lw=1.0, label=label("normal_traction"))
            ax.set_ylabel("tractions [MPa]")
            # outside the panel, right of it: never over the curves or the panel letter
            ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), borderaxespad=0.0, fontsize=8, frameon=False)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.grid(alpha=0.25)
        panel_letter(ax, k)
    axes[-1].set_xlabel(r"$t$ [µs]")
    if len(t):
        axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(f"{info.title()}\nhistories at station {station.name}, "
                 rf"$x_1$ = {station.x1 * 1e3:.4g} mm", fontsize=10)
    fig.tight_layout()
    return save(fig, path)
