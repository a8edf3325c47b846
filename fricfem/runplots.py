"""Figures of a run directory written by ``fricfem run``: ``fricfem plot RUNDIR``.

The figure kinds are the paper's (Coker, Lykotrafitis, Needleman & Rosakis,
"Numerical Results"):

- ``interface_<t>us.png``   distributions along the interface at chosen times
  (Figs. 8, 10, 12 and 14): (a) Δu̇_slip and T_s, the earlier time dashed;
  (b) dT_s = Ṫ_s dt and Δu̇_s; (c) T_n and μ_app; (d) Δu_slip and Δu_s;
- ``tip_speed.png``         leading sliding tip position and speed V_tip versus
  time with c_R, c_s, √2 c_s and c_l marked (Fig. 6);
- ``station_<name>.png``    histories at an interface station: Δu̇_s,
  Δu̇_slip, T_s (and T_n), μ_app (Figs. 20 and 21);
- ``spacetime.png``         Δu̇_slip over (x1, t) on a log colour scale with the
  tracked rupture (solid) and healing (dashed) fronts and the lines x = c_l t,
  x = c_s t;
- ``isochromatics_<t>us.png`` fringe pictures sin²(π N), N = (σ1 − σ2) h / f_σ,
  of the σ1 − σ2 field (prestress included) rendered off-screen with pyvista
  (Figs. 9, 11, 13, 16, 18).

Inputs (SI units throughout; the figures use mm, µs, MPa):

- ``interface.h5``: ``x1`` [n_point], ``time`` [n_time] and [n_time, n_point]
  arrays per quantity; only the first ``n_time`` rows (root attribute) are
  valid, so a run killed half-way plots what it wrote. Stations under
  ``stations/<name>`` (attribute ``n`` valid rows).
- ``summary.json``: ``tip``, ``fronts``, ``mode``, ``speeds`` (each optional).
- ``fields.xdmf``: dolfinx XDMF with a cell-wise ``stress_difference`` [Pa].

Sign convention of the figures: Δu = u⁺ − u⁻, so under the paper's loading
T_s and Δu̇_s are negative while Δu̇_slip ≥ 0. Signed quantities (T_s, dT_s,
Δu̇_s, Δu_s, μ_app) are drawn multiplied by the sliding direction
sgn(Σ Δu̇_slip T_s), which makes them positive like the paper's plots; the
axis labels say so ("−T_s") when the sign is flipped.

Python API: times are in seconds. Command line: times are in µs.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import logging
import math
import os
import sys
from pathlib import Path

import h5py
import numpy as np
from matplotlib.colors import ListedColormap, LogNorm
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .plots import F_SIGMA, THICKNESS

log = logging.getLogger(__name__)

INTERFACE_FILE = "interface.h5"
SUMMARY_FILE = "summary.json"
FIELDS_FILE = "fields.xdmf"
DPI = 120

#: Default isochromatic window (x1_min, x1_max, x2_min, x2_max) [m]: the impact region.
ISO_WINDOW = (0.0, 0.080, -0.030, 0.030)

# Axis labels (mathtext).
LABEL = {
    "slip_rate": r"$\Delta\dot u_{\rm slip}$",
    "jump_rate_s": r"$\Delta\dot u_s$",
    "shear_traction": r"$T_s$",
    "normal_traction": r"$T_n$",
    "shear_traction_increment": r"$dT_s = \dot T_s\,dt$",
    "slip": r"$\Delta u_{\rm slip}$",
    "jump_s": r"$\Delta u_s$",
    "mu_app": r"$\mu_{\rm app} = T_s/T_n$",
}
#: Labels of the signed quantities drawn times −1 (see the module docstring).
NEG_LABEL = {
    "jump_rate_s": r"$-\Delta\dot u_s$",
    "shear_traction": r"$-T_s$",
    "shear_traction_increment": r"$-dT_s = -\dot T_s\,dt$",
    "jump_s": r"$-\Delta u_s$",
    "mu_app": r"$-\mu_{\rm app} = -T_s/T_n$",
}
SIGNED = tuple(NEG_LABEL)
SPEED_LABEL = {"c_R": r"$c_R$", "c_s": r"$c_s$", "sqrt2_c_s": r"$\sqrt{2}\,c_s$", "c_l": r"$c_l$"}


def label(name: str, sign: float = 1.0) -> str:
    """Axis label of quantity ``name`` as drawn times ``sign`` (±1)."""
    if sign < 0 and name in NEG_LABEL:
        return NEG_LABEL[name]
    return LABEL.get(name, name)


def time_tag(t: float) -> str:
    """File-name tag of a time [s]: ``32us``, ``44.6us``."""
    return f"{round(t * 1e6, 1):g}us"


# ---------------------------------------------------------------------------
# Run metadata and data access


@dataclasses.dataclass(frozen=True)
class RunInfo:
    """What a figure title needs: scene, Σ0 [Pa], V_imp [m/s], wave speeds [m/s], mode."""

    scene: str = ""
    sigma0: float | None = None
    v_imp: float | None = None
    speeds: dict = dataclasses.field(default_factory=dict)
    mode: str | None = None

    def title(self) -> str:
        parts = [self.scene] if self.scene else []
        load = []
        if self.sigma0 is not None:
            load.append(rf"$\Sigma_0$ = {self.sigma0 / 1e6:.3g} MPa")
        if self.v_imp is not None:
            load.append(rf"$V_{{\rm imp}}$ = {self.v_imp:.3g} m/s")
        if load:
            parts.append(", ".join(load))
        return " — ".join(parts)


def read_summary(rundir) -> dict:
    """``summary.json`` of a run directory as a dict ({} if absent or unreadable)."""
    path = Path(rundir) / SUMMARY_FILE
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        log.warning("%s: not readable (%s); plotting without it", path, err)
        return {}


def _attr(attrs, key, default=None):
    value = attrs.get(key, default)
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, np.generic):
        value = value.item()
    return value


def run_info(rundir=None, interface=None, summary=None) -> RunInfo:
    """Metadata from interface.h5 root attributes, completed by summary.json."""
    summary = summary if summary is not None else (read_summary(rundir) if rundir else {})
    attrs = dict(interface.attrs) if interface is not None else {}
    speeds = {k: float(v) for k, v in (summary.get("speeds") or {}).items() if _is_number(v)}
    for key in ("c_l", "c_s", "c_R"):
        if _is_number(attrs.get(key)):
            speeds[key] = float(attrs[key])
    if "c_s" in speeds:
        speeds.setdefault("sqrt2_c_s", math.sqrt(2.0) * speeds["c_s"])
    scene = _attr(attrs, "scene") or summary.get("scene") or (Path(rundir).name if rundir else "")
    sigma0 = _attr(attrs, "sigma0", summary.get("sigma0"))
    v_imp = _attr(attrs, "v_imp", summary.get("v_imp"))
    mode = (summary.get("mode") or {}).get("label") if isinstance(summary.get("mode"), dict) else None
    return RunInfo(
        scene=str(scene),
        sigma0=float(sigma0) if _is_number(sigma0) else None,
        v_imp=float(v_imp) if _is_number(v_imp) else None,
        speeds=speeds,
        mode=mode,
    )


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(float(v))


@dataclasses.dataclass
class Station:
    """Histories at one interface point: ``data[name]`` float64[n] against ``time`` [s]."""

    name: str
    x1: float
    time: np.ndarray
    data: dict


class Interface:
    """The valid rows of an open ``interface.h5`` (read lazily, row by row or whole).

    ``x1`` float64[n_point] [m], ``time`` float64[n_time] [s], ``n_time`` the
    number of valid rows: the root attribute ``n_time`` when present, else
    the leading rows whose times increase (a writer killed before setting the
    attribute leaves zero rows behind).
    """

    def __init__(self, f: h5py.File):
        self.file = f
        self.attrs = f.attrs
        self.x1 = f["x1"][...]
        time = f["time"]
        n = _attr(f.attrs, "n_time")
        if n is None:
            t = time[...]
            bad = np.flatnonzero(np.diff(t) <= 0)
            n = int(bad[0]) + 1 if len(bad) else len(t)
        self.n_time = int(min(int(n), time.shape[0]))
        self.time = time[: self.n_time]

    def has(self, name: str) -> bool:
        return name in self.file

    def rows(self, name: str, idx) -> np.ndarray:
        """float64[len(idx), n_point] of quantity ``name`` at valid rows ``idx``."""
        idx = np.asarray(idx, dtype=int)
        if np.any(idx >= self.n_time) or np.any(idx < 0):
            raise IndexError(f"{name}: rows {idx} outside the {self.n_time} valid rows")
        order = np.argsort(idx)
        uniq, inverse = np.unique(idx[order], return_inverse=True)
        data = self.file[name][uniq.tolist()] if len(uniq) else np.empty((0, len(self.x1)))
        out = np.empty((len(idx), data.shape[1]), dtype=np.float64)
        out[order] = data[inverse]
        return out

    def all(self, name: str) -> np.ndarray:
        """float64[n_time, n_point] of quantity ``name`` (valid rows only)."""
        return np.asarray(self.file[name][: self.n_time], dtype=np.float64)

    def nearest(self, times) -> np.ndarray:
        """Indices of the valid rows nearest to ``times`` [s] (sorted, unique)."""
        if self.n_time == 0:
            return np.zeros(0, dtype=int)
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        idx = np.abs(self.time[None, :] - t[:, None]).argmin(axis=1)
        return np.unique(idx)

    def stations(self) -> dict:
        """{name: :class:`Station`} of the valid rows of every station."""
        out = {}
        for name, g in (self.file.get("stations") or {}).items():
            n = _attr(g.attrs, "n")
            n = len(g["time"]) if n is None else min(int(n), len(g["time"]))
            data = {k: np.asarray(g[k][:n], dtype=np.float64) for k in g if k != "time" and g[k].ndim == 1}
            out[name] = Station(name, float(_attr(g.attrs, "x1", np.nan)), g["time"][:n], data)
        return out


@contextlib.contextmanager
def open_interface(src):
    """Yield an :class:`Interface` of ``src``: a run directory, an ``interface.h5``
    path, an open ``h5py.File`` or an :class:`Interface` (left open)."""
    if isinstance(src, Interface):
        yield src
        return
    if isinstance(src, h5py.File):
        yield Interface(src)
        return
    path = Path(src)
    if path.is_dir():
        path = path / INTERFACE_FILE
    with _h5open(path) as f:
        yield Interface(f)


def sliding_sign(itf: Interface, rows=None) -> float:
    """+1 or −1: the sign of T_s where it slides, sgn(Σ Δu̇_slip T_s) over ``rows``
    (all valid rows by default); the sign of Σ T_s if nothing slides."""
    if itf.n_time == 0 or not itf.has("shear_traction"):
        return 1.0
    rows = np.arange(itf.n_time) if rows is None else np.asarray(rows)
    ts = itf.rows("shear_traction", rows)
    w = itf.rows("slip_rate", rows) if itf.has("slip_rate") else np.zeros_like(ts)
    s = float(np.sum(w * ts))
    if s == 0.0:
        s = float(np.sum(ts))
    return -1.0 if s < 0 else 1.0


def default_times(itf: Interface, n: int = 3) -> np.ndarray:
    """``n`` evenly spaced times plus the last valid one [s]."""
    if itf.n_time == 0:
        return np.zeros(0)
    t0, t1 = float(itf.time[0]), float(itf.time[-1])
    return np.linspace(t0, t1, n + 2)[1:]


# ---------------------------------------------------------------------------
# Small figure helpers


def _figure(width: float, height: float, nrows: int = 1, sharex: bool = True):
    fig = Figure(figsize=(width, height), dpi=DPI)
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    return fig, axes


def _save(fig: Figure, path, **savefig_kw) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, **savefig_kw)
    return path


def _panel_letter(ax, k: int) -> None:
    ax.text(0.012, 0.96, f"({'abcdefgh'[k]})", transform=ax.transAxes, va="top", ha="left",
            fontsize=10, fontweight="bold", zorder=5,
            bbox={"boxstyle": "square,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})


def _color_axis(ax, color: str, text: str) -> None:
    ax.set_ylabel(text, color=color)
    ax.tick_params(axis="y", colors=color)


def _stress_unit(values) -> tuple[float, str]:
    """(scale, unit) showing stresses [Pa] in MPa, or kPa if they are all below 0.1 MPa."""
    peak = float(np.nanmax(np.abs(values))) if np.size(values) else 0.0
    return (1e-3, "kPa") if peak < 1e5 else (1e-6, "MPa")


def _time_styles(n: int) -> list[str]:
    """Line styles for ``n`` times, the last one solid (earlier ones dashed, as the paper)."""
    cycle = ["--", ":", "-."]
    return [cycle[(n - 2 - k) % 3] for k in range(n - 1)] + ["-"]


def _markers(x_visible: int) -> dict:
    """Small symbols at the integration points when few enough to be seen (the paper's circles)."""
    return {"marker": "o", "ms": 2.2, "mfc": "none", "mew": 0.6} if x_visible <= 400 else {}


# ---------------------------------------------------------------------------
# 1. Interface distributions (Figs. 8, 10, 12, 14)


def interface_distributions(src, times, path, *, info: RunInfo | None = None, sign: float | None = None,
                            xlim=None, full: bool = True) -> Path:
    """Distributions along x1 at ``times`` [s] (nearest stored rows) into ``path``.

    (a) Δu̇_slip [m/s] and T_s [MPa] at every time (earlier ones dashed);
    (b) Δu̇_s and dT_s = Ṫ_s dt at the last time; with ``full`` also
    (c) T_n and μ_app and (d) Δu_slip and Δu_s [µm] at the last time.
    ``src``: run directory, interface.h5, h5py.File or :class:`Interface`;
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
        mk = _markers(visible)
        last = rows[-1:]
        q = {n: itf.rows(n, last)[0] for n in LABEL if n not in ("slip_rate",) and itf.has(n)}
        rate = itf.rows("slip_rate", rows)
        ts = itf.rows("shear_traction", rows)

        npanel = 4 if full else 2
        fig, axes = _figure(7.0, 2.55 * npanel + 0.6, npanel)
        styles = _time_styles(len(rows))
        ax, axr = axes[0], axes[0].twinx()
        for k in range(len(rows)):
            ax.plot(x, rate[k], "C0", ls=styles[k], lw=1.2, **(mk if k == len(rows) - 1 else {}))
            axr.plot(x, sign * ts[k] / 1e6, "C3", ls=styles[k], lw=1.2, **(mk if k == len(rows) - 1 else {}))
        _color_axis(ax, "C0", label("slip_rate") + " [m/s]")
        _color_axis(axr, "C3", label("shear_traction", sign) + " [MPa]")
        ax.legend(handles=[Line2D([], [], color="k", ls=s, label=f"t = {tk * 1e6:.3g} µs")
                           for s, tk in zip(styles, t)], loc="upper right", fontsize=8, framealpha=0.8)

        tops = [axr, _twin_panel(axes[1], x, sign, q, "jump_rate_s", "shear_traction_increment", mk)]
        if full:
            tops.append(_twin_panel(axes[2], x, sign, q, "normal_traction", "mu_app", mk))
            _slip_panel(axes[3], x, sign, q, mk)
            tops.append(axes[3])
        c_l = info.speeds.get("c_l")
        for k, a in enumerate(axes):
            _panel_letter(tops[k], k)  # on the twin axes, which are drawn over the host's lines
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
        when = ", ".join(f"{tk * 1e6:.3g}" for tk in t)
        later = f"; {'(b)–(d)' if full else '(b)'} at t = {t[-1] * 1e6:.3g} µs" if len(t) > 1 else ""
        fig.suptitle(f"{info.title()}\ninterface at t = {when} µs{later}", fontsize=10)
        fig.tight_layout()
        return _save(fig, path)


def _twin_panel(ax, x, sign, q, left: str, right: str, mk):
    """``left`` on the left axis (C0), ``right`` on a twin right axis (C3), at one
    time; returns the twin axes."""
    def scaled(name):
        v = q[name] * (sign if name in SIGNED else 1.0)
        if name in ("shear_traction", "normal_traction", "shear_traction_increment"):
            scale, unit = _stress_unit(v)
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
        a.plot(x, v, color, lw=1.2, **mk)
        _color_axis(a, color, label(name, sign) + unit)
    return axr


def _slip_panel(ax, x, sign, q, mk) -> None:
    """Δu_slip and sgn·Δu_s [µm] (the paper's Fig. 14)."""
    if "slip" in q:
        ax.plot(x, q["slip"] * 1e6, "C0", lw=1.2, label=label("slip"), **mk)
    if "jump_s" in q:
        ax.plot(x, sign * q["jump_s"] * 1e6, "C2", lw=1.2, ls="--", label=label("jump_s", sign))
    ax.set_ylabel(r"slip, jump [µm]")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.8)


# ---------------------------------------------------------------------------
# 2. Tip position and speed (Fig. 6)


def tip_history(itf: Interface, window: int = 5) -> dict:
    """Leading sliding tip from the slip-rate rows (when summary.json has none).

    The tip is the largest x1 with Δu̇_slip > 0; V_tip is the slope of a
    least-squares line through ``window`` consecutive tip positions (the
    paper's progressive fit), at the window's central time.
    Returns {"time_s", "x1_m", "v_tip_m_s"} (lists; speeds at window centres).
    """
    rate = itf.all("slip_rate")
    sliding = rate > 0
    has = sliding.any(axis=1)
    last = len(itf.x1) - 1 - np.argmax(sliding[:, ::-1], axis=1)
    t, xt = itf.time[has], itf.x1[last[has]]
    v = np.full(len(t), np.nan)
    if len(t) >= window:
        tw = np.lib.stride_tricks.sliding_window_view(t, window)
        xw = np.lib.stride_tricks.sliding_window_view(xt, window)
        tc = tw - tw.mean(axis=1, keepdims=True)
        xc = xw - xw.mean(axis=1, keepdims=True)
        h = window // 2
        v[h:len(t) - h] = (tc * xc).sum(axis=1) / np.maximum((tc * tc).sum(axis=1), 1e-300)
    return {"time_s": t.tolist(), "x1_m": xt.tolist(), "v_tip_m_s": v.tolist()}


def tip_speed(tip: dict, path, *, info: RunInfo | None = None) -> Path:
    """(a) Tip position x_tip(t) with x = c_l t; (b) V_tip(t) with c_R, c_s, √2 c_s, c_l.

    ``tip``: {"time_s": [...], "x1_m": [...], "v_tip_m_s": [...]} (summary.json).
    """
    info = info or RunInfo()
    t = np.asarray(tip.get("time_s", []), dtype=float) * 1e6
    x = np.asarray(tip.get("x1_m", []), dtype=float) * 1e3
    v = np.asarray(tip.get("v_tip_m_s", []), dtype=float)
    fig = Figure(figsize=(7.0, 6.0), dpi=DPI)
    ax_x, ax_v = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    if len(x) == len(t) and len(t):
        ax_x.plot(t, x, "k.-" if len(t) <= 150 else "k-", ms=3, lw=0.8, label=r"$x_{\rm tip}$")
        c_l = info.speeds.get("c_l")
        if c_l:
            tt = np.array([0.0, t.max()])
            ax_x.plot(tt, c_l * tt * 1e-3, "0.5", ls=":", lw=1, label=r"$x_1 = c_l t$")
        ax_x.legend(loc="lower right", fontsize=8)
    ax_x.set_ylabel(r"$x_{\rm tip}$ [mm]")

    n = min(len(t), len(v))
    tv, vv = t[:n], v[:n]
    ok = np.isfinite(vv)
    speeds = info.speeds
    top = 1.35 * speeds["c_l"] if "c_l" in speeds else (np.nanmax(np.abs(vv)) * 1.1 if ok.any() else 1.0)
    inside = ok & (vv >= 0) & (vv <= top)
    dots = ok.sum() <= 150  # symbols at each estimate while they can be told apart
    ax_v.plot(tv[ok], np.clip(vv[ok], 0, top), "k-", lw=0.8, label=None if dots else r"$V_{\rm tip}$")
    if dots:
        ax_v.plot(tv[inside], vv[inside], "ko", ms=3, label=r"$V_{\rm tip}$")
    off = ok & ~inside
    if off.any():
        ax_v.plot(tv[off], np.clip(vv[off], 0, top), "kx", ms=5, label="off scale (drawn at the frame)")
    for key, style, va in (("c_l", "-", "center"), ("sqrt2_c_s", "--", "center"), ("c_s", "-.", "bottom"),
                           ("c_R", ":", "top")):  # c_s and c_R are 8 % apart: labels above / below
        if key in speeds:
            ax_v.axhline(speeds[key], color="C0", ls=style, lw=1)
            ax_v.text(1.0, speeds[key], f" {SPEED_LABEL[key]} = {speeds[key]:.0f} m/s",
                      transform=ax_v.get_yaxis_transform(), va=va, ha="left", fontsize=8, color="C0")
    ax_v.set_ylim(0, top)
    ax_v.set_xlabel(r"$t$ [µs]")
    ax_v.set_ylabel(r"$V_{\rm tip}$ [m/s]")
    if ok.any():
        ax_v.legend(loc="lower right", fontsize=8)
    for k, a in enumerate((ax_x, ax_v)):
        _panel_letter(a, k)
        a.grid(alpha=0.25)
    mode = f"; mode: {info.mode}" if info.mode else ""
    fig.suptitle(f"{info.title()}\nleading sliding tip{mode}", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


# ---------------------------------------------------------------------------
# 3. Station histories (Figs. 20, 21)


def station_history(station: Station, path, *, info: RunInfo | None = None, sign: float = 1.0) -> Path:
    """(a) Δu̇_s, (b) Δu̇_slip, (c) T_s and T_n, (d) μ_app against time at one station."""
    info = info or RunInfo()
    t = station.time * 1e6
    d = station.data
    fig, axes = _figure(7.0, 8.0, 4)
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
            ax.legend(loc="best", fontsize=8)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.grid(alpha=0.25)
        _panel_letter(ax, k)
    axes[-1].set_xlabel(r"$t$ [µs]")
    if len(t):
        axes[-1].set_xlim(t[0], t[-1])
    fig.suptitle(f"{info.title()}\nhistories at station {station.name}, "
                 rf"$x_1$ = {station.x1 * 1e3:.4g} mm", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


# ---------------------------------------------------------------------------
# 4. Space-time map of the slip rate


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
    the tip track if there are no fronts) and the lines x1 = c_l t, x1 = c_s t.
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
    _reference_lines(ax, info.speeds, tmax, float(x[-1]) if len(x) else 0.1)
    handles = _front_lines(ax, summary)
    handles += [Line2D([], [], color="k", ls=ls, lw=1, label=rf"$x_1 = {SPEED_LABEL[key][1:-1]}\,t$")
                for key, ls in (("c_l", "-."), ("c_s", ":")) if info.speeds.get(key)]
    ax.set_xlim(min(0.0, x[0] * 1e3) if len(x) else 0, x[-1] * 1e3 if len(x) else 1)
    ax.set_ylim(min(0.0, t[0] * 1e6) if len(t) else 0, tmax * 1e6)
    ax.set_xlabel(r"$x_1$ [mm]")
    ax.set_ylabel(r"$t$ [µs]")
    if handles:
        ax.legend(handles=handles, loc="lower right", fontsize=8, framealpha=0.85)
    mode = f"; mode: {info.mode}" if info.mode else ""
    ax.set_title(f"{info.title()}\nsliding rate over space and time{mode}", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _viridis_with_white():
    import matplotlib

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
        ax.plot(xx * 1e3, tt * 1e6, lw=1.6, **st)
        if kind not in seen:
            seen.add(kind)
            handles.append(Line2D([], [], lw=1.6, label=f"{kind} front", **st))
    tip = summary.get("tip") or {}
    if not handles and tip.get("time_s") and len(tip.get("time_s")) == len(tip.get("x1_m", [])):
        ax.plot(np.asarray(tip["x1_m"]) * 1e3, np.asarray(tip["time_s"]) * 1e6, "C3-", lw=1.4)
        handles.append(Line2D([], [], color="C3", lw=1.4, label="leading tip"))
    return handles


# ---------------------------------------------------------------------------
# 5. Isochromatics (Figs. 9, 11, 13, 16, 18) rendered with pyvista


def _pyvista():
    """pyvista set up for off-screen rendering, or None if it is not installed."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista
    except ImportError:
        return None
    return pyvista


#: XDMF topology type -> (VTK cell type, nodes per cell) for the cells dolfinx writes in 2D.
_XDMF_CELLS = {"Triangle": (5, 3), "Quadrilateral": (9, 4)}


class FieldReader:
    """Snapshots of one function of a dolfinx ``fields.xdmf`` (+ ``.h5``).

    The XML is parsed here and the arrays are read with h5py; VTK's own XDMF
    reader is not used because, in a process that has loaded dolfinx (and
    with it the system libhdf5), VTK's bundled HDF5 binds to the wrong
    symbols and returns a mesh with all points at the origin.

    ``times`` float64[n] [s]; :meth:`grid` returns a pyvista
    UnstructuredGrid with the function as cell data (cell-centred functions)
    or point data (nodal ones), named ``name``.
    """

    def __init__(self, path, name: str = "stress_difference"):
        import xml.etree.ElementTree as ET

        self.path = Path(path)
        self.name = name
        root = ET.parse(self.path).getroot()
        domain = root.find("Domain")
        grids = domain.findall("Grid") if domain is not None else []
        mesh = next((g for g in grids if g.get("GridType", "Uniform") == "Uniform"
                     and g.find("Topology") is not None), None)
        if mesh is None:
            raise ValueError(f"{self.path}: no mesh grid")
        topo = mesh.find("Topology")
        kind = topo.get("TopologyType")
        if kind not in _XDMF_CELLS:
            raise ValueError(f"{self.path}: cells {kind!r} not supported (allowed {sorted(_XDMF_CELLS)})")
        self.cell_type = _XDMF_CELLS[kind][0]
        self._topology = topo.find("DataItem").text.strip()
        self._geometry = mesh.find("Geometry").find("DataItem").text.strip()
        series = next((g for g in grids if g.get("GridType") == "Collection" and g.get("Name") == name), None)
        if series is None:
            raise KeyError(f"{self.path}: no function {name!r} "
                           f"(has {[g.get('Name') for g in grids if g.get('GridType') == 'Collection']})")
        steps = []
        for g in series.findall("Grid"):
            att = g.find("Attribute")
            steps.append((float(g.find("Time").get("Value")), att.get("Center", "Node"),
                          att.find("DataItem").text.strip()))
        steps.sort(key=lambda s: s[0])
        self.times = np.array([s[0] for s in steps])
        self._steps = steps
        self._mesh = None

    def _read(self, item: str) -> np.ndarray:
        """The array of an XDMF ``file.h5:/path`` data item (file relative to the .xdmf)."""
        fname, _, dset = item.partition(":")
        with _h5open(self.path.parent / fname) as f:
            return f[dset][...]

    def nearest(self, times=None) -> np.ndarray:
        """Indices of the written times nearest to ``times`` [s] (all if None)."""
        if times is None:
            return np.arange(len(self.times))
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        return np.unique(np.abs(self.times[None, :] - t[:, None]).argmin(axis=1))

    def grid(self, index: int):
        """pyvista UnstructuredGrid of the mesh with the function at written time ``index``."""
        pv = _pyvista()
        if pv is None:
            raise ImportError("pyvista is not installed")
        if self._mesh is None:  # the mesh is written once; read it once
            cells = self._read(self._topology).astype(np.int64)
            x = self._read(self._geometry).astype(np.float64)
            if x.shape[1] == 2:
                x = np.column_stack([x, np.zeros(len(x))])
            self._mesh = pv.UnstructuredGrid({self.cell_type: cells}, x)
        grid = self._mesh.copy(deep=False)
        grid.clear_data()
        _, center, item = self._steps[index]
        values = self._read(item)
        values = values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values
        (grid.cell_data if center == "Cell" else grid.point_data)[self.name] = values
        return grid


@contextlib.contextmanager
def _h5open(path):
    """Open an HDF5 file read-only without taking HDF5's file lock (a run may be
    writing it); HDF5 builds without the option are opened normally."""
    try:
        f = h5py.File(path, "r", locking=False)
    except (TypeError, ValueError):
        f = h5py.File(path, "r")
    with f:
        yield f


def fringe_image(grid, window=ISO_WINDOW, *, name: str = "stress_difference", width_px: int = 1200,
                 thickness: float = THICKNESS, f_sigma: float = F_SIGMA) -> np.ndarray:
    """uint8[h, w, 3] picture of sin²(π N), N = |σ1 − σ2| h / f_σ, over ``window`` [m].

    The cell values are averaged to the nodes (the two plates' duplicated
    interface nodes keep them apart) and N is interpolated across each
    triangle before the periodic colour map is applied
    (``interpolate_before_map``), so every pixel gets its own fringe order.
    Dark field: N = 0, 1, 2, … are black. View from +z, parallel projection;
    pixel columns span x1_min…x1_max and rows x2_max…x2_min.
    """
    pv = _pyvista()
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
    plotter = pv.Plotter(off_screen=True, window_size=(width_px, height_px))
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
        return plotter.screenshot(return_img=True)
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
    for k, (a, b) in enumerate(sliding or []):
        ax.plot([a * 1e3, b * 1e3], [0.0, 0.0], color="C1", lw=3.5, solid_capstyle="butt")
        if k == 0:
            handles.append(Line2D([], [], color="C1", lw=3.5, label=r"sliding, $\Delta\dot u_{\rm slip} > 0$"))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$x_1$ [mm]")
    ax.set_ylabel(r"$x_2$ [mm]")
    ax.legend(handles=handles, loc="lower right", fontsize=8, framealpha=0.85)
    ax.set_title(title, fontsize=10)
    ax.annotate(rf"dark field $\sin^2(\pi N)$, $N = (\sigma_1-\sigma_2)\,h/f_\sigma$, "
            rf"$h$ = {thickness * 1e3:.4g} mm, $f_\sigma$ = {f_sigma / 1e3:.3g} kN/m",
            xy=(1.0, 0.0), xycoords="axes fraction", xytext=(0, -36), textcoords="offset points",
            ha="right", va="top", fontsize=7, color="0.3")
    return _save(fig, path, bbox_inches="tight", pad_inches=0.08)


def sliding_zones(itf: Interface | None, t: float) -> list:
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
                  window=ISO_WINDOW, thickness: float = THICKNESS, f_sigma: float = F_SIGMA) -> list[Path]:
    """``isochromatics_<t>us.png`` for every written time (or the nearest to ``times`` [s]).

    ``window`` (x1_min, x1_max, x2_min, x2_max) [m], cut to the mesh; ``itf``
    (an :class:`Interface`) adds the sliding zones of the nearest interface row.
    """
    info = info or RunInfo()
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
        title = f"{info.title()}\nisochromatics at t = {t * 1e6:.3g} µs"
        written.append(isochromatic_figure(image, win, Path(out_dir) / f"isochromatics_{time_tag(t)}.png",
                                           title=title, sliding=sliding_zones(itf, t),
                                           thickness=thickness, f_sigma=f_sigma))
    return written


# ---------------------------------------------------------------------------
# The whole run directory


def plot_run(rundir, times=None, out=None) -> list[Path]:
    """Write every figure a run directory supports; return the PNG paths.

    ``times`` [s]: interface distributions and isochromatics at the stored
    times nearest to these (default: 3 evenly spaced plus the last row for
    the interface, every written snapshot for the isochromatics).
    ``out``: output directory (default ``RUNDIR/plots``). What a run did not
    write (interface.h5, summary.json keys, fields.xdmf, pyvista) is skipped
    with a warning on the ``fricfem.runplots`` logger.
    """
    rundir = Path(rundir)
    if not rundir.is_dir():
        raise FileNotFoundError(f"{rundir}: not a run directory")
    out = Path(out) if out is not None else rundir / "plots"
    out.mkdir(parents=True, exist_ok=True)
    summary = read_summary(rundir)
    written: list[Path] = []
    h5path = rundir / INTERFACE_FILE
    with contextlib.ExitStack() as stack:
        itf = stack.enter_context(open_interface(h5path)) if h5path.is_file() else None
        info = run_info(rundir, interface=itf, summary=summary)
        if itf is None:
            log.warning("%s: absent; interface figures skipped", h5path)
        elif itf.n_time == 0:
            log.warning("%s: no valid rows yet; interface figures skipped", h5path)
        else:
            written += _interface_figures(itf, out, times, info, summary)
        tip = summary.get("tip")
        if not (tip and tip.get("time_s")) and itf is not None and itf.n_time and itf.has("slip_rate"):
            tip = tip_history(itf)
        if tip and tip.get("time_s"):
            written.append(tip_speed(tip, out / "tip_speed.png", info=info))
        else:
            log.warning("no sliding tip in summary.json or interface.h5; tip_speed.png skipped")
        written += _isochromatic_figures(rundir, out, times, info, itf)
    return written


def _interface_figures(itf: Interface, out: Path, times, info: RunInfo, summary: dict) -> list[Path]:
    written = []
    sign = sliding_sign(itf)
    rows = itf.nearest(default_times(itf) if times is None else times)
    for k, row in enumerate(rows):
        pair = itf.time[rows[max(0, k - 1) : k + 1]]  # the previous chosen time dashed, as the paper
        path = out / f"interface_{time_tag(itf.time[row])}.png"
        written.append(interface_distributions(itf, pair, path, info=info, sign=sign))
    for name, station in itf.stations().items():
        if len(station.time):
            written.append(station_history(station, out / f"station_{name}.png", info=info, sign=sign))
    if itf.has("slip_rate"):
        written.append(spacetime(itf, out / "spacetime.png", summary=summary, info=info))
    return written


def _isochromatic_figures(rundir: Path, out: Path, times, info: RunInfo, itf) -> list[Path]:
    fields = rundir / FIELDS_FILE
    if not fields.is_file():
        log.warning("%s: absent (the scene wrote no fields); isochromatics skipped", fields)
        return []
    if _pyvista() is None:
        log.warning("pyvista is not installed; isochromatics skipped")
        return []
    return isochromatics(fields, out, times=times, info=info, itf=itf)


# ---------------------------------------------------------------------------
# Command line


def _mpi_rank() -> int:
    """This process's rank when started by mpirun (OpenMPI or MPICH), else 0."""
    for key in ("OMPI_COMM_WORLD_RANK", "PMI_RANK"):
        if key in os.environ:
            return int(os.environ[key])
    return 0


def main(argv=None) -> int:
    """``fricfem plot RUNDIR [--times 22,32] [--out DIR]`` (times in µs)."""
    parser = argparse.ArgumentParser(prog="fricfem plot", description="Figures of a fricfem run directory.")
    parser.add_argument("rundir", help="directory written by `fricfem run`")
    parser.add_argument("--times", help="comma-separated times in µs (nearest stored ones are used)")
    parser.add_argument("--out", help="output directory (default RUNDIR/plots)")
    args = parser.parse_args(argv)
    if _mpi_rank() != 0:  # under mpirun only rank 0 draws
        return 0
    try:
        times = None
        if args.times:
            times = [float(s) * 1e-6 for s in args.times.split(",") if s.strip()]
    except ValueError:
        print(f"fricfem plot: error: --times {args.times!r}: expected numbers in µs, e.g. 22,32", file=sys.stderr)
        return 2
    if not logging.getLogger().handlers:
        logging.basicConfig(level=logging.WARNING, format="fricfem plot: %(message)s")
    try:
        paths = plot_run(args.rundir, times=times, out=args.out)
    except (FileNotFoundError, ValueError, KeyError) as err:
        print(f"fricfem plot: error: {err}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
