"""Interface diagnostics: leading sliding tip, tip speed, rupture and healing fronts,
sliding-mode classification.

Pure numpy, no dolfinx and no MPI: every function acts on gathered interface
histories (see :func:`fricfem.gather.interface_profile`), identical on every rank.

Inputs share one layout:

    time       float64[n_t]        sample times [s], increasing
    x1         float64[n_p]        interface Gauss-point positions [m], sorted (not uniform)
    slip_rate  float64[n_t, n_p]   Δu̇_slip ≥ 0 [m/s], exactly 0 where the interface sticks
    speeds     dict                c_l, c_s, c_R, sqrt2_c_s [m/s]
                                   (``fricfem.material.Material().speeds()``)

What the paper measures (Coker, Lykotrafitis, Needleman & Rosakis, "Numerical
Results"): the leading sliding tip is the point furthest from the impact edge
(x1 = 0) where Δu̇_slip > 0, and V_tip follows from its positions by "a
progressive least squares fit using five points" (:func:`tip_speed`).  The
sliding modes are told apart by the slip-rate field: crack-like (sliding
persists behind the tip), pulse-like (narrow slipping zones with stick ahead and
behind, possibly growing), trains of pulses (periodic pulses behind the tip,
e.g. Case III: width 1.33 mm, stick 0.92 mm, spacing 2.21 mm) and mixed modes
(pulses coalescing into a crack, Case IV; a pulse followed by a crack, Case V).

Slipping regions (:func:`slip_regions`) are connected runs of points with
Δu̇_slip > ``threshold``.  Diagnostics other than the raw tip ignore isolated
blips: runs of fewer than ``min_points`` points or whose peak is below
``floor`` are dropped, then stick gaps of fewer than ``min_gap_points`` points
are bridged.  A region's ``width`` and a gap's length are sums of the points'
cell lengths (each point owns the interval between the midpoints to its
neighbours), so width + stick gap = pulse spacing.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import NamedTuple

import numpy as np

#: Reference wave speeds a front speed is compared with, slowest first.
SPEED_NAMES = ("c_R", "c_s", "sqrt2_c_s", "c_l")

#: Mode labels returned by :func:`classify`.
LABELS = ("none", "crack-like", "pulse", "pulse-train", "mixed")

#: Snapshot types (one slip-rate profile) used by :func:`classify`.
SNAPSHOT_TYPES = ("stick", "nucleation", "crack", "pulses", "train", "crack+pulses")
_PULSE_TYPES = ("pulses", "train", "crack+pulses")


def _jsonable(obj):
    """Plain Python types for ``json.dumps``: arrays → lists, numpy scalars →
    Python numbers, non-finite floats → ``None``."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def _check_speeds(speeds) -> dict:
    missing = [k for k in SPEED_NAMES if k not in speeds]
    if missing:
        raise ValueError(f"speeds: missing {', '.join(missing)} [m/s] (use Material().speeds())")
    out = {k: float(speeds[k]) for k in SPEED_NAMES}
    for k, v in out.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"speeds[{k!r}] = {v!r} m/s: must be positive")
    return out


def _check_history(time, x1, slip_rate):
    time = np.asarray(time, dtype=np.float64)
    x1 = np.asarray(x1, dtype=np.float64)
    slip_rate = np.asarray(slip_rate, dtype=np.float64)
    if slip_rate.shape != (time.size, x1.size):
        raise ValueError(f"slip_rate has shape {slip_rate.shape}; expected (len(time), len(x1)) = "
                         f"({time.size}, {x1.size})")
    if x1.size > 1 and np.any(np.diff(x1) < 0):
        raise ValueError("x1 must be sorted in increasing order [m]")
    if time.size > 1 and np.any(np.diff(time) <= 0):
        raise ValueError("time must be strictly increasing [s]")
    return time, x1, slip_rate


def mach_numbers(speed: float, speeds: dict) -> dict:
    """|speed| over each reference wave speed: ``{"c_R": .., "c_s": .., "sqrt2_c_s": .., "c_l": ..}``."""
    sp = _check_speeds(speeds)
    return {k: abs(float(speed)) / sp[k] for k in SPEED_NAMES}


def regime(speed: float, speeds: dict) -> str:
    """Name of the speed range |speed| falls in: ``sub-Rayleigh`` (< c_R),
    ``sub-shear`` (c_R .. c_s), ``intersonic`` (c_s .. √2 c_s), ``intersonic
    above sqrt2 c_s`` (√2 c_s .. c_l) or ``supersonic`` (≥ c_l)."""
    sp = _check_speeds(speeds)
    v = abs(float(speed))
    if not math.isfinite(v):
        return "unknown"
    if v < sp["c_R"]:
        return "sub-Rayleigh"
    if v < sp["c_s"]:
        return "sub-shear"
    if v < sp["sqrt2_c_s"]:
        return "intersonic"
    if v < sp["c_l"]:
        return "intersonic above sqrt2 c_s"
    return "supersonic"


# ---------------------------------------------------------------------------
# leading tip and its speed
# ---------------------------------------------------------------------------


def leading_tip(x1, slip_rate_row, threshold: float = 0.0) -> float:
    """x1 [m] of the point furthest from the impact edge (x1 = 0) with
    Δu̇_slip > ``threshold`` [m/s]; ``nan`` if no point slides.

    This is the paper's leading sliding tip: no filtering, a single sliding
    point counts.
    """
    x1 = np.asarray(x1, dtype=np.float64)
    on = np.flatnonzero(np.asarray(slip_rate_row) > threshold)
    return float(x1[on[-1]]) if on.size else math.nan


def tip_history(time, x1, slip_rate, threshold: float = 0.0):
    """(t float64[m], x_tip float64[m]) of the leading sliding tip [s, m], over
    the m sample times at which some point slides."""
    time, x1, slip_rate = _check_history(time, x1, slip_rate)
    on = slip_rate > threshold
    has = on.any(axis=1)
    # index of the last sliding point of every row
    last = x1.size - 1 - np.argmax(on[:, ::-1], axis=1)
    return time[has], x1[last[has]]


def tip_speed(t, x, npts: int = 5):
    """Speed of a front from its positions by the paper's progressive least-squares fit.

    A window of ``npts`` consecutive samples slides along the series; in each
    window the slope of the least-squares line x ≈ a + V t is

        V = Σ (t_i − t̄)(x_i − x̄) / Σ (t_i − t̄)²

    and is assigned to the window's centre time t̄ (the middle sample for odd
    ``npts`` and equally spaced samples).  The fit smooths the staircase of a
    tip that jumps from Gauss point to Gauss point; the paper notes that
    oscillations of V_tip may partly come from this differentiation.

    t float64[m] [s], x float64[m] [m] → (t_centre float64[m−npts+1] [s],
    V float64[m−npts+1] [m/s]); empty arrays if m < npts.
    """
    if int(npts) < 2:
        raise ValueError(f"npts = {npts!r}: the fit needs at least 2 points")
    npts = int(npts)
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.shape != x.shape or t.ndim != 1:
        raise ValueError(f"t and x must be 1-D of equal length; got {t.shape} and {x.shape}")
    if t.size < npts:
        return np.zeros(0), np.zeros(0)
    tw = np.lib.stride_tricks.sliding_window_view(t, npts)
    xw = np.lib.stride_tricks.sliding_window_view(x, npts)
    tc = tw.mean(axis=1)
    dt = tw - tc[:, None]
    v = (dt * (xw - xw.mean(axis=1)[:, None])).sum(axis=1) / (dt * dt).sum(axis=1)
    return tc, v


def _lsq_slope(t, x) -> float:
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.size < 2:
        return math.nan
    dt = t - t.mean()
    return float((dt * (x - x.mean())).sum() / (dt * dt).sum())


# ---------------------------------------------------------------------------
# slipping regions
# ---------------------------------------------------------------------------


def cell_lengths(x1) -> np.ndarray:
    """Length [m] of the interval each point owns: between the midpoints to its
    neighbours (half a spacing beyond the first and last point)."""
    x1 = np.asarray(x1, dtype=np.float64)
    if x1.size < 2:
        return np.zeros(x1.size)
    mid = 0.5 * (x1[1:] + x1[:-1])
    lo = np.concatenate(([x1[0] - (mid[0] - x1[0])], mid))
    hi = np.concatenate((mid, [x1[-1] + (x1[-1] - mid[-1])]))
    return hi - lo


class Region(NamedTuple):
    """One slipping region of a slip-rate profile.

    i0, i1     first and last point index (inclusive)
    x_start    x1 of the first point, nearest the impact edge [m]
    x_end      x1 of the last point, furthest from the impact edge [m]
    width      sum of the points' cell lengths [m]
    peak       largest Δu̇_slip in the region [m/s]
    x_peak     where it occurs [m]
    """

    i0: int
    i1: int
    x_start: float
    x_end: float
    width: float
    peak: float
    x_peak: float

    def to_dict(self) -> dict:
        return _jsonable(self._asdict())


def slip_regions(x1, slip_rate_row, threshold: float = 0.0, *, min_points: int = 1,
                 floor: float = 0.0, min_gap_points: int = 1, weights=None) -> list:
    """Slipping regions of one profile, sorted along x1 (list of :class:`Region`).

    Runs of points with Δu̇_slip > ``threshold`` [m/s]; runs of fewer than
    ``min_points`` points or with a peak below ``floor`` [m/s] are dropped
    (numerical blips), then regions separated by fewer than ``min_gap_points``
    stuck points are joined.  ``weights`` are the points' cell lengths
    (:func:`cell_lengths`, computed if not given).  The defaults keep every run.
    """
    x1 = np.asarray(x1, dtype=np.float64)
    s = np.asarray(slip_rate_row, dtype=np.float64)
    w = cell_lengths(x1) if weights is None else weights
    on = s > threshold
    if not on.any():
        return []
    d = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    if min_points > 1 or floor > 0.0:
        peaks = np.maximum.reduceat(s, starts)
        keep = (ends - starts + 1 >= min_points) & (peaks >= floor)
        starts, ends = starts[keep], ends[keep]
        if starts.size == 0:
            return []
    if min_gap_points > 1 and starts.size > 1:
        wide = (starts[1:] - ends[:-1] - 1) >= min_gap_points
        starts = np.concatenate((starts[:1], starts[1:][wide]))
        ends = np.concatenate((ends[:-1][wide], ends[-1:]))
    cw = np.concatenate(([0.0], np.cumsum(w)))
    out = []
    for a, b in zip(starts.tolist(), ends.tolist()):
        j = a + int(np.argmax(s[a : b + 1]))
        out.append(Region(a, b, float(x1[a]), float(x1[b]), float(cw[b + 1] - cw[a]), float(s[j]), float(x1[j])))
    return out


def _region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w):
    return [slip_regions(x1, row, threshold, min_points=min_points, floor=floor,
                         min_gap_points=min_gap_points, weights=w) for row in slip_rate]


def _local_spacing(x1, i) -> float:
    """Largest spacing next to point ``i`` [m]."""
    lo = x1[i] - x1[i - 1] if i > 0 else 0.0
    hi = x1[i + 1] - x1[i] if i + 1 < x1.size else 0.0
    return max(lo, hi)


def _prior_speed(time, regions, max_speed, npts) -> float:
    """Median speed [m/s] of the filtered leading tip, clipped to [0, max_speed]:
    the expected motion of a front seen for the first time."""
    t = np.array([tk for tk, r in zip(time, regions) if r])
    x = np.array([r[-1].x_end for r in regions if r])
    if t.size < 2:
        return 0.0
    _, v = tip_speed(t, x, min(npts, t.size))
    return float(np.clip(np.median(v), 0.0, max_speed))


# ---------------------------------------------------------------------------
# rupture and healing fronts
# ---------------------------------------------------------------------------


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
        return _jsonable(dataclasses.asdict(self))


def _track_edges(time, x1, regions, max_speed, v_prior, npts):
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
                    v = _lsq_slope(tr["t"][-m:], tr["x"][-m:])
                else:
                    v = v_prior
                x_pred = x_last + v * dt
                h_last = _local_spacing(x1, tr["i"][-1])
                for b, (x, i, _) in enumerate(cand):
                    reach = max_speed * dt + 2.0 * max(h_last, _local_spacing(x1, i))
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
    time, x1, slip_rate = _check_history(time, x1, slip_rate)
    sp = _check_speeds(speeds)
    max_speed = 1.75 * sp["c_l"] if max_speed is None else float(max_speed)
    v_stationary = 0.02 * sp["c_s"] if v_stationary is None else float(v_stationary)
    w = cell_lengths(x1)
    regions = _region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w)
    if v_prior is None:
        v_prior = _prior_speed(time, regions, max_speed, npts)
    return _fronts_from_tracks(_track_edges(time, x1, regions, max_speed, float(v_prior), npts),
                               sp, min_samples, npts, v_stationary)


def _edge_speeds(tracks, npts, min_len=3) -> dict:
    """{(edge, sample k, region index): recent speed [m/s]} — least squares over
    the last ``npts`` samples of the edge's track up to k, once the track has
    ``min_len`` samples."""
    out = {}
    for tr in tracks:
        t, x = np.array(tr["t"]), np.array(tr["x"])
        for m in range(min_len - 1, t.size):
            lo = max(0, m - npts + 1)
            out[(tr["edge"], tr["k"][m], tr["r"][m])] = _lsq_slope(t[lo : m + 1], x[lo : m + 1])
    return out


def _fronts_from_tracks(tracks, sp, min_samples, npts, v_stationary):
    out = []
    for tr in tracks:
        if len(tr["t"]) < max(2, min_samples):
            continue
        t = np.array(tr["t"])
        x = np.array(tr["x"])
        v = _lsq_slope(t, x)
        ts, vs = tip_speed(t, x, npts) if t.size >= npts else (np.zeros(0), np.zeros(0))
        if abs(v) < v_stationary:
            kind = "stationary"
        elif (v > 0) == (tr["edge"] == "leading"):
            kind = "rupture"
        else:
            kind = "healing"
        out.append(Front(kind, tr["edge"], t, x, ts, vs, v, mach_numbers(v, sp), regime(v, sp)))
    return out


# ---------------------------------------------------------------------------
# sliding-mode classification
# ---------------------------------------------------------------------------


def _healed_behind(regs, healed, cw):
    """Length [m] of the run of healed points (slipped before, stuck now)
    directly behind each region."""
    n = healed.size
    idx = np.arange(n)
    last_unhealed = np.maximum.accumulate(np.where(~healed, idx, -1))
    out = []
    for r in regs:
        j = r.i0 - 1
        if j < 0 or not healed[j]:
            out.append(0.0)
            continue
        start = last_unhealed[j] + 1
        out.append(float(cw[r.i0] - cw[start]))
    return out


def _cv(a) -> float:
    a = np.asarray(a, dtype=np.float64)
    if a.size < 2 or a.mean() <= 0:
        return math.inf if a.size < 2 else 0.0
    return float(a.std() / a.mean())


def _snapshot(regs, wake, v_lead, v_trail, crack_ratio, crack_rear_ratio, crack_dominance,
              train_min_pulses, train_max_cv, train_min_duty, train_max_peak_ratio):
    """(type, per-region categories, train statistics) of one profile.

    A region (width W, healed ground H directly behind it) keeps sliding
    behind its leading edge if its trailing edge lags: the trailing edge's
    recent speed is ≤ crack_rear_ratio × the leading edge's (the region grows,
    e.g. the pinned rear of a crack, or of pulses coalesced into one); when the
    trailing edge has no speed yet (on x1 = 0, or just appeared) it counts as
    sliding behind if compact, W ≥ crack_ratio·(W + H).

    Categories: ``crack`` (sliding behind and dominant: alone, or ≥
    crack_dominance × the median width of the other regions), ``nucleus``
    (sliding behind but not dominant: a patch not yet linked up), ``pulse``
    (otherwise: stick closes in behind it).  A profile with ≥
    train_min_pulses regions of similar widths (CV ≤ 0.5), regular spacing
    (CV ≤ train_max_cv) and duty width/spacing ≥ train_min_duty is a ``train``
    whatever the categories, provided their peaks are alike (90th over 10th
    percentile ≤ train_max_peak_ratio: growing pulses born one after another,
    as in Case II, differ in amplitude by age and are not a train).
    """
    n = len(regs)
    if n == 0:
        return "stick", [], {}
    widths = np.array([r.width for r in regs])
    train = {}
    if n >= train_min_pulses:
        # the leading pulse carries more structure (paper, Case III): judge the
        # regularity on the trailing pulses when there are enough of them
        body = regs[:-1] if n - 1 >= train_min_pulses else regs
        bw = np.array([r.width for r in body])
        bp = np.array([r.peak for r in body])
        spacing = np.diff([r.x_end for r in regs])
        sbody = spacing[:-1] if n - 1 >= train_min_pulses else spacing
        duty = float(np.median(bw) / np.median(sbody)) if np.median(sbody) > 0 else 0.0
        p10, p90 = np.percentile(bp, [10, 90])
        train = {"spacing_cv": _cv(sbody), "width_cv": _cv(bw), "duty": duty,
                 "peak_ratio": float(p90 / p10) if p10 > 0 else math.inf}
        if (train["spacing_cv"] <= train_max_cv and train["width_cv"] <= 0.5 and duty >= train_min_duty
                and train["peak_ratio"] <= train_max_peak_ratio):
            return "train", ["pulse"] * n, train
    cats = []
    for k, r in enumerate(regs):
        vl, vt = v_lead[k], v_trail[k]
        if vt is not None and vl is not None and vl > 0:
            behind = vt <= crack_rear_ratio * vl
        else:
            behind = r.width >= crack_ratio * (r.width + wake[k])
        if not behind:
            cats.append("pulse")
            continue
        others = np.delete(widths, k)
        dominant = others.size == 0 or r.width >= crack_dominance * float(np.median(others))
        cats.append("crack" if dominant else "nucleus")
    has_crack, has_pulse = "crack" in cats, "pulse" in cats
    if has_crack and has_pulse:
        kind = "crack+pulses"
    elif has_crack:
        kind = "crack"
    elif has_pulse:
        kind = "pulses"
    else:
        kind = "nucleation"
    return kind, cats, train


def _coalescences(time, x1, regions, v_edge):
    """Gap closures: adjacent regions A (behind) and B (ahead) at t_{k−1} whose
    facing edges — A's leading and B's trailing edge, each tracked for at least
    three samples and moved on by its own speed — both lie in one region at
    t_k (within two point spacings).  Stick gaps that flicker open for a sample
    or two have no speeds and are not counted."""
    events = []
    for k in range(1, len(regions)):
        prev, regs = regions[k - 1], regions[k]
        if len(prev) < 2 or not regs:
            continue
        dt = time[k] - time[k - 1]
        for q in range(len(prev) - 1):
            va = v_edge.get(("leading", k - 1, q))
            vb = v_edge.get(("trailing", k - 1, q + 1))
            if va is None or vb is None:
                continue
            a, b = prev[q], prev[q + 1]
            xa, xb = a.x_end + va * dt, b.x_start + vb * dt
            for r in regs:
                tol = 2.0 * max(_local_spacing(x1, r.i0), _local_spacing(x1, r.i1))
                if r.x_start - tol <= min(xa, xb) and max(xa, xb) <= r.x_end + tol:
                    events.append({"t": float(time[k]), "x_gap": 0.5 * (a.x_end + b.x_start),
                                   "x_start": r.x_start, "x_end": r.x_end})
                    break
    return events


def _growth(values) -> float:
    """Mean of the last third over the mean of the first third (nan if < 3 values)."""
    v = np.asarray(values, dtype=np.float64)
    if v.size < 3:
        return math.nan
    m = max(1, v.size // 3)
    first = v[:m].mean()
    return float(v[-m:].mean() / first) if first > 0 else math.inf


def classify(time, x1, slip_rate, speeds, threshold: float = 0.0, *, min_points: int = 3,
             floor: float = 1e-2, min_gap_points: int = 2, crack_ratio: float = 0.75,
             crack_rear_ratio: float = 0.5, crack_dominance: float = 3.0, train_min_pulses: int = 3,
             train_max_cv: float = 0.35, train_min_duty: float = 0.3, train_max_peak_ratio: float = 2.5,
             late_fraction: float = 0.2, min_phase: int = 3,
             growth_ratio: float = 1.2, npts: int = 5):
    """Sliding mode of a slip-rate history → ``(label, evidence)``.

    label ∈ :data:`LABELS`:

    - ``none``: no slipping region, or slipping regions at fewer than
      ``min_phase`` samples (too little to tell a mode);
    - ``crack-like``: late profiles hold one dominant region that keeps
      sliding behind its leading edge — sliding persists at a point after the
      front has passed — and the history shows no lasting pulse phase;
    - ``pulse``: late profiles hold slipping regions of limited width with
      stick behind them, single or well separated (``evidence["growing"]``
      tells whether the leading pulse grows in amplitude or width);
    - ``pulse-train``: late profiles hold ≥ ``train_min_pulses`` pulses of
      similar width at roughly periodic spacing behind the leading tip;
    - ``mixed``: a crack-like region together with pulses in late profiles
      (a pulse followed by a crack, Case V; pulses still coalescing with a
      crack, Case IV), or a crack after a pulse phase of at least
      ``min_phase`` consecutive samples.

    Method.  Each profile is cut into slipping regions (:func:`slip_regions`
    with ``threshold``, ``min_points``, ``floor`` [m/s], ``min_gap_points``:
    one-point blips and tiny stick holes are ignored) and their edges are
    tracked as in :func:`fronts`.  A region keeps sliding behind its leading
    edge if its trailing edge lags (recent speed, over 3 samples, ≤
    crack_rear_ratio × the leading edge's: a crack's rear is pinned, also
    after pulses coalesced into it) or, while the trailing edge has no speed
    yet, if it is compact: W ≥ crack_ratio·(W + H), with W its width and H the
    length of "healed" ground (slipped before, stuck now) directly behind it.
    Such a region is a crack if dominant (alone, or ≥ crack_dominance × the
    median width of the others), else a nucleus; all other regions are pulses.
    Each profile gets a type (see :data:`SNAPSHOT_TYPES`): ``train``,
    ``crack``, ``pulses``, ``crack+pulses``, ``nucleation`` (small unlinked
    patches) or ``stick``.  The label follows from the most frequent type over
    the last ``late_fraction`` of the sliding duration (at least ``min_phase``
    samples) and, for a late crack, from the longest run of pulse-type
    profiles before.

    evidence (JSON-ready dict):
      ``reason``; ``t_first_slip`` [s], ``x_first_slip`` [m]; ``late_window``
      [s], ``late_type``, ``late_types`` (counts), ``types`` (counts over the
      history), ``longest_pulse_phase`` (samples, before the late window);
      ``last``: the last sliding profile — ``t``, ``n_regions``, ``regions``
      (Region dicts), ``categories`` (crack/pulse/nucleus), ``widths``,
      ``stick_gaps``, ``spacings`` (leading edge to leading edge) [m],
      ``peaks`` [m/s], ``healed_behind`` [m], ``train`` (regularity figures),
      ``slipped_length``, ``sliding_length`` [m], ``active_fraction`` (sliding
      length / slipped length); ``late``: medians over the late window of the
      number of regions, width, stick gap, spacing (trailing pulses: leading
      region excluded when there are enough) and peak; ``max_regions``;
      ``history``: per sample ``t``, ``n_regions``, ``type``,
      ``active_fraction``, ``tip`` (filtered leading tip), ``leading_peak``,
      ``leading_width``, ``max_peak``; ``coalescences`` (t, x of the closed
      gap at t_{k−1}, extent of the joined region) and ``coalescence_times``;
      ``leading_peak_growth``, ``leading_width_growth`` (mean of the last
      third over the first third of the samples where the leading region is a pulse),
      ``growing_amplitude``, ``growing_width``, ``growing``; ``tip_speed``
      (median 5-point V_tip [m/s]), ``tip_mach``, ``fronts`` (counts and mean
      speeds of rupture/healing fronts); ``params``.
    """
    time, x1, slip_rate = _check_history(time, x1, slip_rate)
    sp = _check_speeds(speeds)
    params = dict(threshold=threshold, min_points=min_points, floor=floor, min_gap_points=min_gap_points,
                  crack_ratio=crack_ratio, crack_rear_ratio=crack_rear_ratio, crack_dominance=crack_dominance,
                  train_min_pulses=train_min_pulses, train_max_cv=train_max_cv,
                  train_min_duty=train_min_duty, train_max_peak_ratio=train_max_peak_ratio,
                  late_fraction=late_fraction, min_phase=min_phase,
                  growth_ratio=growth_ratio, npts=npts)
    w = cell_lengths(x1)
    cw = np.concatenate(([0.0], np.cumsum(w)))
    regions = _region_history(time, x1, slip_rate, threshold, min_points, floor, min_gap_points, w)
    sliding = [k for k, r in enumerate(regions) if r]
    if len(sliding) < min_phase:
        return "none", _jsonable({
            "reason": f"slipping regions at {len(sliding)} sample(s), fewer than min_phase = {min_phase} "
                      f"(regions of < {min_points} points or with peak < {floor} m/s ignored)",
            "sliding_times": time[sliding], "max_regions": max((len(r) for r in regions), default=0),
            "params": params})

    max_speed = 1.75 * sp["c_l"]
    v_prior = _prior_speed(time, regions, max_speed, npts)
    tracks = _track_edges(time, x1, regions, max_speed, v_prior, npts)
    v_edge = _edge_speeds(tracks, 3)  # a short window: categories follow jumps of an edge quickly

    n_p = x1.size
    ever = np.zeros(n_p, dtype=bool)
    hist = collections.defaultdict(list)
    snaps = {}
    for k, regs in enumerate(regions):
        mask = np.zeros(n_p, dtype=bool)
        for r in regs:
            mask[r.i0 : r.i1 + 1] = True
        ever |= mask
        if not regs:
            continue
        healed = ever & ~mask
        wake = _healed_behind(regs, healed, cw)
        v_lead = [v_edge.get(("leading", k, q), v_prior if r.i1 == n_p - 1 else None) for q, r in enumerate(regs)]
        v_trail = [v_edge.get(("trailing", k, q)) for q in range(len(regs))]
        kind, cats, train = _snapshot(regs, wake, v_lead, v_trail, crack_ratio, crack_rear_ratio,
                                      crack_dominance, train_min_pulses, train_max_cv, train_min_duty,
                                      train_max_peak_ratio)
        slipped = float(w[ever].sum())
        active = float(w[mask].sum())
        snaps[k] = dict(kind=kind, cats=cats, wake=wake, train=train, slipped=slipped, active=active)
        hist["t"].append(time[k])
        hist["n_regions"].append(len(regs))
        hist["type"].append(kind)
        hist["active_fraction"].append(active / slipped if slipped > 0 else 1.0)
        hist["tip"].append(regs[-1].x_end)
        hist["leading_peak"].append(regs[-1].peak)
        hist["leading_width"].append(regs[-1].width)
        hist["max_peak"].append(max(r.peak for r in regs))

    # late window: the last late_fraction of the sliding duration, >= min_phase samples
    ts = time[sliding]
    t0 = ts[-1] - late_fraction * (ts[-1] - ts[0])
    late = [k for k in sliding if time[k] >= t0]
    if len(late) < min_phase:
        late = sliding[-min_phase:]
    counts = collections.Counter(snaps[k]["kind"] for k in late)
    best = max(counts.values())
    late_type = next(snaps[k]["kind"] for k in reversed(late) if counts[snaps[k]["kind"]] == best)
    if late_type == "nucleation":  # unlinked patches only: fall back on the latest structured profile
        structured = [snaps[k]["kind"] for k in sliding if snaps[k]["kind"] != "nucleation"]
        late_type = structured[-1] if structured else "crack"

    run = longest = 0
    for k in sliding:
        if k >= late[0]:
            break
        run = run + 1 if snaps[k]["kind"] in _PULSE_TYPES else 0
        longest = max(longest, run)

    if late_type == "train":
        label, reason = "pulse-train", "late profiles: regularly spaced pulses of similar width behind the tip"
    elif late_type == "pulses":
        label, reason = "pulse", "late profiles: slipping regions of limited width with stick behind them"
    elif late_type == "crack+pulses":
        label, reason = "mixed", "late profiles: a crack-like region together with pulses"
    elif longest >= min_phase:
        label, reason = "mixed", f"a pulse phase ({longest} samples) followed by a crack-like region"
    else:
        label, reason = "crack-like", "late profiles: one region that keeps sliding behind the tip"

    # the last sliding profile
    kl = sliding[-1]
    regs = regions[kl]
    sn = snaps[kl]
    last = {
        "t": time[kl],
        "n_regions": len(regs),
        "regions": [r.to_dict() for r in regs],
        "categories": sn["cats"],
        "widths": [r.width for r in regs],
        "stick_gaps": [float(cw[b.i0] - cw[a.i1 + 1]) for a, b in zip(regs[:-1], regs[1:])],
        "spacings": np.diff([r.x_end for r in regs]).tolist(),
        "peaks": [r.peak for r in regs],
        "healed_behind": sn["wake"],
        "slipped_length": sn["slipped"],
        "sliding_length": sn["active"],
        "active_fraction": sn["active"] / sn["slipped"] if sn["slipped"] > 0 else 1.0,
        "train": sn["train"],
    }

    # medians over the late window; trailing pulses when the leading one can be left out
    lw, lg, lsp, lpk, ln = [], [], [], [], []
    for k in late:
        rr = regions[k]
        ln.append(len(rr))
        body = rr[:-1] if len(rr) > train_min_pulses else rr
        lw += [r.width for r in body]
        lpk += [r.peak for r in body]
        lg += [float(cw[b.i0] - cw[a.i1 + 1]) for a, b in zip(body[:-1], body[1:])]
        lsp += np.diff([r.x_end for r in body]).tolist()

    def _med(a):
        return float(np.median(a)) if len(a) else math.nan

    late_stats = {"n_regions": _med(ln), "width": _med(lw), "stick_gap": _med(lg), "spacing": _med(lsp),
                  "peak": _med(lpk)}

    # growth of the leading region while it is a pulse
    lead_pulse = [k for k in sliding if snaps[k]["cats"] and snaps[k]["cats"][-1] == "pulse"]
    peaks = [regions[k][-1].peak for k in lead_pulse]
    widths = [regions[k][-1].width for k in lead_pulse]
    pg, wg = _growth(peaks), _growth(widths)
    grow_a, grow_w = bool(pg >= growth_ratio), bool(wg >= growth_ratio)  # False when nan

    coal = _coalescences(time, x1, regions, v_edge)

    t_tip = np.array(hist["t"])
    x_tip = np.array(hist["tip"])
    _, v_tip = tip_speed(t_tip, x_tip, min(npts, t_tip.size)) if t_tip.size >= 2 else (None, np.zeros(0))
    v_med = float(np.median(v_tip)) if v_tip.size else math.nan

    fr = _fronts_from_tracks(tracks, sp, 3, npts, 0.02 * sp["c_s"])
    fr_summary = {kind: {"count": sum(f.kind == kind for f in fr),
                         "mean_speeds": [f.mean_speed for f in fr if f.kind == kind]}
                  for kind in ("rupture", "healing", "stationary")}

    first = regions[sliding[0]]
    evidence = {
        "reason": reason,
        "t_first_slip": time[sliding[0]],
        "x_first_slip": first[0].x_start,
        "late_window": [time[late[0]], time[late[-1]]],
        "late_type": late_type,
        "late_types": dict(counts),
        "types": dict(collections.Counter(hist["type"])),
        "longest_pulse_phase": longest,
        "last": last,
        "late": late_stats,
        "max_regions": max(hist["n_regions"]),
        "history": dict(hist),
        "coalescences": coal,
        "coalescence_times": sorted({c["t"] for c in coal}),
        "leading_peak_growth": pg,
        "leading_width_growth": wg,
        "growing_amplitude": grow_a,
        "growing_width": grow_w,
        "growing": grow_a or grow_w,
        "tip_speed": v_med,
        "tip_mach": mach_numbers(v_med, sp) if math.isfinite(v_med) else None,
        "fronts": fr_summary,
        "params": params,
    }
    return label, _jsonable(evidence)
