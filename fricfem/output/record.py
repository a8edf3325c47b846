"""A run's record on disk: ``summary.json`` for people, ``evidence.json`` for programs.

``summary.json`` holds what a reader wants to see — sizes, step, timing,
initiation, the leading tip's last position and speeds, each front's kind and
speed, the mode with its reason, the energy budget at the end time — and a
``units`` block.  The per-step arrays behind them (the tip every step, V_tip,
each front's track, the classifier's histories) are in ``evidence.json``.
:func:`read_summary` gives the two merged (the run's whole record, as
:func:`fricfem.runner.run_scene` returns it); :func:`read_evidence` the arrays.

Both files are written whole to a temporary name and renamed over the old one,
so a reader (or a kill) never meets half a file.
"""

from __future__ import annotations

import json
import logging
import math
import os
from pathlib import Path

import numpy as np

from .quantities import SUMMARY_FILE

EVIDENCE_FILE = "evidence.json"
log = logging.getLogger("fricfem.output")

#: the units of summary.json's numbers, by key or by key suffix
UNITS = {
    "*_s": "s", "*_m": "m", "*_m_s": "m/s", "speeds": "m/s",
    "energy": "J/m (per unit thickness of the plates); energy.time_s in s",
    "fronts.mean_speed": "m/s", "fronts.mach": "1 (speed / wave speed)",
    "wall_s": "s of wall-clock time", "us_per_step": "µs of wall-clock time per step",
    "input": "SI; every scene key's unit: `fricfem scenes --keys`",
    "evidence.json": "tip.time_s, fronts.t, .t_speed in s; tip.x1_m, fronts.x in m; speeds in m/s",
}


def jsonable(o):
    """Plain Python types for ``json.dumps``: arrays -> lists, numpy scalars ->
    Python numbers, non-finite floats -> None, objects with ``to_dict``."""
    if type(o) is float:  # the common case first (records hold long lists of them)
        return o if math.isfinite(o) else None
    if isinstance(o, np.ndarray) and o.dtype.kind in "biuf":
        # numbers: tolist() gives Python's own; only non-finite floats need a look each
        if o.dtype.kind != "f" or np.isfinite(o).all():
            return o.tolist()
        return jsonable(o.tolist())
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if hasattr(o, "to_dict"):
        return jsonable(o.to_dict())
    if isinstance(o, np.ndarray):
        return [jsonable(v) for v in o.tolist()]
    if isinstance(o, (bool, np.bool_)):
        return bool(o)
    if isinstance(o, (int, np.integer)):
        return int(o)
    if isinstance(o, (float, np.floating)):
        return float(o) if math.isfinite(o) else None
    return o


def replace_texts(texts) -> None:
    """Each ``(path, text)`` written to a temporary name and renamed over the path."""
    for path, text in texts:
        tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
        try:
            tmp.write_text(text)
            os.replace(tmp, path)
        except OSError:
            tmp.unlink(missing_ok=True)
            raise


def _scalars(d: dict) -> dict:
    """The entries of ``d`` that are not lists and not tables holding lists."""
    return {k: v for k, v in d.items()
            if not isinstance(v, (list, tuple, np.ndarray))
            and not (isinstance(v, dict) and any(isinstance(x, (list, tuple, np.ndarray, dict)) for x in v.values()))}


def _finite(values) -> np.ndarray:
    a = np.asarray([np.nan if v is None else v for v in (values if values is not None else [])], dtype=float)
    return a[np.isfinite(a)]


def _brief_tip(tip: dict) -> dict:
    t, x, v = (np.asarray(tip.get(k, []), dtype=float) for k in ("time_s", "x1_m", "v_tip_m_s"))
    vf = _finite(v)
    return {"samples": int(len(t)),
            "first_time_s": float(t[0]) if len(t) else None, "last_time_s": float(t[-1]) if len(t) else None,
            "last_x1_m": float(x[-1]) if len(x) else None,
            "v_tip_max_m_s": float(vf.max()) if len(vf) else None,
            "v_tip_median_m_s": float(np.median(vf)) if len(vf) else None}


def struck(record: dict) -> bool:
    """Whether a run's record is of a struck plate (an edge velocity V_imp > 0 or the
    experiment's projectile); unknown counts as struck."""
    inp = record.get("input") or {}
    v_imp = (inp.get("loading") or {}).get("v_imp")
    return bool(inp.get("experiment")) or not isinstance(v_imp, (int, float)) or v_imp > 0


def _brief_front(front: dict, by_direction: bool = False) -> dict:
    """A front as summary.json lists it.  ``by_direction`` (a run with no impact,
    where "leading"/"trailing" mean nothing: a crack grows both ways from its
    patch): ``edge`` is the way the front moves, ``toward +x1`` or ``toward -x1``
    (``stationary``), and ``region_side`` keeps the side of the slipping region
    the edge bounds (``leading``: stick at larger x1)."""
    d = _scalars(front)
    if by_direction and "edge" in d:
        v = d.get("mean_speed")
        d["region_side"] = d["edge"]
        d["edge"] = ("stationary" if d.get("kind") == "stationary" or not isinstance(v, (int, float))
                     else "toward +x1" if v > 0 else "toward -x1")
    t, x = _finite(front.get("t")), np.asarray(front.get("x") or [], dtype=float)
    if len(t):
        d.update(t_start_s=float(t[0]), t_end_s=float(t[-1]))
    if len(x):
        d.update(x_start_m=float(x[0]), x_end_m=float(x[-1]))
    return d


def split(record: dict) -> tuple[dict, dict]:
    """(summary, evidence) of a run's whole record (see the module docstring)."""
    record = jsonable(record)
    summary = {k: v for k, v in record.items() if k not in ("tip", "fronts", "mode")}
    evidence = {}
    if record.get("tip") is not None:
        tip = {k: v for k, v in record["tip"].items() if k in ("time_s", "x1_m", "v_tip_time_s", "v_tip_m_s")}
        summary["tip"] = {**_brief_tip(tip), **{k: v for k, v in record["tip"].items() if k not in tip}}
        evidence["tip"] = tip
    if record.get("fronts") is not None:
        fronts = record["fronts"]
        summary["fronts"] = [_brief_front(f, by_direction=not struck(record)) for f in fronts]
        evidence["fronts"] = fronts
    if record.get("mode") is not None:
        mode = dict(record["mode"])
        full = mode.pop("evidence", None)
        if full is not None:
            mode["evidence"] = _scalars(full)
            evidence["mode_evidence"] = full
        summary["mode"] = mode
    energy = summary.get("energy")
    if isinstance(energy, dict) and isinstance(energy.get("time_s"), float) and isinstance(summary.get("t_s"), float):
        # say which time the end-of-run budget is at: the end time, or the last evaluation of a run stopped early
        lag = summary["t_s"] - energy["time_s"]
        summary["end_times"] = {
            "t_end_s": summary.get("t_end_s"), "t_s": summary["t_s"], "energy_time_s": energy["time_s"],
            "note": (f"the run ends at t_s = {summary['t_s'] * 1e6:.6g} us"
                     + (f", the last whole step not past time.end = {summary['t_end_s'] * 1e6:.6g} us (steps of "
                        f"{summary['dt_s'] * 1e6:.4g} us)" if isinstance(summary.get("t_end_s"), float)
                        and isinstance(summary.get("dt_s"), float) else "")
                     + f"; the energy budget is at {energy['time_s'] * 1e6:.6g} us"
                     + (" (the run's end time)" if lag == 0 else
                        " (the last evaluation before the run stopped)"))}
    if evidence:
        summary["evidence"] = EVIDENCE_FILE
    summary["units"] = UNITS
    return summary, evidence


def record_texts(rundir, record: dict) -> list:
    """``[(path, JSON text)]`` of a record: ``evidence.json`` (when the record has
    any) first, then ``summary.json`` (the text can be made in one thread and
    written in another: :func:`replace_texts`)."""
    rundir = Path(rundir)
    summary, evidence = split(record)
    # split() gave plain JSON types; the evidence (long arrays) on one line: json's
    # encoder in C serves only unindented text, ~10 times faster than the indented
    texts = [(rundir / EVIDENCE_FILE, json.dumps(evidence))] if evidence else []
    return texts + [(rundir / SUMMARY_FILE, json.dumps(summary, indent=2))]


def write_record(rundir, record: dict) -> None:
    """Write ``evidence.json`` (when the record has any) and then ``summary.json``."""
    replace_texts(record_texts(rundir, record))


def write_summary(rundir, summary: dict) -> None:
    """Write a record (see :func:`write_record`); kept under its old name."""
    write_record(rundir, summary)


def _load(path: Path) -> dict:
    if not path.is_file():
        return {}
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        log.warning("%s: not readable (%s); going on without it", path, err)
        return {}
    return doc if isinstance(doc, dict) else {}


def read_evidence(rundir) -> dict:
    """``evidence.json`` of a run directory: ``tip``, ``fronts``, ``mode_evidence`` ({} if absent)."""
    return _load(Path(rundir) / EVIDENCE_FILE)


def merge(summary: dict, evidence: dict) -> dict:
    """The whole record from a summary and its evidence (see :func:`read_summary`)."""
    summary = dict(summary)
    for key, kind, what in (("tip", dict, "an object"), ("fronts", list, "a list")):
        if key in evidence and not isinstance(evidence[key], kind):
            log.warning("evidence.json: %r is %s, not %s; going on without it", key, type(evidence[key]).__name__,
                        what)
            evidence = {k: v for k, v in evidence.items() if k != key}
    if "tip" in evidence:
        tip = summary.get("tip")
        summary["tip"] = {**(tip if isinstance(tip, dict) else {}), **evidence["tip"]}
    if "fronts" in evidence:
        brief = summary.get("fronts")
        brief = brief if isinstance(brief, list) else []
        summary["fronts"] = [{**(brief[i] if i < len(brief) and isinstance(brief[i], dict) else {}),
                              **(f if isinstance(f, dict) else {})} for i, f in enumerate(evidence["fronts"])]
    if "mode_evidence" in evidence and isinstance(summary.get("mode"), dict):
        summary["mode"] = {**summary["mode"], "evidence": evidence["mode_evidence"]}
    return summary


def whole(record: dict) -> dict:
    """``record`` as :func:`read_summary` will read it back once written (JSON types)."""
    return jsonable(merge(*split(record)))


def read_summary(rundir) -> dict:
    """The run's whole record: ``summary.json`` with ``evidence.json`` merged in
    (``tip`` gains its arrays, ``fronts`` their tracks, ``mode.evidence`` its
    histories); {} if there is no summary.  A summary written before the split
    (arrays inside it) reads unchanged."""
    rundir = Path(rundir)
    summary = _load(rundir / SUMMARY_FILE)
    if not summary or not summary.get("evidence"):
        return summary
    return merge(summary, read_evidence(rundir))
