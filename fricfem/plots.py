"""Figures of the paper's kinds (matplotlib, Agg): interface distributions and isochromatics."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

#: Homalite-100: stress-optic constant f_σ [N/m] and specimen thickness [m] (the experiments').
F_SIGMA = 22.6e3
THICKNESS = 9.525e-3


def interface_distributions(profiles: dict, path, title: str = "") -> None:
    """Δu̇_slip and T_s (top), T_n and μ_app (bottom) along x1 at several times.

    ``profiles``: {time_s: profile dict from :func:`fricfem.gather.interface_profile`}.
    """
    fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax_t = ax[0].twinx()
    ax_m = ax[1].twinx()
    for k, (t, p) in enumerate(sorted(profiles.items())):
        ls = ("--", "-", ":", "-.")[k % 4]
        x = p["x1"] * 1e3
        ax[0].plot(x, p["slip_rate"], "C0" + ls, label=f"Δu̇_slip, t = {t * 1e6:.0f} µs")
        ax_t.plot(x, np.abs(p["Ts"]) / 1e6, "C3" + ls, label=f"|T_s|, t = {t * 1e6:.0f} µs")
        ax[1].plot(x, p["Tn"] / 1e6, "C2" + ls, label=f"T_n, t = {t * 1e6:.0f} µs")
        mu = np.divide(np.abs(p["Ts"]), p["Tn"], out=np.zeros_like(p["Tn"]), where=p["Tn"] > 0)
        ax_m.plot(x, mu, "C1" + ls, label=f"μ_app, t = {t * 1e6:.0f} µs")
    ax[0].set_ylabel("Δu̇_slip [m/s]", color="C0")
    ax_t.set_ylabel("|T_s| [MPa]", color="C3")
    ax[1].set_ylabel("T_n [MPa]", color="C2")
    ax_m.set_ylabel("μ_app = |T_s|/T_n", color="C1")
    ax[1].set_xlabel("x1 [mm]")
    for a in (ax[0], ax_t, ax[1], ax_m):
        a.legend(loc="upper right" if a in (ax_t, ax_m) else "upper left", fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def isochromatics(xy, sdiff, path, title: str = "", window=None) -> None:
    """Fringe picture sin²(π N), N = (σ1 − σ2) h / f_σ, from cell-wise σ1 − σ2.

    ``xy`` float64[n, 3, 2] triangle corners [m], ``sdiff`` float64[n] [Pa];
    ``window`` = (x0, x1, y0, y1) in metres.
    """
    n = len(xy)
    tri = Triangulation(xy[:, :, 0].ravel() * 1e3, xy[:, :, 1].ravel() * 1e3, np.arange(3 * n).reshape(n, 3))
    order = sdiff * THICKNESS / F_SIGMA
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.tripcolor(tri, facecolors=np.sin(np.pi * order) ** 2, cmap="gray", shading="flat")
    ax.axhline(0.0, color="C3", lw=0.5)
    ax.set_aspect("equal")
    if window is not None:
        ax.set_xlim(window[0] * 1e3, window[1] * 1e3)
        ax.set_ylim(window[2] * 1e3, window[3] * 1e3)
    ax.set_xlabel("x1 [mm]")
    ax.set_ylabel("x2 [mm]")
    ax.set_title(title or "isochromatics, sin²(π (σ1−σ2) h / f_σ)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
