"""The sliding mode of a slip-rate history: crack-like, pulse, train of pulses
or mixed, with its evidence (:func:`classify`).

Inputs share one layout (as every function of :mod:`fricfem.analysis`):

    time       float64[n_t]        sample times [s], increasing
    x1         float64[n_p]        interface Gauss-point positions [m], sorted (not uniform)
    slip_rate  float64[n_t, n_p]   Δu̇_slip ≥ 0 [m/s], exactly 0 where the interface sticks
    speeds     dict                c_l, c_s, c_R, sqrt2_c_s [m/s] (``Material().speeds()``)

What the paper measures (Coker, Lykotrafitis, Needleman & Rosakis, "Numerical
Results"): the sliding modes are told apart by the slip-rate field:
crack-like (sliding persists behind the tip), pulse-like (narrow slipping
zones with stick ahead and behind, possibly growing), trains of pulses
(periodic pulses behind the tip, e.g. Case III: width 1.33 mm, stick 0.92 mm,
spacing 2.21 mm) and mixed modes (pulses coalescing into a crack, Case IV; a
pulse followed by a crack, Case V).

Stages: slipping regions of every profile (:func:`~.regions.slip_regions`)
and their edges tracked in time (:mod:`.fronts`) → a type per profile
(:func:`_snapshot`) → the label from the late profiles (:func:`_label`) → the
evidence (:func:`_evidence`).  The thresholds are a :class:`Criteria`.
"""

from __future__ import annotations

import collections
import math
from typing import NamedTuple

import numpy as np

from ..output.rundir import jsonable
from .fronts import edge_speeds, fronts_from_tracks, prior_speed, track_edges
from .regions import cell_lengths, check_history, region_history, spacings
from .speeds import check_speeds, mach_numbers
from .tip import tip_speed

#: Mode labels returned by :func:`classify`.
LABELS = ("none", "crack-like", "pulse", "pulse-train", "mixed")

#: The fewest interface cells across a pulse's width for the pulses a label counts to be
#: resolved.  Linear elements need a few cells to carry a pulse's rise, peak and fall; on
#: the shipped meshes Case III's late pulses span 1.0 cell on ``coarse`` (label "mixed")
#: and 5.5 on ``reference`` ("pulse", as on ``half``): below this the label is said to
#: depend on the mesh (``evidence["resolution"]``).
MIN_CELLS_PER_PULSE = 4.0
#: interface points per mesh cell along the interface (its Gauss points)
POINTS_PER_CELL = 4

#: Snapshot types (one slip-rate profile).
SNAPSHOT_TYPES = ("stick", "nucleation", "crack", "pulses", "train", "crack+pulses")
_PULSE_TYPES = ("pulses", "train", "crack+pulses")


class Criteria(NamedTuple):
    """The thresholds of :func:`classify` (its docstring says how each is used)."""

    threshold: float = 0.0  # slip rate above which a point slides [m/s]
    min_points: int = 3  # a region has at least this many points
    floor: float = 1e-2  # and a peak of at least this [m/s]
    min_gap_points: int = 2  # stick gaps narrower than this are bridged
    crack_ratio: float = 0.75  # W >= crack_ratio (W + H): compact, sliding behind
    crack_rear_ratio: float = 0.5  # trailing edge speed <= this × leading: sliding behind
    crack_dominance: float = 3.0  # a crack is this × wider than the median other region
    train_min_pulses: int = 3
    train_max_cv: float = 0.35  # spacing regularity of a train
    train_min_duty: float = 0.3  # width / spacing of a train
    train_max_peak_ratio: float = 2.5  # 90th / 10th percentile of a train's peaks
    late_fraction: float = 0.2  # the late window: this share of the sliding duration
    min_phase: int = 3  # samples for a mode or a phase to count
    growth_ratio: float = 1.2  # last third / first third for a growing pulse
    npts: int = 5  # points of the progressive speed fit


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


def _snapshot(regs, wake, v_lead, v_trail, c):
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
    if n >= c.train_min_pulses:
        # the leading pulse carries more structure (paper, Case III): judge the
        # regularity on the trailing pulses when there are enough of them
        body = regs[:-1] if n - 1 >= c.train_min_pulses else regs
        bw = np.array([r.width for r in body])
        bp = np.array([r.peak for r in body])
        spacing = np.diff([r.x_end for r in regs])
        sbody = spacing[:-1] if n - 1 >= c.train_min_pulses else spacing
        duty = float(np.median(bw) / np.median(sbody)) if np.median(sbody) > 0 else 0.0
        p10, p90 = np.percentile(bp, [10, 90])
        train = {"spacing_cv": _cv(sbody), "width_cv": _cv(bw), "duty": duty,
                 "peak_ratio": float(p90 / p10) if p10 > 0 else math.inf}
        if (train["spacing_cv"] <= c.train_max_cv and train["width_cv"] <= 0.5 and duty >= c.train_min_duty
                and train["peak_ratio"] <= c.train_max_peak_ratio):
            return "train", ["pulse"] * n, train
    cats = []
    for k, r in enumerate(regs):
        vl, vt = v_lead[k], v_trail[k]
        if vt is not None and vl is not None and vl > 0:
            behind = vt <= c.crack_rear_ratio * vl
        else:
            behind = r.width >= c.crack_ratio * (r.width + wake[k])
        if not behind:
            cats.append("pulse")
            continue
        others = np.delete(widths, k)
        dominant = others.size == 0 or r.width >= c.crack_dominance * float(np.median(others))
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
    spacing = spacings(x1)
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
                tol = 2.0 * max(spacing[r.i0], spacing[r.i1])
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


def classify(time, x1, slip_rate, speeds, criteria: Criteria = Criteria()):
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

    Method (the names are ``criteria``'s, a :class:`Criteria`).  Each profile
    is cut into slipping regions (:func:`~.regions.slip_regions` with
    ``threshold``, ``min_points``, ``floor`` [m/s], ``min_gap_points``:
    one-point blips and tiny stick holes are ignored) and their edges are
    tracked as in :func:`~.fronts.fronts`.  A region keeps sliding behind its
    leading edge if its trailing edge lags (recent speed, over 3 samples, ≤
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
      ``reason`` (ends by saying so when the pulses are under-resolved);
      ``resolution`` (:func:`pulse_resolution`: cells per pulse width against
      :data:`MIN_CELLS_PER_PULSE`); ``t_first_slip`` [s], ``x_first_slip`` [m]; ``late_window``
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
      speeds of rupture/healing fronts); ``params`` (the criteria).
    """
    time, x1, slip_rate = check_history(time, x1, slip_rate)
    sp = check_speeds(speeds)
    c = criteria
    w = cell_lengths(x1)
    regions = region_history(time, x1, slip_rate, c.threshold, c.min_points, c.floor, c.min_gap_points, w)
    sliding = [k for k, r in enumerate(regions) if r]
    if len(sliding) < c.min_phase:
        return "none", jsonable({
            "reason": f"slipping regions at {len(sliding)} sample(s), fewer than min_phase = {c.min_phase} "
                      f"(regions of < {c.min_points} points or with peak < {c.floor} m/s ignored)",
            "sliding_times": time[sliding], "max_regions": max((len(r) for r in regions), default=0),
            "params": c._asdict()})

    max_speed = 1.75 * sp["c_l"]
    v_prior = prior_speed(time, regions, max_speed, c.npts)
    tracks = track_edges(time, x1, regions, max_speed, v_prior, c.npts)
    v_edge = edge_speeds(tracks, 3)  # a short window: categories follow jumps of an edge quickly
    snaps, hist = _snapshots(time, x1, regions, w, v_edge, v_prior, c)
    late, counts, late_type, longest = _late(time, sliding, snaps, c)
    label, reason = _label(late_type, longest, c)
    resolution = pulse_resolution(regions, late, snaps)
    if not resolution["resolved"]:
        reason += (f"; the mesh does not resolve the pulses it counts: {resolution['cells_per_pulse']:.1f} cells "
                   f"per pulse width (median over the late window), fewer than {MIN_CELLS_PER_PULSE:g}: the label "
                   f"may change on a finer mesh")
    evidence = {"reason": reason, "resolution": resolution, **_evidence(time, x1, regions, sliding, snaps, hist, late, counts, late_type,
                                              longest, tracks, v_edge, w, sp, c)}
    return label, jsonable(evidence)


def pulse_resolution(regions, late, snaps) -> dict:
    """How many interface cells the pulses of the late window span: ``cells_per_pulse``
    (median over those pulses of their points / :data:`POINTS_PER_CELL`; None when
    the late profiles hold no pulse), ``pulse_width_m`` (their median width),
    ``min_cells_per_pulse`` (:data:`MIN_CELLS_PER_PULSE`) and ``resolved`` (True
    when there is no pulse to resolve)."""
    cells, widths = [], []
    for k in late:
        for r, cat in zip(regions[k], snaps[k]["cats"]):
            if cat == "pulse":
                cells.append((r.i1 - r.i0 + 1) / POINTS_PER_CELL)
                widths.append(r.width)
    if not cells:
        return {"cells_per_pulse": None, "pulse_width_m": None, "min_cells_per_pulse": MIN_CELLS_PER_PULSE,
                "resolved": True}
    n = float(np.median(cells))
    return {"cells_per_pulse": n, "pulse_width_m": float(np.median(widths)),
            "min_cells_per_pulse": MIN_CELLS_PER_PULSE, "resolved": bool(n >= MIN_CELLS_PER_PULSE)}


def _snapshots(time, x1, regions, w, v_edge, v_prior, c):
    """Type, categories, healed ground and train figures of every sliding
    profile ({sample: dict}), and the per-sample history of the evidence."""
    n_p = x1.size
    cw = np.concatenate(([0.0], np.cumsum(w)))
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
        kind, cats, train = _snapshot(regs, wake, v_lead, v_trail, c)
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
    return snaps, hist


def _late(time, sliding, snaps, c):
    """The late window (the last ``late_fraction`` of the sliding duration, at
    least ``min_phase`` samples), its type counts, its dominant type, and the
    longest run of pulse-type profiles before it."""
    ts = time[sliding]
    t0 = ts[-1] - c.late_fraction * (ts[-1] - ts[0])
    late = [k for k in sliding if time[k] >= t0]
    if len(late) < c.min_phase:
        late = sliding[-c.min_phase:]
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
    return late, counts, late_type, longest


def _label(late_type: str, longest: int, c) -> tuple:
    """(label, reason) from the late profiles' type and the earlier pulse phase."""
    if late_type == "train":
        return "pulse-train", "late profiles: regularly spaced pulses of similar width behind the tip"
    if late_type == "pulses":
        return "pulse", "late profiles: slipping regions of limited width with stick behind them"
    if late_type == "crack+pulses":
        return "mixed", "late profiles: a crack-like region together with pulses"
    if longest >= c.min_phase:
        return "mixed", f"a pulse phase ({longest} samples) followed by a crack-like region"
    return "crack-like", "late profiles: one region that keeps sliding behind the tip"


def _last_profile(time, regions, sliding, snaps, cw) -> dict:
    """The evidence's ``last``: the last sliding profile in figures."""
    kl = sliding[-1]
    regs = regions[kl]
    sn = snaps[kl]
    return {
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


def _late_stats(regions, late, cw, c) -> dict:
    """Medians over the late window; trailing pulses when the leading one can be left out."""
    lw, lg, lsp, lpk, ln = [], [], [], [], []
    for k in late:
        rr = regions[k]
        ln.append(len(rr))
        body = rr[:-1] if len(rr) > c.train_min_pulses else rr
        lw += [r.width for r in body]
        lpk += [r.peak for r in body]
        lg += [float(cw[b.i0] - cw[a.i1 + 1]) for a, b in zip(body[:-1], body[1:])]
        lsp += np.diff([r.x_end for r in body]).tolist()

    def med(a):
        return float(np.median(a)) if len(a) else math.nan

    return {"n_regions": med(ln), "width": med(lw), "stick_gap": med(lg), "spacing": med(lsp), "peak": med(lpk)}


def _evidence(time, x1, regions, sliding, snaps, hist, late, counts, late_type, longest, tracks, v_edge, w, sp,
              c) -> dict:
    """Everything the label rests on (see :func:`classify`), but the reason."""
    cw = np.concatenate(([0.0], np.cumsum(w)))
    # growth of the leading region while it is a pulse
    lead_pulse = [k for k in sliding if snaps[k]["cats"] and snaps[k]["cats"][-1] == "pulse"]
    pg = _growth([regions[k][-1].peak for k in lead_pulse])
    wg = _growth([regions[k][-1].width for k in lead_pulse])
    grow_a, grow_w = bool(pg >= c.growth_ratio), bool(wg >= c.growth_ratio)  # False when nan
    coal = _coalescences(time, x1, regions, v_edge)
    t_tip = np.array(hist["t"])
    x_tip = np.array(hist["tip"])
    _, v_tip = tip_speed(t_tip, x_tip, min(c.npts, t_tip.size)) if t_tip.size >= 2 else (None, np.zeros(0))
    v_med = float(np.median(v_tip)) if v_tip.size else math.nan
    fr = fronts_from_tracks(tracks, sp, 3, c.npts, 0.02 * sp["c_s"])
    fr_summary = {kind: {"count": sum(f.kind == kind for f in fr),
                         "mean_speeds": [f.mean_speed for f in fr if f.kind == kind]}
                  for kind in ("rupture", "healing", "stationary")}
    first = regions[sliding[0]]
    return {
        "t_first_slip": time[sliding[0]],
        "x_first_slip": first[0].x_start,
        "late_window": [time[late[0]], time[late[-1]]],
        "late_type": late_type,
        "late_types": dict(counts),
        "types": dict(collections.Counter(hist["type"])),
        "longest_pulse_phase": longest,
        "last": _last_profile(time, regions, sliding, snaps, cw),
        "late": _late_stats(regions, late, cw, c),
        "max_regions": max(hist["n_regions"]),
        "history": dict(hist),
        "coalescences": coal,
        "coalescence_times": sorted({e["t"] for e in coal}),
        "leading_peak_growth": pg,
        "leading_width_growth": wg,
        "growing_amplitude": grow_a,
        "growing_width": grow_w,
        "growing": grow_a or grow_w,
        "tip_speed": v_med,
        "tip_mach": mach_numbers(v_med, sp) if math.isfinite(v_med) else None,
        "fronts": fr_summary,
        "params": c._asdict(),
    }
