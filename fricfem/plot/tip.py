"""Leading sliding tip: position and speed V_tip against time (the paper's Fig. 6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..output.rundir import RunInfo
from .common import DPI, SPEED_LABEL, has_impact, panel_letter, save



def tip_speed(tip: dict, path, *, info: RunInfo | None = None) -> Path:
    """(a) Tip position x_tip(t) with x = c_l t; (b) V_tip(t) with c_R, c_s, √2 c_s, c_l.

    ``tip``: {"time_s": [...], "x1_m": [...], "v_tip_time_s": [...], "v_tip_m_s": [...]}
    (summary.json's ``tip``; :func:`fricfem.analysis.tip.tip_record` makes one).
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
        if c_l and has_impact(info):  # the line from the struck corner: none without an impact
            tt = np.array([0.0, t.max()])
            ax_x.plot(tt, c_l * tt * 1e-3, "0.5", ls=":", lw=1, label=r"$x_1 = c_l t$")
        ax_x.legend(loc="lower right", fontsize=8)
    ax_x.set_ylabel(r"$x_{\rm tip}$ [mm]")

    # V_tip holds at the centres of its fitting windows (summary ``v_tip_time_s``),
    # not at the first tip times
    tv = np.asarray(tip.get("v_tip_time_s", []), dtype=float) * 1e6
    if len(tv) != len(v):
        raise ValueError(f"tip: {len(v)} speeds but {len(tv)} times (v_tip_time_s)")
    vv = v
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
        panel_letter(a, k)
        a.grid(alpha=0.25)
    mode = f"; mode: {info.mode}" if info.mode else ""
    fig.suptitle(f"{info.title()}\nleading sliding tip{mode}", fontsize=10)
    fig.tight_layout()
    return save(fig, path)
