"""The mode-map figure: Σ0 (log) × V_imp (log), one mark per point, the
crack/pulse boundary dashed along cell edges, each label's confidence shown.

Two styles, chosen by the grid: up to :data:`SPARSE` values per axis (the
paper's 8 × 8), one marker per mode at each point, hollow when the label's
confidence is below :data:`fricfem.analysis.modemap.LOW_CONFIDENCE`, with the
confidence written under every marker below 1; denser or adaptive maps, one
coloured cell per point (pale where the label was inferred from its cell by
the adaptive refinement), a dot on every computed point, a ring on the
uncertain ones.  Confidence: :func:`fricfem.analysis.modemap.confidence`.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..analysis.modemap import LOW_CONFIDENCE, boundary, cell_edges, tag

#: Marker per mode label (all of :data:`fricfem.analysis.LABELS`) and for a point without one.
MARKERS = {
    "none": dict(marker="o", color="0.55", label="no sliding"),
    "crack-like": dict(marker="s", color="C3", label="crack-like"),
    "pulse": dict(marker="^", color="C0", label="pulse"),
    "pulse-train": dict(marker="D", color="C2", label="train of pulses"),
    "mixed": dict(marker="*", color="C4", label="mixed", size=1.8),
    "diverged": dict(marker="X", color="0.2", label="stopped by the watchdog"),
    None: dict(marker="x", color="k", label="incomplete / not classified"),
}

#: Largest number of values per axis drawn with one marker per point.
SPARSE = 12

CONFIDENCE_NOTE = "confidence: the share of the late\nslip-rate profiles whose type\ndecided the label\n"
#: how the figure shows it: with markers (sparse), with cells (dense)
CONFIDENCE_SHOWN = {True: f"(written under the marker\nwhen < 1; open when < {LOW_CONFIDENCE:.2f})",
                    False: f"(computed points ringed\nwhen < {LOW_CONFIDENCE:.2f})"}


CONFIDENCE_FONTSIZE = 8  # pt: the confidence under each uncertain point (sparse maps)
_SYMBOLS = (("V_imp", r"$V_\mathrm{imp}$"), ("Σ0", r"$\Sigma_0$"), ("C_n", "$C_n$"), ("C_s", "$C_s$"),
            ("c_l", "$c_l$"), ("c_s", "$c_s$"), ("c_R", "$c_R$"))


def math_text(text: str) -> str:
    """``text`` with the raw symbols V_imp, Σ0, C_n, C_s, c_l, c_s, c_R set as subscripts (mathtext)."""
    if "$" in text:  # already typeset
        return text
    for raw, tex in _SYMBOLS:
        text = text.replace(raw, tex)
    return text


def _markers(ax, sigma0, v_imp, labels, conf) -> None:
    """One marker per point, hollow when uncertain, the confidence under it when below 1."""
    for lab, st in MARKERS.items():
        for hollow in (False, True):
            pts = [(s, v) for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
                   if (labels[i][j] if labels[i][j] in MARKERS else None) == lab
                   and hollow == (conf[i][j] is not None and conf[i][j] < LOW_CONFIDENCE)]
            if not pts:
                continue
            xs, ys = zip(*pts)
            size, label = 55 * st.get("size", 1.0) ** 2, st["label"] if not hollow else None
            if lab is None:  # an unfilled marker: one colour
                ax.scatter(xs, ys, marker=st["marker"], s=size, c=st["color"], linewidths=1.0, zorder=3, label=label)
                continue
            face = "none" if hollow or lab == "none" else st["color"]
            edge = st["color"] if hollow or lab == "none" else "k"
            ax.scatter(xs, ys, marker=st["marker"], s=size, facecolors=face, edgecolors=edge,
                       linewidths=1.1 if hollow else 0.8, zorder=3, label=label)
    for i, s in enumerate(sigma0):
        for j, v in enumerate(v_imp):
            c = conf[i][j]
            if c is not None and c < 1.0:
                ax.annotate(f"{c:.2f}", (s, v), xytext=(0, -11), textcoords="offset points", ha="center",
                            va="top", fontsize=CONFIDENCE_FONTSIZE, color="0.15", zorder=4)


def _cells(ax, sigma0, v_imp, labels, conf, computed) -> list:
    """One coloured cell per point (pale when inferred), a dot per computed point,
    a ring on the uncertain ones; returns the legend's proxies for the cells."""
    # lazy: start-up time (matplotlib is slow to import, only for a figure)
    from matplotlib.patches import Patch, Rectangle

    xe, ye = cell_edges(sigma0, v_imp)
    seen = set()
    for i in range(len(sigma0)):
        for j in range(len(v_imp)):
            lab = labels[i][j] if labels[i][j] in MARKERS else None
            done = computed is None or computed[i][j]
            color = "white" if lab is None else MARKERS[lab]["color"]
            ax.add_patch(Rectangle((xe[i], ye[j]), xe[i + 1] - xe[i], ye[j + 1] - ye[j], facecolor=color,
                                   alpha=0.8 if done else 0.35, edgecolor="none", zorder=1))
            seen.add(lab)
    proxies = [Patch(facecolor="white" if lab is None else MARKERS[lab]["color"], alpha=0.8,
                     edgecolor="0.5" if lab is None else "none", label=MARKERS[lab]["label"])
               for lab in MARKERS if lab in seen]
    pts = [(s, v, conf[i][j]) for i, s in enumerate(sigma0) for j, v in enumerate(v_imp)
           if computed is None or computed[i][j]]
    sure = [(s, v) for s, v, c in pts if c is None or c >= LOW_CONFIDENCE]
    unsure = [(s, v) for s, v, c in pts if c is not None and c < LOW_CONFIDENCE]
    if sure:
        ax.scatter(*zip(*sure), s=4, c="k", zorder=3, label="computed" if computed is not None else None)
    if unsure:
        ax.scatter(*zip(*unsure), s=22, facecolors="none", edgecolors="k", linewidths=0.8, zorder=3,
                   label=f"confidence < {LOW_CONFIDENCE:.2f}")
    if computed is not None:
        proxies.append(Patch(facecolor="0.6", alpha=0.35, label="pale: inferred from its cell (adaptive)"))
    return proxies


def draw(ax, sigma0, v_imp, labels, title: str = "", conf=None, computed=None) -> list:
    """One map on ``ax``: the points, the boundary, log axes.  ``conf[i][j]``: the
    labels' confidences (None: not known); ``computed[i][j]``: which points were
    computed (an adaptive map; None: all).  Returns legend proxies beyond the
    axes' own labelled artists."""
    conf = conf or [[None] * len(v_imp) for _ in sigma0]
    sparse = computed is None and max(len(sigma0), len(v_imp)) <= SPARSE
    proxies = []
    if sparse:
        _markers(ax, sigma0, v_imp, labels, conf)
    else:
        proxies = _cells(ax, sigma0, v_imp, labels, conf, computed)
    for k, line in enumerate(boundary(sigma0, v_imp, labels)):
        bx, by = zip(*line)
        ax.plot(bx, by, "k--", lw=1.4, zorder=5, label="crack / pulse boundary" if k == 0 else None)
    xe, ye = cell_edges(sigma0, v_imp)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(xe[0], xe[-1])
    ax.set_ylim(ye[0], ye[-1])
    if sparse:
        ax.set_xticks(sigma0)
        ax.set_xticklabels([tag(s) for s in sigma0])
        ax.set_yticks(v_imp)
        ax.set_yticklabels([tag(v) for v in v_imp])
        ax.minorticks_off()
        ax.grid(True, which="major", lw=0.3, alpha=0.5)
    else:
        # lazy: start-up time (matplotlib is slow to import, only for a figure)
        from matplotlib.ticker import FixedLocator, NullLocator

        for axis, lo, hi in ((ax.xaxis, xe[0], xe[-1]), (ax.yaxis, ye[0], ye[-1])):
            ticks = [t for t in (0.5, 1, 2, 4, 5, 10, 20, 40, 50, 100, 200) if lo <= t <= hi]
            axis.set_major_locator(FixedLocator(ticks))
            axis.set_ticklabels([tag(t) for t in ticks])
            axis.set_minor_locator(NullLocator())
    ax.set_xlabel(r"$\Sigma_0$ [MPa]")
    ax.set_ylabel(r"$V_\mathrm{imp}$ [m/s]")
    if title:
        ax.set_title(math_text(title), fontsize=9)
    return proxies


def figure(maps: dict, path: Path, note: str | None = None, suptitle: str | None = None) -> None:
    """``maps``: {title: (sigma0, v_imp, labels[, conf[, computed]])} → one panel each,
    a shared legend, ``note`` in small print under the legend."""
    # matplotlib here and in the drawing helpers, not at the top: the sweep imports this module on every
    # rank, and only rank 0 draws, once at the end (start-up time)
    import matplotlib

    matplotlib.use("Agg")
    # lazy: start-up time (matplotlib is slow to import, only for a figure)
    import matplotlib.pyplot as plt

    n = len(maps)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n + 2.4, 5.0), squeeze=False)
    handles = {}
    styles = set()
    for ax, (title, panel) in zip(axes[0], maps.items()):
        styles.add(panel[4] is None and max(len(panel[0]), len(panel[1])) <= SPARSE if len(panel) > 4
                   else max(len(panel[0]), len(panel[1])) <= SPARSE)
        s, v, labels = panel[:3]
        proxies = draw(ax, s, v, labels, title, *panel[3:5])
        for h in proxies:
            handles.setdefault(h.get_label(), h)
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    right = 1 - 2.3 / (5.2 * n + 2.4)
    fig.legend(handles.values(), handles.keys(), loc="upper left", bbox_to_anchor=(right, 0.92), fontsize=7,
               frameon=False)
    shown = "\n".join(CONFIDENCE_SHOWN[k] for k in sorted(styles, reverse=True))
    fig.text(right + 0.005, 0.08, CONFIDENCE_NOTE + shown + (f"\n\n{note}" if note else ""), fontsize=7.5,
             va="bottom", color="0.3")
    if suptitle:
        fig.suptitle(math_text(suptitle), fontsize=10)
    fig.tight_layout(rect=(0, 0, right, 0.95 if suptitle else 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


SWEEP_MAPS = ("", "stiff_x10", "stiff_div10")  # fricfem.sweep's map folders: the scene's C and the variants


def is_sweep(directory) -> bool:
    """A directory ``fricfem sweep --out`` wrote (its map, or its points so far)."""
    d = Path(directory)
    return (d / "modemap.json").is_file() or ((d / "points").is_dir() and not (d / "interface.h5").exists())


def sweep_maps(directory) -> dict:
    """{map folder name ('' for the scene's C): modemap.json document} of a sweep directory; a
    ValueError naming the directory when its map is not written yet (cheap: every rank may ask)."""
    d = Path(directory)
    docs = {}
    for name in SWEEP_MAPS:
        path = d / name / "modemap.json" if name else d / "modemap.json"
        if path.is_file():
            try:
                docs[name] = json.loads(path.read_text())
            except (OSError, ValueError) as err:
                raise ValueError(f"{path}: not readable as a mode map ({err})") from None
    if "" not in docs:
        done = len([p for p in (d / "points").iterdir() if (p / "summary.json").is_file()]) \
            if (d / "points").is_dir() else 0
        raise ValueError(f"{d}: a sweep directory whose mode map is not written yet ({done} point(s) with a "
                         f"summary); the same `fricfem sweep ... --out {d}` resumes it and writes modemap.json")
    return docs


def from_sweep(directory, out=None) -> list:
    """Redraw the mode map(s) of a sweep directory from its ``modemap.json`` files into ``out``
    (default DIR/plots): ``modemap.png`` per map (``<variant>_modemap.png`` for the stiffness
    variants) and, with variants, ``modemap_variants.png``.  A sweep whose map is not written
    yet (still running, or stopped) is a ValueError saying so."""
    d = Path(directory)
    docs = sweep_maps(d)
    out = Path(out) if out is not None else d / "plots"
    out.mkdir(parents=True, exist_ok=True)
    paths, panels = [], {}
    for name, doc in docs.items():
        s, v = doc["grid"]["sigma0_MPa"], doc["grid"]["v_imp_m_s"]
        panel = (s, v, doc["labels"]["values"], (doc.get("confidence") or {}).get("values"),
                 (doc.get("adaptive") or {}).get("computed"))
        path = out / (f"{name}_modemap.png" if name else "modemap.png")
        figure({doc.get("title", "mode map"): panel}, path, note=doc.get("note"))
        paths.append(path)
        head = "C_n, C_s of the scene" if not name else name.replace("stiff_x", "C_n, C_s × ").replace(
            "stiff_div", "C_n, C_s ÷ ")
        if "Cn_Pa_m" in doc and "Cs_Pa_m" in doc:
            head += f"\n(C_n = {doc['Cn_Pa_m'] / 1e12:g}, C_s = {doc['Cs_Pa_m'] / 1e12:g} MPa/µm)"
        panels[head] = panel
    if len(docs) > 1:
        path = out / "modemap_variants.png"
        figure(panels, path, suptitle=docs[""].get("title", "").split("\n")[0] or None)
        paths.append(path)
    return paths
