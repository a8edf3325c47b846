"""Rupture and healing fronts: the edges of slipping regions tracked in time."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..output.rundir import jsonable
from .regions import cell_lengths, check_history, region_history, spacings
from .speeds import check_speeds, mach_numbers, regime
from .tip import lsq_slope, tip_speed


def prior_speed(time, regions, max_speed, npts) -> float:
    """Median speed [m/s] of the filtered leading tip, clipped to [0, max_speed]:
    the expected motion of a front seen for the first time."""
    t = np.array([tk for tk, r in zip(time, regions) if r])
    x = np.array([r[-1].x_end for r in regions if r])
    if t.size < 2:
        return 0.0
    _, v = tip_speed(t, x, min(npts, t.size))
    return float(np.clip(np.median(v), 0.0, max_speed))


@dataclasses.dataclass(frozen=True)
class Front:
    """A tracked edge of a slipping region.

    kind        ``"rupture"`` (the edge moves into stuck ground: the region grows),
                ``"healing"`` (it moves into the slipping region: sliding stops
                behind or ahead of it) or ``"stationary"`` (|mean speed| below
                the stationary limit, e.g. the pinned rear of a crack)
    edge        ``"leading"`` (stick at larger x1) or ``"trailing"`` (stick at smaller x1)
    t, x        float64[m] sample times [s] and positions (x1 of the edge's
                sliding point) [m]
    t_speed, speed  the 5-point progressive least-squares speed (:func:`tip_speed`)
                [s], [m/s]; empty when the track has fewer samples than the fit
    mean_speed  least-squares slope over the whole track [m/s] (signed, +x1 away
                from the impact edge)
    mach        |mean_speed| / c_R, c_s, √2 c_s, c_l
    regime      speed range (:func:`regime`)
    """

    kind: str
    edge: str
    t: np.ndarray
    x: np.ndarray
    t_speed: np.ndarray
    speed: np.ndarray
    mean_speed: float
    mach: dict
    regime: str

    def to_dict(self) -> dict:
        return jsonable(dataclasses.asdict(self))


def track_edges(time, x1, regions, max_speed, v_prior, npts):
    """Link region edges between consecutive samples into tracks.

    Edges on the domain ends (first/last point) are boundaries, not fronts.  A
    track seen at t_k predicts its position at t_{k+1} from its recent speed
    (least squares over its last ``npts`` samples), a new one from ``v_prior``;
    an edge of the same kind at t_{k+1} may continue it if it lies within
    ``max_speed·Δt + 2 local point spacings`` of both the last and the
    predicted position.  Pairs are taken greedily, closest to the prediction
    first, each edge and track at most once.
    """
    n_p = x1.size
    spacing = spacings(x1)  # looked up for every pair below
    tracks: list = []  # dict(edge, t, x, i (point index), k (sample), r (region index))
    open_ids: list = []
    for k, (tk, regs) in enumerate(zip(time, regions)):
        edges = {
            "leading": [(r.x_end, r.i1, q) for q, r in enumerate(regs) if r.i1 < n_p - 1],
            "trailing": [(r.x_start, r.i0, q) for q, r in enumerate(regs) if r.i0 > 0],
        }
        now_open = []
        for edge, cand in edges.items():
            mine = [j for j in open_ids if tracks[j]["edge"] == edge]
            pairs = []
            for j in mine:
                tr = tracks[j]
                dt = tk - tr["t"][-1]
                x_last = tr["x"][-1]
                if len(tr["t"]) >= 2:
                    m = min(npts, len(tr["t"]))
                    v = lsq_slope(tr["t"][-m:], tr["x"][-m:])
                else:
                    v = v_prior
                x_pred = x_last + v * dt
                h_last = spacing[tr["i"][-1]]
                for b, (x, i, _) in enumerate(cand):
                    reach = max_speed * dt + 2.0 * max(h_last, spacing[i])
                    cost = abs(x - x_pred)
                    if abs(x - x_last) <= reach and cost <= reach:
                        pairs.append((cost, j, b))
            pairs.sort()
            used_t, used_c = set(), set()
            for _, j, b in pairs:
                if j in used_t or b in used_c:
                    continue
                used_t.add(j)
                used_c.add(b)
                x, i, q = cand[b]
                for key, val in (("t", tk), ("x", x), ("i", i), ("k", k), ("r", q)):
                    tracks[j][key].append(val)
                now_open.append(j)
            for b, (x, i, q) in enumerate(cand):
                if b not in used_c:
                    tracks.append({"edge": edge, "t": [tk], "x": [x], "i": [i], "k": [k], "r": [q]})
                    now_open.append(len(tracks) - 1)
        open_ids = now_open
    return tracks


def fronts(time, x1, slip_rate, speeds, threshold: float = 0.0, min_points: int = 3, *,
           floor: float = 0.0, min_gap_points: int = 2, min_samples: int = 3, npts: int = 5,
           max_speed: float | None = None, v_prior: float | None = None,
           v_stationary: float | None = None) -> list:
    """Every rupture and healing front of the history (list of :class:`Front`,
    ordered by first appearance).

    The edges of the slipping regions (:func:`slip_regions` with ``threshold``,
    ``min_points``, ``floor``, ``min_gap_points``) are tracked in time: an edge
    at t_k is linked to the edge of the same kind at t_{k+1} nearest to its
    predicted position, within a travel of ``max_speed``·Δt plus two point
    spacings.  ``max_speed`` defaults to 1.75 c_l (the paper reports fronts up
    to 3500 m/s ≈ 1.6 c_l in Case V).  Predicting from the track's own speed
    (new tracks: ``v_prior``, default the median speed of the leading tip)
    keeps a train of pulses that moves half a spacing per sample from being
    linked backwards; the sampling must still resolve the motion
    (speed·Δt well below the pulse spacing).

    Tracks with fewer than ``min_samples`` samples are dropped.  A front's kind
    follows from the sign of its mean speed and its edge: a leading edge moving
    away from the impact edge and a trailing edge moving towards it are
    rupture fronts; the opposite motions are healing fronts; ``|mean speed| <
    v_stationary`` (default 0.02 c_s) is stationary.  Edges on the first or
    last point (the rear of a crack pinned at x1 = 0) are not fronts.
    """
    time, x1, slip_rate = check_history(time, x1, slip_rate)
    sp = check_speeds(speeds)
    max_speed = 1.75 * sp["c_l"] if max_speed is None else float(max_speed)
    v_stationary = 0.02 * sp["c_s"] if v_stationary is None else float(v_stationary)
    w = cell_lengths(x1)
    regions = region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w)
    if v_prior is None:
        v_prior = prior_speed(time, regions, max_speed, npts)
    return fronts_from_tracks(track_edges(time, x1, regions, max_speed, float(v_prior), npts),
                               sp, min_samples, npts, v_stationary)


def edge_speeds(tracks, npts, min_len=3) -> dict:
    """{(edge, sample k, region index): recent speed [m/s]} — least squares over
    the last ``npts`` samples of the edge's track up to k, once the track has
    ``min_len`` samples."""
    out = {}
    for tr in tracks:
        t, x = np.array(tr["t"]), np.array(tr["x"])
        for m in range(min_len - 1, t.size):
            lo = max(0, m - npts + 1)
            out[(tr["edge"], tr["k"][m], tr["r"][m])] = lsq_slope(t[lo : m + 1], x[lo : m + 1])
    return out


def fronts_from_tracks(tracks, sp, min_samples, npts, v_stationary):
    out = []
    for tr in tracks:
        if len(tr["t"]) < max(2, min_samples):
            continue
        t = np.array(tr["t"])
        x = np.array(tr["x"])
        v = lsq_slope(t, x)
        ts, vs = tip_speed(t, x, npts) if t.size >= npts else (np.zeros(0), np.zeros(0))
        if abs(v) < v_stationary:
            kind = "stationary"
        elif (v > 0) == (tr["edge"] == "leading"):
            kind = "rupture"
        else:
            kind = "healing"
        out.append(Front(kind, tr["edge"], t, x, ts, vs, v, mach_numbers(v, sp), regime(v, sp)))
    return out
