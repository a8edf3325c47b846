"""The mode map as data: axes, the label grid, the label's confidence, the
crack/pulse boundary, adaptive refinement and the text table.

Conventions: ``labels[i][j]`` is the label at (``sigma0[i]``, ``v_imp[j]``),
both axes increasing; a label is one of :data:`fricfem.analysis.LABELS`,
``"diverged"`` (stopped by the watchdog) or None (not computed / incomplete).
"""

from __future__ import annotations

import math
from typing import NamedTuple

#: Table cell per label (stdout).
SHORT = {"none": ".", "crack-like": "crack", "pulse": "pulse", "pulse-train": "train", "mixed": "mixed",
         "diverged": "div", None: "?"}

_CRACK = ("crack-like",)
#: what lies across the crack/pulse boundary from crack-like sliding
_PULSE_SIDE = ("pulse", "pulse-train", "mixed")

#: Significant digits of the values of a ``LO:HI:N`` axis.
AXIS_DIGITS = 4

#: Below this confidence a label is drawn as uncertain (open marker).
LOW_CONFIDENCE = 2.0 / 3.0


def tag(x: float) -> str:
    """Short decimal form of a grid value: 0.9 -> '0.9', 40.0 -> '40'."""
    return f"{x:g}"


def log_axis(lo: float, hi: float, n: int) -> tuple:
    """``n`` values from ``lo`` to ``hi`` evenly spaced in log, each rounded to
    :data:`AXIS_DIGITS` significant digits (the ends exact as given)."""
    if n < 2:
        raise ValueError(f"log_axis: n = {n}, need at least 2 values")
    vals = [lo * (hi / lo) ** (k / (n - 1)) for k in range(n)]
    out = [float(f"{v:.{AXIS_DIGITS}g}") for v in vals]
    out[0], out[-1] = float(lo), float(hi)
    return tuple(out)


# --------------------------------------------------------------------------- confidence


def confidence(label, evidence) -> float | None:
    """How firmly the classifier's evidence supports ``label``, in [0, 1]
    (None for a run without a mode: diverged, incomplete).

    A sliding mode (crack-like, pulse, pulse-train, mixed) is decided by the
    most frequent type of the late slip-rate profiles (the last 20 % of the
    sliding duration, :func:`fricfem.analysis.classify`): its confidence is the
    share of the late profiles that have the deciding type (1: every late
    profile agrees; near 1/2: the late window is split between two types).
    ``none``: 1 without any slipping region, else 1 − n/min_phase for slipping
    regions at n < min_phase samples (a point on the edge of sliding).
    """
    if not evidence or label not in ("none", "crack-like", "pulse", "pulse-train", "mixed"):
        return None
    if label == "none":
        n = len(evidence.get("sliding_times") or [])
        need = (evidence.get("params") or {}).get("min_phase") or 3
        return max(0.0, 1.0 - n / need)
    counts = evidence.get("late_types") or {}
    total = sum(counts.values())
    if not total:
        return None
    return counts.get(evidence.get("late_type"), 0) / total


# --------------------------------------------------------------------------- boundary


def _edges(values) -> list:
    """Cell edges around each value of an increasing axis, in log: the geometric
    means of neighbours, and half a spacing beyond the ends."""
    v = list(values)
    if len(v) == 1:
        return [v[0] / 1.2, v[0] * 1.2]
    mid = [math.sqrt(a * b) for a, b in zip(v, v[1:])]
    return [v[0] * v[0] / mid[0], *mid, v[-1] * v[-1] / mid[-1]]


def cell_edges(sigma0, v_imp) -> tuple:
    """(Σ0 edges, V_imp edges): each point's cell reaches half-way, in log, to its neighbours."""
    return _edges(sigma0), _edges(v_imp)


def _side(label):
    return "crack" if label in _CRACK else "pulse" if label in _PULSE_SIDE else None


def boundary(sigma0, v_imp, labels) -> list:
    """The crack/pulse boundary as polylines [[(Σ0, V_imp), ...], ...] along cell edges.

    Every point owns the cell reaching half-way (in log) to its neighbours
    (:func:`cell_edges`).  The boundary is every cell edge between a
    ``crack-like`` point and a neighbour with pulse-like or mixed sliding
    (``pulse``, ``pulse-train``, ``mixed``), so it passes between points, never
    through one, and a ``mixed`` point lies beside it on the pulse side.
    Points without sliding or without a label border nothing.  The edges are
    joined into polylines where they meet.
    """
    xe, ye = cell_edges(sigma0, v_imp)
    ni, nj = len(sigma0), len(v_imp)
    segs = []
    for i in range(ni):
        for j in range(nj):
            a = _side(labels[i][j])
            if a is None:
                continue
            if i + 1 < ni and {a, _side(labels[i + 1][j])} == {"crack", "pulse"}:
                segs.append(((i + 1, j), (i + 1, j + 1)))  # vertical edge at xe[i + 1]
            if j + 1 < nj and {a, _side(labels[i][j + 1])} == {"crack", "pulse"}:
                segs.append(((i, j + 1), (i + 1, j + 1)))  # horizontal edge at ye[j + 1]
    return [[(xe[p], ye[q]) for p, q in line] for line in _join(segs)]


def _join(segs) -> list:
    """Join edges (pairs of lattice corners) into polylines (a corner where more
    than two edges meet ends a line)."""
    nbr = {}
    for a, b in segs:
        nbr.setdefault(a, []).append(b)
        nbr.setdefault(b, []).append(a)
    used = set()
    lines = []
    for start in sorted(nbr, key=lambda c: (len(nbr[c]) == 2, c)):  # line ends first
        for nxt in nbr[start]:
            if frozenset((start, nxt)) in used:
                continue
            line = [start, nxt]
            used.add(frozenset((start, nxt)))
            while len(nbr[line[-1]]) == 2:
                cand = [c for c in nbr[line[-1]] if frozenset((line[-1], c)) not in used]
                if not cand:
                    break
                used.add(frozenset((line[-1], cand[0])))
                line.append(cand[0])
            lines.append(line)
    return lines


# --------------------------------------------------------------------------- adaptive refinement


class Cell(NamedTuple):
    """A rectangle of the finest grid, by index: corners (i0, j0) .. (i1, j1) inclusive."""

    i0: int
    i1: int
    j0: int
    j1: int

    def corners(self) -> set:
        return {(self.i0, self.j0), (self.i0, self.j1), (self.i1, self.j0), (self.i1, self.j1)}

    def finest(self) -> bool:
        return self.i1 - self.i0 <= 1 and self.j1 - self.j0 <= 1

    def split(self) -> list:
        """Bisected at the integer middle of each side longer than one interval."""
        bi = [self.i0, (self.i0 + self.i1) // 2, self.i1] if self.i1 - self.i0 > 1 else [self.i0, self.i1]
        bj = [self.j0, (self.j0 + self.j1) // 2, self.j1] if self.j1 - self.j0 > 1 else [self.j0, self.j1]
        return [Cell(a, b, c, d) for a, b in zip(bi, bi[1:]) for c, d in zip(bj, bj[1:])]


def coarse_indices(n: int, m: int) -> list:
    """``m`` indices of an axis of ``n`` values, evenly spread, both ends included."""
    if not 2 <= m <= n:
        raise ValueError(f"coarse_indices: {m} coarse values on an axis of {n}; need 2 <= coarse <= {n}")
    return sorted({round(k * (n - 1) / (m - 1)) for k in range(m)})


def coarse_cells(ni: int, nj: int, mi: int, mj: int) -> list:
    """The cells of the coarse grid (``mi`` × ``mj`` of ``ni`` × ``nj`` values)."""
    ci, cj = coarse_indices(ni, mi), coarse_indices(nj, mj)
    return [Cell(a, b, c, d) for a, b in zip(ci, ci[1:]) for c, d in zip(cj, cj[1:])]


def _inside(cell: Cell, labels: dict) -> set:
    """Labels of the labelled points in the cell's closed rectangle."""
    return {lab for (i, j), lab in labels.items() if cell.i0 <= i <= cell.i1 and cell.j0 <= j <= cell.j1}


def _sides(c: Cell) -> list:
    """(end, end, midpoint) of each side of ``c`` longer than one interval."""
    out = []
    if c.i1 - c.i0 > 1:
        mi = (c.i0 + c.i1) // 2
        out += [((c.i0, j), (c.i1, j), (mi, j)) for j in (c.j0, c.j1)]
    if c.j1 - c.j0 > 1:
        mj = (c.j0 + c.j1) // 2
        out += [((i, c.j0), (i, c.j1), (i, mj)) for i in (c.i0, c.i1)]
    return out


def refine(cells, known: dict, guessed: dict) -> tuple:
    """One round: ``(cells, points to compute)``.

    A cell whose labelled points (its corners, and any point on its sides or
    inside labelled for a neighbour) carry more than one label is bisected in
    log Σ0 and log V_imp, down to the finest grid; the others stay.  Its new
    points: the centre is computed; the midpoint of a side is computed when
    the side's ends differ (the side is bisected), and otherwise takes their
    label (``guessed``, updated here: a side whose ends agree is taken to hold
    no boundary).  ``known``: {(i, j): label} of the computed points."""
    labels = {**guessed, **known}
    out, need = [], set()
    for c in cells:
        if c.finest() or len(_inside(c, labels)) <= 1:
            out.append(c)
            continue
        for a, b, m in _sides(c):
            if m in known or m in need:
                continue
            if labels.get(a) == labels.get(b):
                guessed[m] = labels[a]
            else:
                need.add(m)
        if c.i1 - c.i0 > 1 and c.j1 - c.j0 > 1:
            need.add(((c.i0 + c.i1) // 2, (c.j0 + c.j1) // 2))
        out.extend(c.split())
    need -= set(known)
    for m in need:
        guessed.pop(m, None)
    return out, sorted(need)


def fill(ni: int, nj: int, cells, known: dict, guessed: dict | None = None) -> tuple:
    """``(labels, computed)``: the label of every finest point (``labels[i][j]``)
    and whether it was computed.  A point not computed takes its guessed label
    (:func:`refine`) or the label of the cell it lies in, whose labelled points
    all agree (else it would have been refined)."""
    labelled = {**(guessed or {}), **known}
    labels = [[None] * nj for _ in range(ni)]
    for c in cells:
        labs = _inside(c, labelled)
        if len(labs) == 1:
            lab = next(iter(labs))
            for i in range(c.i0, c.i1 + 1):
                for j in range(c.j0, c.j1 + 1):
                    labels[i][j] = lab
    for (i, j), lab in labelled.items():
        labels[i][j] = lab
    computed = [[(i, j) in known for j in range(nj)] for i in range(ni)]
    return labels, computed


def adaptive(ni: int, nj: int, mi: int, mj: int, label_at, max_rounds: int = 64) -> tuple:
    """The whole refinement with a label oracle ``label_at(points) -> {point: label}``
    (a round at a time): ``(labels, computed, rounds)``, rounds = points per round.
    The sweep runs the same loop with scenes (:mod:`fricfem.sweep.adaptive`)."""
    cells = coarse_cells(ni, nj, mi, mj)
    need = sorted(set().union(*(c.corners() for c in cells)))
    known, guessed, rounds = {}, {}, []
    for _ in range(max_rounds):
        if not need:
            break
        known.update(label_at(need))
        rounds.append(len(need))
        cells, need = refine(cells, known, guessed)
    labels, computed = fill(ni, nj, cells, known, guessed)
    return labels, computed, rounds


# --------------------------------------------------------------------------- tables


def label_table(sigma0, v_imp, by_key) -> list:
    """labels[i][j] at (sigma0[i], v_imp[j]) from {key: record}."""
    return [[(by_key.get(f"s{tag(s)}_v{tag(v)}") or {}).get("label") for v in v_imp] for s in sigma0]


def agreement(a, b) -> float:
    """Share of the grid's points where two label tables agree."""
    pairs = [(x, y) for ra, rb in zip(a, b) for x, y in zip(ra, rb)]
    return sum(x == y for x, y in pairs) / max(len(pairs), 1)


def table(sigma0, v_imp, labels) -> str:
    """The label grid as text: V_imp rows (top = fastest), Σ0 columns."""
    w = 7
    lines = ["V_imp \\ Σ0 " + "".join(f"{tag(s):>{w}}" for s in sigma0) + "  [MPa]"]
    for j in reversed(range(len(v_imp))):
        lines.append(f"{tag(v_imp[j]):>6} m/s " + "".join(f"{SHORT.get(labels[i][j], '?'):>{w}}"
                                                          for i in range(len(sigma0))))
    return "\n".join(lines)
