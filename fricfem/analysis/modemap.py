"""The mode map as data: the label grid, the crack/pulse boundary, the text table."""

from __future__ import annotations

import math

#: Table cell per label (stdout).
SHORT = {"none": ".", "crack-like": "crack", "pulse": "pulse", "pulse-train": "train", "mixed": "mixed",
         "diverged": "div", None: "?"}

_CRACK = ("crack-like",)
_PULSE = ("pulse", "pulse-train")


def tag(x: float) -> str:
    """Short decimal form of a grid value: 0.9 -> '0.9', 40.0 -> '40'."""
    return f"{x:g}"


def boundary(sigma0, v_imp, labels) -> list:
    """The crack/pulse boundary: at most one point per Σ0 column, joined into a line.

    ``labels[i][j]`` is the label at (sigma0[i], v_imp[j]), both axes
    increasing.  In each column the points without sliding (``none``) or
    without a label are set aside; walking up in V_imp over the rest, the
    first change between crack-like and the others places the boundary
    point: on the ``mixed`` point when the change is to or from one (the
    paper: mixed modes occur near the dashed line), else at the geometric
    mean of the two V_imp (the middle on the log axis) between crack-like and
    pulse / pulse-train.  A column without such a change has no point.
    Returns [(Σ0, V_imp), ...] in increasing Σ0.
    """
    out = []
    for i, s in enumerate(sigma0):
        col = [(v, lab) for v, lab in zip(v_imp, labels[i]) if lab in _CRACK + _PULSE + ("mixed",)]
        for (va, la), (vb, lb) in zip(col, col[1:]):
            if (la in _CRACK) != (lb in _CRACK):
                out.append((s, va if la == "mixed" else vb if lb == "mixed" else math.sqrt(va * vb)))
                break
    return out


def label_table(sigma0, v_imp, by_key) -> list:
    """labels[i][j] at (sigma0[i], v_imp[j]) from {key: record}."""
    return [[(by_key.get(f"s{tag(s)}_v{tag(v)}") or {}).get("label") for v in v_imp] for s in sigma0]


def table(sigma0, v_imp, labels) -> str:
    """The label grid as text: V_imp rows (top = fastest), Σ0 columns."""
    w = 7
    lines = ["V_imp \\ Σ0 " + "".join(f"{tag(s):>{w}}" for s in sigma0) + "  [MPa]"]
    for j in reversed(range(len(v_imp))):
        lines.append(f"{tag(v_imp[j]):>6} m/s " + "".join(f"{SHORT.get(labels[i][j], '?'):>{w}}"
                                                          for i in range(len(sigma0))))
    return "\n".join(lines)
