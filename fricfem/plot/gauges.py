"""``gauges.png``: the histories of the gauges inside the plates (``output.gauges``,
``gauges.h5``; :mod:`fricfem.output.gauges`).

(a) the particle velocity v1, v2 [m/s] against its own time (v^{n−½}, half a
step before the sample: ``velocity_time``); (b) σ1 − σ2 [MPa] (prestress
included) and (c) the strain ε11, ε22, ε12 [10⁻³] at ``time``.  One colour per
gauge (its name and position in the legend), one line style per component.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.lines import Line2D

from ..output.rundir import RunInfo
from .common import figure, panel_letter, save

#: the line style of each component (v1 / e11 solid, v2 / e22 dashed, e12 dotted)
COMPONENT_STYLES = ("-", "--", ":")


def gauge_histories(gauges, path, *, info: RunInfo | None = None) -> Path:
    """Draw every gauge of ``gauges`` (a :class:`fricfem.output.gauges.GaugeFile`) into ``path``."""
    fig, axes = figure(7.0, 8.2, 3)
    colors = [f"C{k % 10}" for k in range(len(gauges))]
    tv, t = gauges.velocity_time * 1e6, gauges.time * 1e6
    for k, name in enumerate(gauges.names):
        g = gauges[name]
        for c, style in enumerate(COMPONENT_STYLES[:2]):
            axes[0].plot(tv, g.velocity[:, c], color=colors[k], ls=style, lw=1.1)
        axes[1].plot(t, g.stress_difference / 1e6, color=colors[k], lw=1.1)
        for c, style in enumerate(COMPONENT_STYLES):
            axes[2].plot(t, g.strain[:, c] * 1e3, color=colors[k], ls=style, lw=1.1)
    axes[0].set_ylabel("velocity [m/s]")
    axes[1].set_ylabel(r"$\sigma_1 - \sigma_2$ [MPa]")
    axes[2].set_ylabel(r"strain [$10^{-3}$]")
    axes[2].set_xlabel(r"$t$ [µs]")
    where = [Line2D([], [], color=colors[k], lw=1.5,
                    label=f"{name} ({gauges.position[k, 0] * 1e3:.3g}, {gauges.position[k, 1] * 1e3:.3g}) mm")
             for k, name in enumerate(gauges.names)]
    axes[1].legend(handles=where, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                   title=r"gauge ($x_1$, $x_2$)", title_fontsize=7)
    for ax, comps in ((axes[0], (r"$v_1$", r"$v_2$")), (axes[2], (r"$\varepsilon_{11}$", r"$\varepsilon_{22}$",
                                                                   r"$\varepsilon_{12}$"))):
        ax.legend(handles=[Line2D([], [], color="k", ls=s, label=c) for s, c in zip(COMPONENT_STYLES, comps)],
                  fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    for k, ax in enumerate(axes):
        panel_letter(ax, k)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.grid(alpha=0.25)
    title = info.title() if info is not None else ""
    fig.suptitle(f"{title}\ngauges: (a) velocity at t − dt/2, (b) σ1 − σ2 with the prestress, (c) strain",
                 fontsize=10)
    fig.tight_layout()
    return save(fig, path)
