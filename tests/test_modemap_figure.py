"""The mode-map figure's data in the dense (cell) style of 32 × 32 and adaptive maps:
the dashed line drawn is the boundary computed from the labels, every one of its
segments is a cell edge between a crack-like point and a pulse-side one (pulse,
pulse-train, mixed), every such pair of neighbours has its edge drawn, no segment
passes through a point, and the uncertain and the computed points are marked."""

from __future__ import annotations

import numpy as np
import pytest

from fricfem.analysis import modemap
from fricfem.analysis.modemap import LOW_CONFIDENCE, log_axis

PULSE_SIDE = {"pulse", "pulse-train", "mixed"}


def _labels(n: int) -> list:
    """A crack region at low Σ0 and V, pulses beyond a diagonal with a band of mixed
    points along it, no sliding at high Σ0 and low V, a notch of pulses into the crack."""
    out = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(n):
            d = i + j - n
            out[i][j] = ("none" if i > 2 * j + 4 else "crack-like" if d < -2 else "mixed" if d < 0 else
                         "pulse-train" if j > n - 4 else "pulse")
    out[3][5] = "pulse"  # a pulse point inside the crack region: boxed in by four edges
    return out


def _segments(ax):
    """The dashed lines' unit segments as sorted pairs of points (log-rounded)."""
    segs = set()
    for line in ax.lines:
        if line.get_linestyle() != "--":
            continue
        xy = np.column_stack(line.get_data())
        for a, b in zip(xy, xy[1:]):
            key = tuple(sorted((tuple(np.round(np.log(a), 9)), tuple(np.round(np.log(b), 9)))))
            segs.add(key)
    return segs


@pytest.mark.parametrize("adaptive", [False, True])
def test_dense_figure_draws_the_boundary_between_crack_and_pulse_points(adaptive):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fricfem.plot import modemap as plot_modemap

    n = 16
    s, v = log_axis(0.9, 40, n), log_axis(1, 40, n)
    labels = _labels(n)
    conf = [[0.5 if lab == "mixed" and i % 2 == 0 else 1.0 for j, lab in enumerate(row)]
            for i, row in enumerate(labels)]
    computed = [[(i + j) % 2 == 0 for j in range(n)] for i in range(n)] if adaptive else None
    fig, ax = plt.subplots()
    plot_modemap.draw(ax, s, v, labels, "t", conf, computed)
    drawn = _segments(ax)
    xe, ye = (np.log(e) for e in modemap.cell_edges(s, v))
    r = lambda x: float(np.round(x, 9))  # noqa: E731
    want = set()
    for i in range(n):
        for j in range(n):
            for di, dj in ((1, 0), (0, 1)):
                if i + di >= n or j + dj >= n:
                    continue
                pair = {labels[i][j], labels[i + di][j + dj]}
                if "crack-like" in pair and pair & PULSE_SIDE:
                    a = (r(xe[i + 1]), r(ye[j])) if di else (r(xe[i]), r(ye[j + 1]))
                    b = (r(xe[i + 1]), r(ye[j + 1]))
                    want.add(tuple(sorted((a, b))))
    assert len(want) > 20
    assert drawn == want  # every crack | pulse-side edge, and nothing else
    ls, lv = np.log(s), np.log(v)
    for (x0, y0), (x1, y1) in drawn:  # along cell edges, never through a point
        if x0 == x1:
            assert not np.any(np.isclose(ls, x0))
        else:
            assert not np.any(np.isclose(lv, y0))
    ringed = [c for c in ax.collections if c.get_label() == f"confidence < {LOW_CONFIDENCE:.2f}"]
    uncertain = {(i, j) for i in range(n) for j in range(n) if conf[i][j] < LOW_CONFIDENCE
                 and (computed is None or computed[i][j])}
    assert len(ringed) == 1 and len(ringed[0].get_offsets()) == len(uncertain) > 0
    dots = [c for c in ax.collections if c.get_sizes().tolist() == [4.0]]  # the computed, certain points
    shown = sum(len(c.get_offsets()) for c in dots) + len(uncertain)
    assert shown == (sum(map(sum, computed)) if adaptive else n * n)
    plt.close(fig)
