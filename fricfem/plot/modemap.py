"""The mode-map figure: Σ0 (log) × V_imp (log), one marker per mode, the boundary dashed."""

from __future__ import annotations

from pathlib import Path

from ..analysis.modemap import boundary, tag

#: Marker per mode label (all of :data:`fricfem.analysis.LABELS`) and for a point without one.
MARKERS = {
    "none": dict(marker="o", facecolor="none", edgecolor="0.55", label="no sliding"),
    "crack-like": dict(marker="s", facecolor="C3", edgecolor="k", label="crack-like"),
    "pulse": dict(marker="^", facecolor="C0", edgecolor="k", label="pulse"),
    "pulse-train": dict(marker="D", facecolor="C2", edgecolor="k", label="train of pulses"),
    "mixed": dict(marker="*", facecolor="C4", edgecolor="k", label="mixed", size=1.8),
    "diverged": dict(marker="X", facecolor="0.2", edgecolor="k", label="stopped by the watchdog"),
    None: dict(marker="x", facecolor="k", edgecolor="k", label="incomplete / not classified"),
}


def draw(ax, sigma0, v_imp, labels, title: str = "") -> None:
    """One map on ``ax``: markers per mode, the boundary dashed, log axes."""
    for lab, style in MARKERS.items():
        xs = [s for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
              if (labels[i][j] if labels[i][j] in MARKERS else None) == lab]
        ys = [v for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
              if (labels[i][j] if labels[i][j] in MARKERS else None) == lab]
        if not xs:
            continue
        ax.scatter(xs, ys, marker=style["marker"], s=55 * style.get("size", 1.0) ** 2,
                   facecolors=style["facecolor"], edgecolors=style["edgecolor"], linewidths=0.8,
                   label=style["label"], zorder=3)
    line = boundary(sigma0, v_imp, labels)
    if line:
        bx, by = zip(*line)
        ax.plot(bx, by, "k--", lw=1.2, marker="_" if len(line) == 1 else None, ms=14,
                label="crack / pulse boundary", zorder=2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    pad = 1.35
    ax.set_xlim(min(sigma0) / pad, max(sigma0) * pad)
    ax.set_ylim(min(v_imp) / pad, max(v_imp) * pad)
    ax.set_xticks(sigma0)
    ax.set_xticklabels([tag(s) for s in sigma0])
    ax.set_yticks(v_imp)
    ax.set_yticklabels([tag(v) for v in v_imp])
    ax.minorticks_off()
    ax.set_xlabel("Σ0 [MPa]")
    ax.set_ylabel("V_imp [m/s]")
    ax.grid(True, which="major", lw=0.3, alpha=0.5)
    if title:
        ax.set_title(title, fontsize=10)


def figure(maps: dict, path: Path) -> None:
    """``maps``: {title: (sigma0, v_imp, labels)} → one panel each, a shared legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(maps)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n + 1.8, 4.8), squeeze=False)
    handles = {}
    for ax, (title, (s, v, labels)) in zip(axes[0], maps.items()):
        draw(ax, s, v, labels, title)
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="center right", fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1 - 1.7 / (5.2 * n + 1.8), 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)
