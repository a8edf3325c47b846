"""A mode map's records (:mod:`fricfem.sweep`): each point's entry read from its run
directory, and per map ``modemap.json`` and ``modemap.png`` (plus the combined
figure of ``--variants``), written by rank 0 once the points have run."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from .. import batch
from ..analysis.modemap import boundary, confidence, label_table, tag
from ..output.quantities import INTERFACE_FILE
from ..output.rundir import open_interface, read_summary
from ..plot.modemap import figure
from .planning import Point, physics_title


def peak_slip_rate(run_dir: Path) -> float | None:
    """max Δu̇_slip [m/s] over the recorded interface snapshots (None without a file)."""
    try:
        with open_interface(Path(run_dir) / INTERFACE_FILE) as itf:
            return float(itf.all("slip_rate").max()) if itf.n_time else 0.0
    except (OSError, KeyError):
        return None


def _finite_median(values) -> float | None:
    vals = sorted(v for v in values or () if v is not None and math.isfinite(v))
    if not vals:
        return None
    n = len(vals)
    return vals[n // 2] if n % 2 else 0.5 * (vals[n // 2 - 1] + vals[n // 2])


def point_label(point: Point) -> str | None:
    """The point's label from its run directory (None unless complete): the mode, or
    ``diverged`` when the watchdog stopped it."""
    if batch.status(point.job) != "done":
        return None
    s = read_summary(point.dir)
    return "diverged" if s.get("watchdog") else (s.get("mode") or {}).get("label")


def record(point: Point) -> dict:
    """One point of ``modemap.json``, from its run directory."""
    s = read_summary(point.dir)
    mode = s.get("mode") or {}
    ev = mode.get("evidence") or {}
    tip = s.get("tip") or {}
    ini = s.get("initiation")
    label = "diverged" if s.get("watchdog") else mode.get("label")
    return {
        "key": point.key,
        "sigma0_MPa": point.sigma0_mpa,
        "v_imp_m_s": point.v_imp,
        "dir": str(Path("points") / point.key),
        "complete": batch.status(point.job) == "done",
        "label": label,
        "confidence": confidence(label, ev),
        "reason": s.get("watchdog") or ev.get("reason") or s.get("diagnostics_error"),
        "initiation": ini,
        "peak_slip_rate_m_s": peak_slip_rate(point.dir) if s else None,
        "tip_speed_median_m_s": _finite_median(tip.get("v_tip_m_s")) if ini else None,
        "tip_extent_m": max(tip.get("x1_m") or [], default=None),
        "wall_s": (s.get("wall_s") or {}).get("total"),
        "steps": s.get("steps"),
        "dofs": s.get("dofs"),
        "overrides": [o for o in point.overrides if not o.startswith("name=")],
    }


BOUNDARY_METHOD = ("cell edges between a crack-like point and a neighbour with pulse, pulse-train or mixed "
                   "sliding (each point's cell reaches half-way, in log, to its neighbours); polylines "
                   "[[Σ0 MPa, V_imp m/s], ...]")
CONFIDENCE_MEANING = ("share of the late-window slip-rate profiles (last 20 % of the sliding duration) whose "
                      "type decided the label; for 'none', 1 - (samples with slipping regions) / min_phase")


def write_map(out: Path, meta: dict, sigma0, v_imp, records: list, adaptive: dict | None = None) -> dict:
    """``out/modemap.json`` and ``out/modemap.png``; returns the JSON document.

    ``adaptive``: {"labels", "computed", ...} of an adaptive map (labels of the
    points not computed inferred from their cell); else the records' labels."""
    by_key = {r["key"]: r for r in records}
    labels = adaptive["labels"] if adaptive else label_table(sigma0, v_imp, by_key)
    conf = [[(by_key.get(f"s{tag(s)}_v{tag(v)}") or {}).get("confidence") for v in v_imp] for s in sigma0]
    doc = {
        **meta,
        "grid": {"sigma0_MPa": list(sigma0), "v_imp_m_s": list(v_imp)},
        "labels": {"layout": "labels[i][j] at sigma0_MPa[i], v_imp_m_s[j]", "values": labels},
        "confidence": {"meaning": CONFIDENCE_MEANING, "values": conf},
        "boundary": {"method": BOUNDARY_METHOD, "lines": [[list(p) for p in line]
                                                          for line in boundary(sigma0, v_imp, labels)]},
        **({"adaptive": {k: v for k, v in adaptive.items() if k != "labels"}} if adaptive else {}),
        "points": records,
    }
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "modemap.json.tmp"
    tmp.write_text(json.dumps(doc, indent=2, allow_nan=False, default=str))
    tmp.replace(out / "modemap.json")
    figure({meta["title"]: (sigma0, v_imp, labels, conf, adaptive and adaptive["computed"])},
           out / "modemap.png", note=meta.get("note"))
    return doc


def _calls(path: Path, ranks: int, wall: float, recs: list) -> list:
    """The record of every call on this map (a resumed sweep's own wall time is small)."""
    try:
        calls = json.loads(path.read_text()).get("calls", [])
    except (FileNotFoundError, json.JSONDecodeError, AttributeError):
        calls = []
    now = [r for r in recs if r["computed_now"]]
    calls.append({"finished": time.strftime("%Y-%m-%dT%H:%M:%S"), "ranks": ranks, "wall_s": wall,
                  "computed": len(now), "point_wall_s": sum(r["wall_s"] or 0.0 for r in now)})
    return calls


def collect(maps, points, results, spec, label, ranks, t0, refined=None) -> dict:
    """Rank 0: records of every point, ``modemap.json``/``.png`` per map, the combined figure.
    ``refined``: {map name: adaptive dict} of an adaptive map."""
    computed = {r.key: r.error for r in results}
    wall = time.perf_counter() - t0
    s, v = spec["sigma0"], spec["v_imp"]
    docs = {}
    for name, mp in maps.items():
        recs = []
        for p in (p for p in points if p.map == name):
            r = record(p)
            r["computed_now"] = p.job.key in computed
            if computed.get(p.job.key):
                r["error"] = computed[p.job.key]
            recs.append(r)
        f = mp["factor"]
        meta = {
            "title": label if label and not name else f"{label}: C_n, C_s {_factor(f)}" if label
            else physics_title(mp["scene"]),
            "note": f"base scene {mp['scene'].name};\n{len(recs)} scenes"
                    + (f" of {len(s) * len(v)} points\n(adaptive)" if refined else ""),
            "base": str(spec["base"]), "map": name or "main", "dir": str(mp["dir"]), "sets": spec["sets"],
            "preset": spec["preset"], "interface_factor": f, "Cn_Pa_m": mp["Cn"], "Cs_Pa_m": mp["Cs"],
            "t_end_s": mp["scene"].t_end, "law": mp["scene"].law,
            "overrides": list(mp["overrides"]), "ranks": ranks, "sweep_wall_s": wall,
            "calls": _calls(mp["dir"] / "modemap.json", ranks, wall, recs),
            "computed": [r["key"] for r in recs if r["computed_now"]],
            "reused": [r["key"] for r in recs if not r["computed_now"] and r["complete"]],
            "incomplete": [r["key"] for r in recs if not r["complete"]],
        }
        docs[name] = write_map(mp["dir"], meta, s, v, recs, refined and refined[name])
    if len(maps) > 1:
        panels = {}
        for name, doc in docs.items():
            t = "C_n, C_s of the scene" if not name else f"C_n, C_s {_factor(maps[name]['factor'])}"
            t += f"\n(C_n = {doc['Cn_Pa_m'] / 1e12:g}, C_s = {doc['Cs_Pa_m'] / 1e12:g} MPa/µm)"
            panels[t] = (s, v, doc["labels"]["values"], doc["confidence"]["values"],
                         (doc.get("adaptive") or {}).get("computed"))
        figure(panels, spec["out"] / "modemap_variants.png", suptitle=physics_title(maps[""]["scene"]).split("\n")[0])
    return {"maps": docs, "wall_s": wall}


def _factor(f: float) -> str:
    return f"× {tag(f)}" if f >= 1 else f"÷ {tag(1 / f)}"
