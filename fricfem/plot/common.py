"""What the figures share: sizes, saving, panel letters, units of stresses.

Labels of quantities come from :mod:`fricfem.output.quantities`.  Sign
convention of the figures: Δu = u⁺ − u⁻, so under the paper's loading T_s and
Δu̇_s are negative while Δu̇_slip ≥ 0.  Signed quantities (T_s, dT_s, Δu̇_s,
Δu_s, μ_app) are drawn multiplied by the sliding direction
sgn(Σ Δu̇_slip T_s), which makes them positive like the paper's plots; the
axis labels say so ("−T_s") when the sign is flipped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..output.quantities import BY_NAME, SPEED_LABEL, label  # noqa: F401 (re-exported for the figures)

DPI = 120

#: Quantities drawn times the sliding sign.
SIGNED = tuple(q.name for q in BY_NAME.values() if q.signed)
#: Quantities the interface figures can draw (all but the open flag).
PLOTTED = tuple(name for name in BY_NAME if name != "open")


def figure(width: float, height: float, nrows: int = 1, sharex: bool = True):
    fig = Figure(figsize=(width, height), dpi=DPI)
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    return fig, axes


def save(fig: Figure, path, **savefig_kw) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, **savefig_kw)
    return path


def panel_letter(ax, k: int) -> None:
    ax.text(0.012, 0.96, f"({'abcdefgh'[k]})", transform=ax.transAxes, va="top", ha="left",
            fontsize=10, fontweight="bold", zorder=5,
            bbox={"boxstyle": "square,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})


def color_axis(ax, color: str, text: str) -> None:
    ax.set_ylabel(text, color=color)
    ax.tick_params(axis="y", colors=color)


def stress_unit(values) -> tuple[float, str]:
    """(scale, unit) showing stresses [Pa] in MPa, or kPa if they are all below 0.1 MPa."""
    peak = float(np.nanmax(np.abs(values))) if np.size(values) else 0.0
    return (1e-3, "kPa") if peak < 1e5 else (1e-6, "MPa")


def us(t: float) -> str:
    """A row's time [s] as figures print it: µs to 0.01 µs (rows are 0.2048 µs apart
    on the default step, so 19.87 µs is not rounded to a "20" it is not)."""
    return f"{t * 1e6:.2f}"


def round_times(t_first: float, t_last: float, n: int = 3) -> np.ndarray:
    """``n`` round times [s] (multiples of 1, 2 or 5 × 10^k µs) evenly spread over
    (``t_first``, ``t_last``), ascending, each inside the range: the times the
    default interface figures ask for (each drawn at its nearest row, labelled
    with that row's own time)."""
    span = t_last - t_first
    if not span > 0:
        return np.array([t_last])
    raw = span / (n + 1)
    mag = 10.0 ** np.floor(np.log10(raw))
    step = next((m * mag for m in (1.0, 2.0, 5.0, 10.0) if m * mag >= raw * (1.0 - 1e-9)), 10.0 * mag)
    k = np.arange(np.ceil(t_first / step + 1e-9), np.floor(t_last / step - 1e-9) + 1)
    times = k * step
    times = times[(times > t_first) & (times < t_last)]
    return times[np.round(np.linspace(0, len(times) - 1, min(n, len(times)))).astype(int)] if len(times) else times


def mode_text(mode) -> str | None:
    """The mode as figure titles print it: the label, and when the mesh does not
    resolve the pulses it counts, their cells per pulse width against the minimum
    (summary.json's ``mode.evidence.resolution``: :func:`fricfem.analysis.classify.pulse_resolution`)."""
    if not isinstance(mode, dict) or not mode.get("label"):
        return None
    res = (mode.get("evidence") or {}).get("resolution") or {}
    n, least = res.get("cells_per_pulse"), res.get("min_cells_per_pulse")
    if res.get("resolved") is False and n is not None and least is not None:
        return f"{mode['label']} (mesh-dependent: pulses {n:.1f} cells wide, < {least:g} needed)"
    return str(mode["label"])


def time_styles(n: int) -> list[str]:
    """Line styles for ``n`` times, the last one solid (earlier ones dashed, as the paper)."""
    cycle = ["--", ":", "-."]
    return [cycle[(n - 2 - k) % 3] for k in range(n - 1)] + ["-"]


def markers(x_visible: int) -> dict:
    """Small symbols at the integration points when few enough to be seen (the paper's circles)."""
    return {"marker": "o", "ms": 2.2, "mfc": "none", "mew": 0.6} if x_visible <= 400 else {}


def has_impact(info) -> bool:
    """Whether the run was struck (an edge velocity or the experiment's projectile): only then do
    the lines x1 = c t from the struck corner mean anything.  Unknown V_imp counts as struck."""
    return info.v_imp is None or info.v_imp > 0 or bool(info.projectile)


def sliding_extent(x, rate, margin: float = 0.08):
    """(lo, hi) [same unit as ``x``] of the points that ever slide (``rate`` [n_t, n_x] > 0),
    widened by ``margin`` of the span (at least 2 % of the interface) and kept inside ``x``;
    None if nothing slides."""
    x = np.asarray(x, dtype=float)
    slid = np.flatnonzero(np.any(np.asarray(rate) > 0, axis=0)) if np.size(rate) else np.zeros(0, int)
    if len(slid) == 0:
        return None
    lo, hi = float(x[slid[0]]), float(x[slid[-1]])
    pad = max(margin * (hi - lo), 0.02 * (x[-1] - x[0]))
    return max(float(x[0]), lo - pad), min(float(x[-1]), hi + pad)

