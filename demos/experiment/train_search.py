# # The search for a train of pulses: what the classifier saw at every computed point of a mode map
#
# The paper reports a train of pulses for its Case III (Σ0 = 10 MPa, V_imp = 20 m/s) and along its
# lines A and B.  The search is an adaptive mode map of the edge-velocity loading around Case III,
#
#     mpirun -n 2 .venv/bin/fricfem sweep case3 --adaptive --coarse 5 --sigma0 4:24:16 --v-imp 10:40:16 \
#         --out runs/train_search/map
#
# (nothing tuned: the paper's loading and friction, fricfem's classifier as it is).  This script reads
# each computed point's run and reports, for every one that slides in pulses: how many of its sampled
# slip-rate profiles were of the train type (docs/diagnostics.md: ≥ 3 pulses, spacing CV ≤ 0.35,
# width CV ≤ 0.5, width/spacing ≥ 0.3, 90th/10th percentile of the peaks ≤ 2.5), the late profiles'
# median pulse count, width and spacing, and the train figures of its last profile with the
# criteria they miss; and the label the same classifier gives each run's history cut at earlier
# times (`--cut`, default 32 µs, the paper's Case III frame, and 36 µs): the trains are transient,
# so a run's label depends on where it ends.  `--map DIR` reads another map (e.g. the full 32 × 32 map of
# benchmarks/results/sweep_speed.md, whose runs keep the profile types in summary.json).
#
# Run: `.venv/bin/python demos/experiment/train_search.py [--map runs/train_search/map]`
# Writes benchmarks/results/experiment/train_search_<tag>.json and .png.

import collections
import json
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from fricfem import open_run
from fricfem.analysis.classify import classify

sys.path.insert(0, str(Path(__file__).parent))
import common  # noqa: E402

ap = common.options("runs/train_search")
ap.add_argument("--map", type=Path, default=Path("runs/train_search/map"))
ap.add_argument("--tag", default="reference")
ap.add_argument("--cut", default="32e-6,36e-6", help="end times [s] at which to relabel each history")
a = ap.parse_args()

#: the classifier's train criteria (fricfem/analysis/classify.py, Criteria), as the runs recorded them
CRITERIA = {"spacing_cv": ("train_max_cv", "≤"), "width_cv": (None, "≤"), "duty": ("train_min_duty", "≥"),
            "peak_ratio": ("train_max_peak_ratio", "≤")}


def missed(train: dict, params: dict) -> list:
    """The train criteria a profile's figures miss."""
    limits = {"spacing_cv": params["train_max_cv"], "width_cv": 0.5, "duty": params["train_min_duty"],
              "peak_ratio": params["train_max_peak_ratio"]}
    out = []
    for k, lim in limits.items():
        v = train.get(k)
        if v is None or not np.isfinite(v) or (v < lim if CRITERIA[k][1] == "≥" else v > lim):
            out.append(k)
    return out


def point_row(p: dict) -> dict:
    d = a.map / p["dir"]
    ev_file = d / "evidence.json"
    ev = json.loads(ev_file.read_text())["mode_evidence"] if ev_file.is_file() else \
        json.loads((d / "summary.json").read_text())["mode"]["evidence"]
    types = ev.get("types", {})
    row = {"sigma0_MPa": p["sigma0_MPa"], "v_imp_m_s": p["v_imp_m_s"], "label": p["label"],
           "profiles": int(sum(types.values())), "train_profiles": int(types.get("train", 0)),
           "pulse_profiles": int(sum(types.get(k, 0) for k in ("pulses", "crack+pulses"))),
           "late_types": ev.get("late_types"), "max_regions": ev.get("max_regions"), "late": ev.get("late")}
    hist = ev.get("history") or {}
    if hist.get("type"):
        is_train = np.array([k == "train" for k in hist["type"]])
        t = np.asarray(hist["t"]) * 1e6
        runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], is_train.astype(int), [0]]))))[::2]
        row["train_profile_times_us"] = [float(t[is_train].min()), float(np.median(t[is_train])),
                                         float(t[is_train].max())] if is_train.any() else None
        row["longest_train_run"] = int(runs.max()) if len(runs) else 0
    run = open_run(d)
    for cut in CUTS:
        keep = run.t <= cut + 1e-12
        row[f"label_cut_{cut * 1e6:g}us"] = classify(run.t[keep], run.x1, run.slip_rate[keep],
                                                     run.summary["speeds"])[0]
    last = ev.get("last")
    if last and last.get("train"):
        row["last"] = {"t_us": last["t"] * 1e6, "n_regions": last["n_regions"], **last["train"],
                       "misses": missed(last["train"], ev["params"])}
    return row


CUTS = [float(c) for c in a.cut.split(",")]
m = json.loads((a.map / "modemap.json").read_text())
computed = [p for p in m["points"] if p.get("complete") and (a.map / p["dir"]).is_dir()]
rows = [point_row(p) for p in computed]
labels = collections.Counter(r["label"] for r in rows)
pulsed = [r for r in rows if r["pulse_profiles"] > 0]
with_last = [r for r in pulsed if "last" in r]
misses = collections.Counter(k for r in with_last for k in r["last"]["misses"])
late = [r["late"] for r in pulsed if r.get("late") and r["late"].get("n_regions")]
med = {k: float(np.median([x[k] for x in late if x.get(k) is not None]))
       for k in ("n_regions", "width", "stick_gap", "spacing", "peak") if any(x.get(k) is not None for x in late)}
report = {
    "map": str(a.map), "base": m.get("base"), "grid": m["grid"], "t_end_s": m.get("t_end_s"),
    "adaptive": {k: m["adaptive"][k] for k in ("coarse", "rounds", "scenes")} if m.get("adaptive") else None,
    "sweep_wall_s": m.get("sweep_wall_s"), "computed": len(rows), "labels_computed": dict(labels),
    "labels_all": dict(collections.Counter(v for row in m["labels"]["values"] for v in row)),
    "profiles": sum(r["profiles"] for r in rows), "train_profiles": sum(r["train_profiles"] for r in rows),
    "points_with_pulses": len(pulsed),
    "points_with_train_in_late_window": sum(1 for r in rows if (r["late_types"] or {}).get("train")),
    "most_train_profiles_in_a_late_window": max([(r["late_types"] or {}).get("train", 0) for r in rows] or [0]),
    "longest_train_run": max([r.get("longest_train_run", 0) for r in rows] or [0]),
    "train_profile_times_us_median": float(np.median([r["train_profile_times_us"][1] for r in rows
                                                      if r.get("train_profile_times_us")] or [np.nan])), "late_medians_over_those_points": med,
    "last_profile_misses": dict(misses), "last_profiles_judged": len(with_last),
    "last_profile_medians": {k: float(np.median([r["last"][k] for r in with_last if np.isfinite(r["last"][k])]))
                             for k in ("spacing_cv", "width_cv", "duty", "peak_ratio")} if with_last else {},
    "labels_cut": {f"{c * 1e6:g}us": dict(collections.Counter(r[f"label_cut_{c * 1e6:g}us"] for r in rows))
                   for c in CUTS},
    "trains_cut": {f"{c * 1e6:g}us": [[r["sigma0_MPa"], r["v_imp_m_s"]] for r in rows
                                      if r[f"label_cut_{c * 1e6:g}us"] == "pulse-train"] for c in CUTS},
    "points": rows,
}
a.out.mkdir(parents=True, exist_ok=True)
(a.out / f"train_search_{a.tag}.json").write_text(json.dumps(report, indent=1, default=float) + "\n")

fig = Figure(figsize=(10, 3.8))
ax1, ax2 = fig.subplots(1, 2)
colour = {"none": "0.85", "crack-like": "tab:blue", "pulse": "tab:orange", "pulse-train": "tab:red",
          "mixed": "tab:purple"}
for lab in colour:
    sel = [r for r in rows if r["label"] == lab]
    if sel:
        ax1.scatter([r["sigma0_MPa"] for r in sel], [r["v_imp_m_s"] for r in sel], c=colour[lab], s=22,
                    label=f"{lab} ({len(sel)})")
ax1.plot([10], [20], "k*", ms=12, mfc="none", label="Case III (the paper: a train)")
ax1.set(xscale="log", yscale="log", xlabel="Σ0 [MPa]", ylabel="V_imp [m/s]",
        title=f"computed points of the map: {len(rows)}, train-type profiles {report['train_profiles']}")
ax1.title.set_fontsize(9)
ax1.legend(fontsize=7)
if with_last:
    x = np.array([r["last"]["spacing_cv"] for r in with_last])
    y = np.array([r["last"]["peak_ratio"] for r in with_last])
    ax2.scatter(np.minimum(x, 3), np.minimum(y, 30), c=[colour[r["label"]] for r in with_last], s=22)
    ax2.axvline(0.35, color="k", lw=0.8, ls="--")
    ax2.axhline(2.5, color="k", lw=0.8, ls="--")
    ax2.set(yscale="log", xlabel="spacing CV of the last profile (train: ≤ 0.35)",
            ylabel="peak ratio p90/p10 (train: ≤ 2.5)", title="last profile of each point with pulses")
    ax2.title.set_fontsize(9)
fig.tight_layout()
fig.savefig(a.out / f"train_search_{a.tag}.png", dpi=110)
print(json.dumps({k: v for k, v in report.items() if k != "points"}, indent=1, default=float))
