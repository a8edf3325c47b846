"""Tables and work–precision figures of ``peer_score.json`` (written by score.py):
``peer_score.md`` and ``peer_<problem>.png``.

    .venv/bin/python benchmarks/peer/report.py     # redraw from the committed JSON
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parents[1] / "benchmarks" / "results"
METRICS = (("t_r_pct", "worst |Δt_r| [% of t_r]"), ("slip_pct", "worst |Δ final slip| [%]"),
           ("v_peak_pct", "worst |Δ peak slip rate| [%]"))
GOAL_CPU = 0.5  # fricfem reaches the peer's accuracy at <= this fraction of its CPU
GOAL_RIGID = 0.5  # % worst rupture-time error of the rigid kind
#: line styles of the fricfem series by tag (score.py --tag): 1 rank solid, 2 ranks dotted, others dashed
LINES = {"serial": "-", "tree": ":"}
#: the tags of the tree's own code, in the order the verdicts consult them (1 rank first: the peer's runs are serial)
TREE_TAGS = ("serial", "tree", "p4-serial", "p6-serial", "p4-dt0.45-serial", "p6-dt0.45-serial")
#: the spectral elements' series (score.py --degree p [--safety 0.45] --tag ...): their own colours
COLORS = {"p4-serial": "C3", "p6-serial": "C4", "p4-dt0.45-serial": "C5", "p6-dt0.45-serial": "C6"}


def _rank_text(tag: str) -> str:
    return (("1 rank" if "serial" in tag else "2 ranks") + (f", degree {tag[1]}" if tag in COLORS else "")
            + (", dt_safety 0.45" if "-dt0.45" in tag else ""))


def historical(t: dict) -> bool:
    """A tag kept for comparison only (code no longer in the tree): open markers, no verdicts."""
    return bool(t.get("historical"))


def _name(tag: str) -> str:
    return "" if tag == "tree" else f" [{tag}]"


def series(runs: dict, kind: str) -> list:
    """The runs of one kind, coarsest first: [(h, record)]."""
    return sorted(((r["h_m"], r) for r in runs.values() if r["kind"] == kind), key=lambda t: -t[0])


def cpu_to_reach(points, err: float, metric: str):
    """CPU seconds a fricfem ladder needs to reach error ``err``: (cpu, how).  In cost
    order, the first run from which every costlier run is at or below ``err`` too (a
    ladder that dips below and comes back up has not reached it); if it is the
    cheapest run, 'at most' its CPU, else the log–log interpolation between it and
    the run before ('interpolated'); (None, None) if no run reaches ``err``."""
    pts = sorted((r["cpu_s"], r[metric]) for _, r in points)
    i = len(pts)
    while i > 0 and pts[i - 1][1] <= err:
        i -= 1
    if i == len(pts):
        return None, None
    c1, e1 = pts[i]
    if i == 0:
        return c1, "at most"
    c0, e0 = pts[i - 1]
    f = math.log(e0 / err) / math.log(e0 / e1) if e1 > 0 else 1.0
    return math.exp(math.log(c0) + f * math.log(c1 / c0)), "interpolated"


def _fmt(v, d=3):
    return "—" if v is None else (f"{v:.{d}f}" if abs(v) < 1e4 else f"{v:.3g}")


def problem_md(name: str, prob: dict) -> list:
    L = [f"## {name}", "", "| run | CPU [s] | size | worst Δt_r [µs] | worst Δt_r [%] | rms Δt_r [%] | "
         "worst Δslip [%] | worst ΔV_peak [%] |", "|---|---|---|---|---|---|---|---|"]
    for label, r in prob["peer"].items():
        L.append(f"| SEM2DPACK {label} | {r['cpu_s']:.1f} | | {r['t_r_us']:.3f} | {r['t_r_pct']:.2f} | "
                 f"{r['t_r_rms_pct']:.2f} | {r['slip_pct']:.2f} | {r['v_peak_pct']:.1f} |")
    for tag, t in prob["fricfem"].items():
        for kind in ("rigid", "elastic"):
            for h, r in series(t["runs"], kind):
                L.append(f"| fricfem{_name(tag)} {kind} h = {h * 1e3:g} mm | "
                         f"{r['cpu_s']:.1f} | {r['dofs']:,} dofs, {r['steps']} steps | {r['t_r_us']:.3f} | "
                         f"{r['t_r_pct']:.2f} | {r['t_r_rms_pct']:.2f} | {r['slip_pct']:.2f} | "
                         f"{r['v_peak_pct']:.1f} |")
    spread = prob["peer"].get("h0.05mm") if prob.get("reference", "p8_h0.0625mm") == "p8_h0.0625mm" else None
    if prob.get("reference", "p8_h0.0625mm") != "p8_h0.0625mm":
        L += ["", f"**Reference: the peer's `{prob['reference']}`**, not its finest `p8_h0.0625mm` "
              "(benchmarks/peer/README.md, problem (c): that run had not finished when these scores were made)."]
    L += ["", "CPU: fricfem, user + system of the whole run summed over its ranks "
          f"({_ranks(prob)} ranks); SEM2DPACK, user + system of its serial run."]
    if spread:
        L.append(f"The reference's own uncertainty: the peer's two finest runs (degree 4 at 0.05 mm, degree 8 at "
                 f"0.0625 mm) differ by {spread['t_r_pct']:.2f} % in rupture time and {spread['slip_pct']:.2f} % in "
                 f"final slip (worst stations); smaller errors are not resolved by this reference.")
    L.append("")
    L += verdict_md(prob)
    L += goal_md(prob)
    L += issue26_md(prob)
    L += dt_md(name)
    L += stations_md(prob)
    return L


GOAL_ORDER = 1.8  # issue 26: rupture-time convergence in h, monotone, of at least this order
GOAL_SLIP_WHERE_TR = (0.5, 1.0)  # issue 26: slip within 1 % wherever rupture times are within 0.5 %
GOAL_DT = (0.05, 0.2)  # issue 26: µs and % between dt_safety 0.9 and 0.45 at fixed h


def issue26_md(prob: dict) -> list:
    """Issue 26's stage-1 goals on the h ladders of the tree's own tags: the order of
    the worst rupture-time error in h between neighbouring meshes (goal: monotone,
    ≥ GOAL_ORDER) and the final slip of every run whose rupture times are within
    0.5 % (goal: within 1 %)."""
    L = ["### Issue 26 (stage 1): order in h, slip where t_r is accurate", "",
         f"Order of the worst |Δt_r| against the peer between neighbouring meshes, log(e₁/e₂)/log(h₁/h₂) (goal: "
         f"monotone, ≥ {GOAL_ORDER}; the reference's own spread limits what small errors mean); and the worst slip "
         f"error of the runs whose worst Δt_r ≤ {GOAL_SLIP_WHERE_TR[0]} % (goal ≤ {GOAL_SLIP_WHERE_TR[1]} %).", ""]
    for tag, t in prob["fricfem"].items():
        if historical(t):
            continue
        for kind in ("rigid", "elastic"):
            pts = series(t["runs"], kind)
            if len(pts) < 2:
                continue
            orders = [math.log(r0["t_r_pct"] / r1["t_r_pct"]) / math.log(h0 / h1)
                      for (h0, r0), (h1, r1) in zip(pts, pts[1:])]
            mono = all(r1["t_r_pct"] < r0["t_r_pct"] for (_, r0), (_, r1) in zip(pts, pts[1:]))
            met = mono and min(orders) >= GOAL_ORDER
            L.append(f"- fricfem{_name(tag)} {kind}: worst Δt_r " + " → ".join(f"{r['t_r_pct']:.2f}" for _, r in pts)
                     + f" % at h = " + " → ".join(f"{h * 1e3:g}" for h, _ in pts) + " mm; orders "
                     + ", ".join(f"{o:.2f}" for o in orders) + f"; {'monotone' if mono else 'not monotone'} — "
                     + ("**met**" if met else "**not met**"))
            halving = _halving(pts)
            if len(halving) >= 3:  # self-convergence: free of the reference's own error
                diffs = [_worst_change(r0, r1) for (_, r0), (_, r1) in zip(halving, halving[1:])]
                own = [math.log(d0 / d1) / math.log(h0 / h1) for d0, d1, (h0, _), (h1, _)
                       in zip(diffs, diffs[1:], halving, halving[1:])]
                L.append(f"- fricfem{_name(tag)} {kind}, its own ladder (worst |t_r(h) − t_r(h/2)| over the stations, "
                         f"free of the reference's error): " + " → ".join(f"{d:.3f}" for d in diffs) + " µs; orders "
                         + ", ".join(f"{o:.2f}" for o in own))
            acc = [(h, r) for h, r in pts if r["t_r_pct"] <= GOAL_SLIP_WHERE_TR[0]]
            if acc:
                L.append(f"- fricfem{_name(tag)} {kind}, slip where Δt_r ≤ {GOAL_SLIP_WHERE_TR[0]} %: "
                         + ", ".join(f"h = {h * 1e3:g} mm {r['slip_pct']:.2f} %" for h, r in acc) + " — "
                         + ("**met**" if all(r["slip_pct"] <= GOAL_SLIP_WHERE_TR[1] for _, r in acc)
                            else "**not met**"))
    return L + [""]


def _halving(pts: list) -> list:
    """The runs of an h ladder (coarse to fine) that halve h from the finest up: the
    self-convergence differences t_r(h) − t_r(h/2) need exact halvings."""
    chain = pts[-1:]
    for h, r in reversed(pts[:-1]):
        if math.isclose(h, 2 * chain[-1][0], rel_tol=1e-9):
            chain.append((h, r))
    return chain[::-1]


def _worst_change(r0: dict, r1: dict) -> float:
    """Worst |Δt_r| [µs] between two runs over the stations both scored (t_r > 1 µs in the peer)."""
    t1 = {st["x_mm"]: st["t_r_s"] for st in r1["stations"] if "dt_r_us" in st}
    return max(1e6 * abs(st["t_r_s"] - t1[st["x_mm"]]) for st in r0["stations"]
               if "dt_r_us" in st and st["t_r_s"] is not None and t1.get(st["x_mm"]) is not None)


def dt_md(name: str, path: Path = RESULTS / "peer_dt_convergence.json") -> list:
    """The time-step study of dt_convergence.py for this problem (if run)."""
    if not path.exists():
        return []
    doc = json.loads(path.read_text())
    rows = sorted((r for r in doc["runs"].values() if r["problem"] == name),
                  key=lambda r: (r["kind"] != "rigid", -r["h_m"]))
    if not rows:
        return []
    tags = sorted({k.split("/")[0] for k, r in doc["runs"].items() if r["problem"] == name})
    notes = "; ".join(f"`{tg}`: {doc['notes'][tg]}" for tg in tags)
    L = ["### The step at fixed h", "",
         f"`benchmarks/peer/dt_convergence.py` ({notes}; "
         f"{doc['date']}): each kind at `time.dt_safety` 0.9 and 0.45 on one mesh; the worst change over the peer's "
         f"stations (goal of issue 26: < {GOAL_DT[0]} µs and < {GOAL_DT[1]} %) and each step's errors against the "
         f"peer.", "",
         "| kind | h [mm] | dt at 0.9 / 0.45 [ns] | worst Δt_r [µs] (x) | worst Δslip [%] (x) | goal | "
         "peer at 0.9: t_r [µs] (%) / slip [%] | peer at 0.45 | CPU [s] |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        a, b = (r["peer"][f"{sf:g}"] for sf in r["safety"])
        ok = r["dt_r_us"] < GOAL_DT[0] and r["dslip_pct"] < GOAL_DT[1]
        L.append(f"| {r['kind']} | {r['h_m'] * 1e3:g} | {r['dt_s'][0] * 1e9:.2f} / {r['dt_s'][1] * 1e9:.2f} | "
                 f"{r['dt_r_us']:.3f} ({r['dt_r_x_mm']} mm) | {r['dslip_pct']:.2f} ({r['dslip_x_mm']} mm) | "
                 f"{'**met**' if ok else '**not met**'} | {a['t_r_us']:.3f} ({a['t_r_pct']:.2f}) / {a['slip_pct']:.2f} | "
                 f"{b['t_r_us']:.3f} ({b['t_r_pct']:.2f}) / {b['slip_pct']:.2f} | "
                 f"{r['cpu_s'][0]:.1f} / {r['cpu_s'][1]:.1f} |")
    return L + [""]


def _ranks(prob):
    return ", ".join(sorted({str(r["ranks"]) for t in prob["fricfem"].values() for r in t["runs"].values()}))


def goal_md(prob: dict) -> list:
    L = ["### Against the goal", "", f"CPU fricfem needs to reach each peer run's accuracy (log–log interpolation "
         f"along its ladder; reached: that run and every costlier one at or below it), as a fraction of the peer's "
         f"CPU (goal ≤ {GOAL_CPU}); and the rigid kind's worst rupture-time error (goal ≤ {GOAL_RIGID} %).", ""]
    for tag, t in prob["fricfem"].items():
        if historical(t):
            continue
        for kind in ("rigid", "elastic"):
            pts = series(t["runs"], kind)
            if not pts:
                continue
            for metric, what in METRICS[:2]:
                cells = []
                for label, p in prob["peer"].items():
                    c, how = cpu_to_reach(pts, p[metric], metric)
                    cells.append(f"{label} ({p[metric]:.2f} %): " + ("not reached" if c is None else
                                 f"{'≤ ' if how == 'at most' else ''}{c / p['cpu_s']:.2f}×"))
                L.append(f"- fricfem{_name(tag)} {kind}, {what}: " + "; ".join(cells))
            if kind == "rigid":
                ok = [f"h = {h * 1e3:g} mm: {r['t_r_pct']:.2f} %" for h, r in pts]
                L.append(f"- fricfem{_name(tag)} rigid worst Δt_r: " + ", ".join(ok))
    return L + [""]


def verdict_md(prob: dict) -> list:
    """The two goals, met or not, with the numbers: for each peer run, the cheapest
    fricfem of the tree (either kind, 1 or 2 ranks) at its accuracy, as a fraction of
    its CPU; the rigid kind's worst rupture-time error on each mesh."""
    tags = [tg for tg in TREE_TAGS if tg in prob["fricfem"]]
    L = ["### Verdict", ""]
    for metric, what in METRICS[:2]:
        cells = []
        for label, p in prob["peer"].items():
            best = None
            for tag in tags:
                for kind in ("rigid", "elastic"):
                    c, how = cpu_to_reach(series(prob["fricfem"][tag]["runs"], kind), p[metric], metric)
                    if c is not None and (best is None or c < best[0]):
                        best = (c, how, kind, tag)
            if best is None:
                cells.append(f"{label} ({p[metric]:.2f} %): not reached — **not met**")
            else:
                c, how, kind, tag = best
                r = c / p["cpu_s"]
                cells.append(f"{label} ({p[metric]:.2f} %, {p['cpu_s']:.0f} s): {'≤ ' if how == 'at most' else ''}"
                             f"{r:.2f}× ({kind}, {_rank_text(tag)}) — "
                             + ("**met**" if r <= GOAL_CPU else "**not met**"))
        L.append(f"- ≤ {GOAL_CPU} × the peer's CPU at its accuracy, {what}: " + "; ".join(cells))
    for tag in tags:
        pts = series(prob["fricfem"][tag]["runs"], "rigid")
        if not pts:
            continue
        ok = [(h, r) for h, r in pts if r["t_r_pct"] <= GOAL_RIGID]
        res = (f"**met** from h = {ok[0][0] * 1e3:g} mm ({ok[0][1]['t_r_pct']:.2f} %, {ok[0][1]['cpu_s']:.1f} CPU s)"
               if ok else f"**not met** (finest: {pts[-1][1]['t_r_pct']:.2f} %)")
        L.append(f"- rigid kind, worst Δt_r ≤ {GOAL_RIGID} % ({_rank_text(tag)}): {res}; "
                 + ", ".join(f"{h * 1e3:g} mm {r['t_r_pct']:.2f} %" for h, r in pts))
    return L + [""]


def stations_md(prob: dict) -> list:
    """Per-station table of each tag's finest rigid and elastic runs."""
    L = []
    for tag, t in prob["fricfem"].items():
        if historical(t):
            continue
        for kind in ("rigid", "elastic"):
            pts = series(t["runs"], kind)
            if not pts:
                continue
            h, r = pts[-1]
            L += [f"### Stations: fricfem{_name(tag)} {kind}, h = {h * 1e3:g} mm", "",
                  "| x [mm] | t_r [µs] | peer t_r [µs] | Δt_r [µs] | V_peak [m/s] | peer | ΔV_peak [%] | slip [µm] | "
                  "peer | Δslip [%] |", "|---|---|---|---|---|---|---|---|---|---|"]
            for s in r["stations"]:
                tr = None if s["t_r_s"] is None else 1e6 * s["t_r_s"]
                trr = None if s["t_r_ref_s"] is None else 1e6 * s["t_r_ref_s"]
                L.append(f"| {s['x_mm']} | {_fmt(tr)} | {_fmt(trr)} | {_fmt(s.get('dt_r_us'))} | "
                         f"{s['v_peak']:.3g} | {s['v_peak_ref']:.3g} | {_fmt(s.get('dv_peak_pct'), 1)} | "
                         f"{1e6 * s['slip_m']:.3f} | {1e6 * s['slip_ref_m']:.3f} | {_fmt(s.get('dslip_pct'), 2)} |")
            L.append("")
    return L


def figure(name: str, prob: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 5.6))
    for ax, (metric, what) in zip(axes, METRICS):
        for degree, style in (("h", "o-"), ("p8", "s")):
            pts = [(p["cpu_s"], p[metric], lab) for lab, p in prob["peer"].items() if lab.startswith(degree)]
            if pts:
                c, e, labs = zip(*pts)
                ax.plot(c, e, style, color="0.3", label=f"SEM2DPACK degree {'4' if degree == 'h' else '8'}")
                for ci, ei, lab in pts:
                    ax.annotate(lab, (ci, ei), fontsize=7, color="0.3", xytext=(3, 3), textcoords="offset points")
                    if metric != "v_peak_pct":  # the goal: the same accuracy at half the peer's CPU
                        ax.plot([GOAL_CPU * ci, ci], [ei, ei], color="0.55", lw=0.7)
                        ax.plot([GOAL_CPU * ci], [ei], "|", color="0.3", ms=8)
        for tag, t in prob["fricfem"].items():
            for kind, color in (("rigid", "C0"), ("elastic", "C1")):
                pts = series(t["runs"], kind)
                if not pts:
                    continue
                c = [r["cpu_s"] for _, r in pts]
                e = [max(r[metric], 1e-3) for _, r in pts]
                filled = not historical(t)  # the tree's own code: filled markers
                color = COLORS.get(tag, color)
                ax.plot(c, e, marker="^" if kind == "rigid" else "v", color=color, mfc=color if filled else "none",
                        ls=LINES.get(tag, "-."), lw=1.6 if "serial" in tag else 0.9,
                        label=f"fricfem {kind} [{tag}]" + (" (historical, not in the tree)" if historical(t) else ""))
                for (h, _), ci, ei in zip(pts, c, e):
                    ax.annotate(f"{h * 1e3:g}", (ci, ei), fontsize=7, color=color, xytext=(3, -9),
                                textcoords="offset points")
        if metric == "t_r_pct":
            ax.axhline(GOAL_RIGID, color="C2", lw=0.8, ls=":", label=f"{GOAL_RIGID} % (goal, rigid)")
        if metric != "v_peak_pct":
            ax.plot([], [], "|-", color="0.3", lw=0.7, ms=8, label=f"goal: a peer run's error at {GOAL_CPU} × its CPU")
        ax.set(xscale="log", yscale="log", xlabel="CPU seconds (user + system, all ranks)", ylabel=what)
        ax.grid(True, which="both", lw=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle(f"{name}: error against SEM2DPACK {prob.get('reference', 'p8_h0.0625mm')} versus CPU "
                 "(fricfem labels: band cell size h in mm; degree p: the element size)")
    fig.tight_layout(rect=(0, 0.17, 1, 1))
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=7, frameon=False)  # below: off the data
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(doc: dict, out: Path = RESULTS) -> None:
    L = ["# fricfem against SEM2DPACK (code-to-code)", "",
         "`.venv/bin/python benchmarks/peer/score.py` (method and definitions: its header; the problems: "
         "benchmarks/peer/README.md, fricfem/scenes/tpv205_2d.toml, rsf_aging_2d.toml, rsf_slip_2d.toml).  Reference: the peer's "
         f"finest run `{doc['reference']}`; rupture time = first slip rate > {doc['threshold_m_s']:g} m/s "
         f"(stations with t_r > {doc['t_r_min_s'] * 1e6:g} µs); slip and peak rate over the stations that slip.  "
         f"{doc['machine']}, {doc['date']}.", ""]
    for tag in sorted({tg for p in doc["problems"].values() for tg in p["fricfem"]}):
        note = next(p["fricfem"][tag]["note"] for p in doc["problems"].values() if tag in p["fricfem"])
        L.append(f"- `{tag}`: {note}")
    L += ["", "Commands: `score.py` (tag `tree`, 2 ranks); `score.py --ranks 1 --tag serial`; a variant: "
          "`score.py --pythonpath <its source tree> --tag <name> --note <what differs>` (with `--ranks 1` for "
          "the serial one).  A tag marked historical in the JSON is code no longer in the tree, kept for "
          "comparison (open markers, no verdict); the interface kinds and the rigid verbs: "
          "docs/interface_kinds.md.", ""]
    for name, prob in doc["problems"].items():
        L += problem_md(name, prob)
        figure(name, prob, out / f"peer_{name}.png")
        L += [f"![{name}](peer_{name}.png)", ""]
    (out / "peer_score.md").write_text("\n".join(L) + "\n")


if __name__ == "__main__":
    src = Path(sys.argv[1]) if len(sys.argv) > 1 else RESULTS / "peer_score.json"
    write(json.loads(src.read_text()), src.parent)
    print(f"wrote {src.parent / 'peer_score.md'}")
