"""The report of the stability stress test (``benchmarks/stability.py``): ``stability.md``
and ``stability.png`` from the results document.

``S`` is the study's design (``stability_design.py``: its levels, defaults and helpers).
"""

from __future__ import annotations

from pathlib import Path

import stability_design as S  # benchmarks/ is on the path (the script's directory)



SYMBOL = {"ok": "·", "watchdog": "W", "rejected": "R", "error": "E"}
COLOUR = {"ok": "tab:green", "watchdog": "tab:orange", "rejected": "0.6", "error": "tab:red"}
MARKER = {"ok": "o", "watchdog": "X", "rejected": "s", "error": "P"}


def _num(x, fmt=".3g") -> str:
    return "" if x is None else format(x, fmt)


def _mpa(x):
    return None if x is None else x / 1e6


def _loading(ld) -> str:
    return f"Σ0 = {ld['sigma0_MPa']:g} MPa, V_imp = {ld['v_imp_m_s']:g} m/s, k = {ld['k']:g}"


def stable_text(doc: dict) -> str:
    gd = doc["gamma_dt"]
    cells = gd["stable_cells"]
    gam = sorted({g for g, _ in cells})
    dts = sorted({d for _, d in cells})
    n_acc = len(gd["accepted_gamma"]) * len(S.LEVELS["dt_safety"])
    calm = [ld for ld in gd["loadings"] if not ld["spikes"]]
    wild = [ld for ld in gd["loadings"] if ld["spikes"]]
    text = [f"γ = {', '.join(f'{g:g}' for g in gd['rejected_gamma'])} are rejected at validation: "
            f"\"{doc['rejection_message']}\"."]
    if calm:
        spread = "; ".join(f"{_loading(ld)}: {ld['counts']['ok']} of {n_acc} ok, peak slip rate "
                           f"{ld['peak_range'][0]:.3g}–{ld['peak_range'][1]:.3g} m/s" for ld in calm)
        text.append(f"At the loadings without spikes ({spread}), {len(cells)} of {n_acc} accepted "
                    f"(γ, dt_safety) cells end ok with the default cell's mode and a peak slip rate within "
                    f"{100 * S.PEAK_TOL:g} % of it.")
    if cells and len(cells) == len(gam) * len(dts):
        text.append(f"Stable region: γ ∈ [{min(gam):g}, {max(gam):g}] × dt_safety ∈ [{min(dts):g}, {max(dts):g}] "
                    f"— every accepted level of both.")
    elif cells:
        text.append("Stable cells: " + ", ".join(f"({g:g}, {d:g})" for g, d in cells) + ".")
    for ld in wild:
        w = [c for c in ld["cells"].values() if c["kind"] != "ok" and c["kind"] != "rejected"]
        modes = sorted({c["mode"] for c in ld["cells"].values() if c["kind"] == "ok" and c["mode"]})
        text.append(f"At {_loading(ld)} the slip rate spikes above c_l in every accepted cell (peak "
                    f"{ld['peak_range'][0]:.3g}–{ld['peak_range'][1]:.3g} m/s): {ld['counts']['ok']} of {n_acc} "
                    f"end ok (modes: {', '.join(modes) or '–'})"
                    + (", " + ", ".join(f"γ {c['gamma']:g}, dt {c['dt_safety']:g}: {c['kind']}" for c in w)
                       if w else "")
                    + ". The peak of such a spike is a short event (tens of ns) sampled once per step, so it "
                      "differs from cell to cell; these cells are left out of the comparison with the default.")
    if [S.DEFAULT["gamma"], S.DEFAULT["dt_safety"]] in cells:
        text.append("The defaults, dt_safety = 0.9 and γ = 0.5, lie inside the region. γ = ½ is the second-order "
                    "(trapezoidal) sub-step, 2–70 × more accurate than backward Euler at equal tolerance "
                    "(docs/friction.md), and γ > ½ gains nothing in stability here. Inside the region the peak slip "
                    "rate does not depend on dt_safety, so the largest safety with a margin is the cheapest: 0.9 "
                    "takes 0.5/0.9 = 0.56 × the steps of 0.5. The margin below 1 covers dt_crit being an estimate "
                    "(power iteration: the Rayleigh quotient approaches λmax from below, so dt_crit from above); "
                    "0.95 also ran without fault, while fixed steps of 1.05–1.5 × dt_crit diverge (contrast below).")
    return " ".join(text)


def spike_lines(doc: dict, c_l: float) -> list:
    """The markdown section on slip-rate spikes above c_l and what the spring–slider says of them."""
    ra = doc["spikes"]
    lo, hi = ra["peak_range_m_s"] or (0.0, 0.0)
    return [
        "## Slip-rate spikes above c_l", "",
        f"{ra['count']} design runs reach a peak slip rate above c_l = {c_l:.0f} m/s (peaks {lo:.3g}–{hi:.3g} "
        f"m/s): {ra['ok']} end ok, {ra['watchdog']} are stopped by the watchdog; summary.json reports "
        f"{ra['reported']} of them (`slip_rate_spike`, its peak taken every step at least the snapshots'). By k: "
        + ", ".join(f"k = {k}: {n}" for k, n in ra["k_of_spikes"].items()) + ". "
        "Such peaks are genuine: the Povirk–Needleman spring–slider's slip rate is bounded over any finite time "
        "with no threshold in T_n (docs/friction_reference.md §4, checked against an exact Radau "
        "integration). A sliding point's slip rate grows only while |T_s| > C_s L0/(B κ(θ0)) ≥ m L0 C_s/B "
        "(" + ", ".join(f"{v / 1e6:.3g} MPa at k = {k}" for k, v in ra["growth_floor_Pa"].items()) + "), and "
        "stops growing once θ0 has decayed to about L0/v; steady sliding turns to stick–slip above "
        "T_n,c(v) = C_s L0/(B |dμ_ss/d ln v|), at least "
        + ", ".join(f"{v / 1e6:.3g} MPa at k = {k}" for k, v in ra["hopf_floor_Pa"].items()) + f". In "
        f"{ra['ts_above_growth_floor']} of the {ra['count']} runs |T_s| at the peak exceeds m L0 C_s/B, and in "
        f"{ra['tn_above_hopf_floor']} T_n there exceeds min T_n,c. The spikes sit where the normal traction "
        "behind the struck edge is high (fast impacts) or C_s is small (k = 0.01), where both thresholds are "
        "low.", ""]


def changed_lines(doc: dict) -> list:
    """What changed against an earlier results document (``--compare``), if given."""
    ch = doc.get("changed")
    if not ch:
        return []
    c, u = ch["counts_before"], ch["unstable_counts_before"]
    out = ["## Changes against the previous results", "",
           f"Against the earlier results (finished {ch['finished_before']}, before the watchdog stopped only on "
           "divergence): design points then "
           + ", ".join(f"{k} {c[k]}" for k in c) + "; unstable contrast then " + ", ".join(f"{k} {u[k]}" for k in u)
           + f". {len(ch['points'])} points changed outcome or mode (outcome/mode then → now, peak slip rate "
           "[m/s] then → now):", "", "| point | then | now | peak then | peak now |", "|---|---|---|---|---|"]
    out += [f"| `{r['key']}` | {r['before']} | {r['now']} | {_num(r['peak_before'])} | {_num(r['peak_now'])} |"
            for r in ch["points"]]
    return out + [""]


def contrast_lines(doc: dict, by_key: dict, missed: list) -> list:
    """What stopped the unstable runs, and what the ones not stopped show."""
    causes = {}
    for c in doc["contrast"]:
        r = by_key[c["key"]]
        if r["kind"] == "watchdog":
            what = r["outcome"].partition(" µs: ")[2].partition(";")[0]
            causes.setdefault(what, []).append(round(r["t_stop_s"] / r["dt_s"]))
    out = []
    if causes:
        out.append("Causes of the stops: " + "; ".join(
            f"{what}: {len(steps)} (after "
            + (f"{min(steps)}" if min(steps) == max(steps) else f"{min(steps)}–{max(steps)}") + " steps)"
            for what, steps in causes.items())
            + ". Central differences conserve ½ v^{n−½}·M v^{n+½} + ½ u·K u at any step, so a growing mode "
            "shows as a kinetic energy that turns negative while the budget still closes; the watchdog looks at "
            "the energies every `output.energy_every` steps.")
    for c in missed:
        out.append(f"Not stopped: `{c['key']}` ({c['kind']}, mode {c['mode'] or '–'} against "
                   f"{c['reference_mode'] or '–'} at the stable step; largest open share {_num(c['open_fraction_max'], '.2f')} "
                   f"against {_num(c['reference_open_fraction_max'], '.2f')}).")
    if any(by_key[c["key"]]["k"] >= 100 for c in missed):
        out.append("With k = 100 the stable step is set by the interface springs; beyond it the unstable "
                   "normal-spring mode is clipped by opening (T_n ≥ 0), so the interface chatters open and shut "
                   "with bounded, finite values and a closed energy budget: nothing a divergence check can see, "
                   "which is why a step above the stable one is refused unless `time.allow_unstable_dt`.")
    return [" ".join(out), ""] if out else []


def markdown(doc: dict) -> str:
    recs = [r for r in doc["points"] if not r.get("dt_factor")]
    by_key = {r["key"]: r for r in doc["points"]}
    c_l = doc["spikes"]["c_l_m_s"]
    lines = [
        "# Stability stress test",
        "",
        f"`mpirun -n {doc['ranks']} .venv/bin/python benchmarks/stability.py`"
        f"{' --smoke' if doc['smoke'] else ''} — {doc['finished']}; "
        f"{len(doc['points'])} points ({len(recs)} design, {len(doc['points']) - len(recs)} unstable contrast) "
        f"on the `{doc['preset']}` mesh to {doc['t_end_s'] * 1e6:g} µs, base scene `{S.BASE}`; "
        "runs per call: " + "; ".join(f"{c['finished']}: {c['runs']} runs, wall {c['wall_s']:.0f} s on {c['ranks']} "
                                      f"rank(s), load average {_num(c['load_avg'], '.1f')}" for c in doc["calls"])
        + f". The point walls sum to {doc['point_wall_sum_s']:.0f} s (2 cores shared with other jobs: wall times "
        "are upper bounds).",
        "",
        "Factors: Σ0 " + ", ".join(f"{x:g}" for x in S.LEVELS["sigma0_MPa"]) + " MPa; V_imp "
        + ", ".join(f"{x:g}" for x in S.LEVELS["v_imp_m_s"]) + " m/s; k (C_n and C_s × k) "
        + ", ".join(f"{x:g}" for x in S.LEVELS["k"]) + "; dt_safety " + ", ".join(f"{x:g}" for x in S.LEVELS["dt_safety"])
        + "; γ " + ", ".join(f"{x:g}" for x in S.LEVELS["gamma"]) + ". Design: the 32 corners, one factor at a time "
        "around Case I (6 MPa, 2 m/s, k = 1, 0.9, 0.5), the full γ × dt_safety grid at "
        + "; ".join(_loading(ld) for ld in doc["gamma_dt"]["loadings"])
        + ", the full Σ0 × V_imp grids at the default step and γ for k = " + ", ".join(f"{k:g}" for k in S.SIGMA_V_K)
        + f", and a {S.LHS_POINTS}-point Latin hypercube on the levels.",
        "",
        "Outcomes: `ok` — complete, every dataset of interface.h5 finite and a sound energy history; "
        "`watchdog` — stopped with the watchdog's message; `rejected` — refused by the scene's validation; "
        "`error` — anything else, including a complete run with a non-finite value or an unsound energy "
        f"history (kinetic energy below −{S.ENERGY_REL:g} × the energy scale, or a balance error above "
        f"{S.ENERGY_REL:g} × it: the watchdog's own bound, `watchdog.energy_tol`, checked again on the stored "
        "history; the scale is the largest of the external work, kinetic + strain energy, the interface work "
        "and the absorbed energy). Over the ok runs the balance error stays below "
        f"{doc['energy_calibration']['balance_rel_max_ok']:.3g} × the energy scale and the kinetic energy is "
        f"never below {doc['energy_calibration']['kinetic_min_rel_ok']:.3g} × it, so the bound is far from both. "
        f"A slip rate above c_l = {doc['spikes']['c_l_m_s']:.0f} m/s is reported (summary.json "
        "`slip_rate_spike`), not stopped.",
        "",
        "## Outcomes",
        "",
        "| | ok | watchdog | rejected | error |",
        "|---|---|---|---|---|",
        "| design points | " + " | ".join(str(doc["counts"][k]) for k in S.KINDS) + " |",
        "| unstable contrast | " + " | ".join(str(doc["unstable_counts"][k]) for k in S.KINDS) + " |",
        "",
        f"Complete runs with a non-finite value (silent NaN): {len(doc['silent_nonfinite'])}. "
        f"Complete runs with an unsound energy history (silent divergence): {len(doc['silent_divergence'])}"
        + (f" ({', '.join(f'`{k}`' for k in doc['silent_divergence'])})" if doc["silent_divergence"] else "") + ".",
        "",
        "### Per factor level (design points)",
        "",
    ]
    for f in S.FACTORS:
        lines += [f"**{S.LABELS[f]}**", "", "| level | ok | watchdog | rejected | error |", "|---|---|---|---|---|"]
        for lv, c in doc["per_level"][f].items():
            lines.append(f"| {lv} | " + " | ".join(str(c[k]) for k in S.KINDS) + " |")
        lines.append("")
    lines += ["## Stable region in γ × dt_safety", "", stable_text(doc), ""]
    for ld in doc["gamma_dt"]["loadings"]:
        lines += [f"**{_loading(ld)}** — peak slip rate [m/s] per cell (`W` watchdog, `E` error, `R` rejected)", "",
                  "| γ \\ dt_safety | " + " | ".join(f"{d:g}" for d in S.LEVELS["dt_safety"]) + " |",
                  "|---|" + "---|" * len(S.LEVELS["dt_safety"])]
        for g in S.LEVELS["gamma"]:
            row = []
            for d in S.LEVELS["dt_safety"]:
                c = ld["cells"].get(f"{g:g}/{d:g}")
                row.append("" if c is None else "R" if c["kind"] == "rejected" else
                           ("" if c["kind"] == "ok" else SYMBOL[c["kind"]] + " ") + _num(c["peak"], ".4g"))
            lines.append(f"| {g:g} | " + " | ".join(row) + " |")
        lines.append("")
    lines += ["## Σ0 × V_imp at dt_safety 0.9, γ 0.5", "",
              "Peak slip rate [m/s]; `W` watchdog, `E` error. Rows V_imp (fastest on top), columns Σ0 [MPa].", ""]
    for k in S.SIGMA_V_K:
        lines += [f"**k = {k:g}** (C_n = {0.3 * k:g}, C_s = {0.1 * k:g} MPa/µm; m L0 C_s/B = "
                  f"{S.growth_floor(k) / 1e6:.3g} MPa, min T_n,c = {S.hopf_floor(k) / 1e6:.3g} MPa)", "",
                  "| V_imp \\ Σ0 | " + " | ".join(f"{s:g}" for s in S.LEVELS["sigma0_MPa"]) + " |",
                  "|---|" + "---|" * len(S.LEVELS["sigma0_MPa"])]
        for v in reversed(S.LEVELS["v_imp_m_s"]):
            cells = []
            for s in S.LEVELS["sigma0_MPa"]:
                r = by_key.get(S.key_of({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, **S.DEFAULT}))
                cells.append("" if r is None else ("" if r["kind"] == "ok" else SYMBOL[r["kind"]] + " ")
                             + _num(r["peak_slip_rate_m_s"], ".3g"))
            lines.append(f"| {v:g} | " + " | ".join(cells) + " |")
        lines.append("")
    lines += spike_lines(doc, c_l) + changed_lines(doc)
    lines += [
        "## Unstable explicit step (contrast)", "",
        "`time.dt` = factor × dt_crit (`build_model(scene, comm)[1].dt_crit`); the reference is the same "
        "loading at dt_safety 0.9, γ 0.5.", "",
        "| loading | dt / dt_crit | outcome | stopped at [µs] | peak slip rate (ref) [m/s] | max T_n (ref) [MPa] "
        "| max open share (ref) | mode (ref) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in doc["contrast"]:
        r = by_key[c["key"]]
        lines.append(
            f"| {r['sigma0_MPa']:g} MPa, {r['v_imp_m_s']:g} m/s, k = {r['k']:g} | {c['dt_factor']:g} | "
            f"{r['outcome'][:150]}{'…' if len(r['outcome']) > 150 else ''} | "
            f"{_num(r['t_stop_s'] * 1e6 if r['kind'] == 'watchdog' else None, '.2f')} | "
            f"{_num(c['peak'])} ({_num(c['reference_peak'])}) | "
            f"{_num(_mpa(c['tn_max']))} ({_num(_mpa(c['reference_tn_max']))}) | "
            f"{_num(c['open_fraction_max'], '.2f')} ({_num(c['reference_open_fraction_max'], '.2f')}) | "
            f"{c['mode'] or '–'} ({c['reference_mode'] or '–'}) |")
    missed = [c for c in doc["contrast"] if not c["stopped_naming_step"]]
    lines += ["", f"{len(doc['contrast']) - len(missed)} of {len(doc['contrast'])} unstable runs are stopped by the "
              "watchdog with a message naming the step." + (" Not stopped: " + ", ".join(
                  f"`{c['key']}` ({c['kind']})" for c in missed) + "." if missed else ""), ""]
    lines += contrast_lines(doc, by_key, missed)
    bad = [r for r in recs if r["kind"] in ("watchdog", "error")]
    lines += ["## Every design point ending `watchdog` or `error`", ""]
    if bad:
        lines += ["| point | parts | peak slip rate [m/s] | steps | outcome |", "|---|---|---|---|---|"]
        for r in sorted(bad, key=lambda r: r["key"]):
            lines.append(f"| `{r['key']}` | {', '.join(r['parts'])} | {_num(r['peak_slip_rate_m_s'])} | "
                         f"{r['steps']} | {r['outcome']} |")
    else:
        lines.append("None.")
    lines += ["", "<details><summary>Every point</summary>", "",
              "| point | parts | outcome | peak slip rate [m/s] | steps | dt [ns] | wall [s] |",
              "|---|---|---|---|---|---|---|"]
    for r in doc["points"]:
        dt_ns = "" if r["dt_s"] is None else f"{r['dt_s'] * 1e9:.1f}"
        out = r["outcome"] if r["kind"] == "ok" else f"{r['kind']}: {r['outcome'].partition(': ')[2][:90]}…"
        lines.append(f"| `{r['key']}` | {', '.join(r['parts'])} | {out} | {_num(r['peak_slip_rate_m_s'])} | "
                     f"{'' if r['steps'] is None else r['steps']} | {dt_ns} | {r['wall_s']:.2f} |")
    lines += ["", "</details>", ""]
    return "\n".join(lines)


def figure(doc: dict, path: Path) -> None:
    """Top: γ × dt_safety per loading (outcome, peak slip rate); bottom: Σ0 × V_imp per k."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    loadings = doc["gamma_dt"]["loadings"]
    ncol = max(len(loadings), len(S.SIGMA_V_K), 1)
    fig, axes = plt.subplots(2, ncol, figsize=(5.0 * ncol, 10.0), squeeze=False, layout="constrained")
    gs, ds = S.LEVELS["gamma"], S.LEVELS["dt_safety"]
    for ax, ld in zip(axes[0], loadings):
        for c in ld["cells"].values():
            i, j = ds.index(c["dt_safety"]), gs.index(c["gamma"])
            ax.add_patch(plt.Rectangle((i - 0.46, j - 0.46), 0.92, 0.92, color=COLOUR[c["kind"]], alpha=0.4))
            txt = "R" if c["kind"] == "rejected" else _num(c["peak"], ".3g")
            ax.text(i, j, txt, ha="center", va="center", fontsize=7)
        ax.plot(ds.index(S.DEFAULT["dt_safety"]), gs.index(S.DEFAULT["gamma"]), marker="s", ms=26, mfc="none",
                mec="k", mew=1.5, ls="none")
        ax.set_xticks(range(len(ds)), [f"{d:g}" for d in ds])
        ax.set_yticks(range(len(gs)), [f"{g:g}" for g in gs])
        ax.set_xlim(-0.6, len(ds) - 0.4)
        ax.set_ylim(-0.6, len(gs) - 0.4)
        ax.set_xlabel("time.dt_safety")
        ax.set_ylabel("friction.params.gamma γ")
        ax.set_title(f"{_loading(ld)}\npeak slip rate [m/s]: green ok, orange watchdog,\n"
                     "grey rejected; framed: the default", fontsize=8)
    for ax in axes[0][len(loadings):]:
        ax.axis("off")
    by_key = {r["key"]: r for r in doc["points"]}
    peaks = [r["peak_slip_rate_m_s"] for r in doc["points"] if r["peak_slip_rate_m_s"]]
    norm = LogNorm(vmin=0.1, vmax=max(peaks + [1.0]))
    sc = None
    for ax, k in zip(axes[1], S.SIGMA_V_K):
        for kind in S.KINDS:
            xs, ys, cs = [], [], []
            for s in S.LEVELS["sigma0_MPa"]:
                for v in S.LEVELS["v_imp_m_s"]:
                    r = by_key.get(S.key_of({"sigma0_MPa": s, "v_imp_m_s": v, "k": k, **S.DEFAULT}))
                    if r and r["kind"] == kind:
                        xs.append(s)
                        ys.append(v)
                        cs.append(max(r["peak_slip_rate_m_s"] or 0.1, 0.1))
            if xs:
                sc = ax.scatter(xs, ys, marker=MARKER[kind], c=cs, cmap="viridis", norm=norm, s=70,
                                edgecolors="k" if kind == "ok" else "r", linewidths=0.6 if kind == "ok" else 1.6,
                                label=kind, zorder=3)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("Σ0 [MPa]")
        ax.set_ylabel("V_imp [m/s]")
        ax.set_title(f"C_n, C_s × {k:g} (m L0 C_s/B = {S.growth_floor(k) / 1e6:.3g} MPa), dt_safety 0.9, γ 0.5\n"
                     "colour: peak slip rate; o ok, X watchdog", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.5)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="lower left")
    for ax in axes[1][len(S.SIGMA_V_K):]:
        ax.axis("off")
    if sc is not None:
        fig.colorbar(sc, ax=list(axes[1]), shrink=0.8, label="peak slip rate [m/s]")
    fig.suptitle(f"fricfem stability on the {doc['preset']} mesh to {doc['t_end_s'] * 1e6:g} µs", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


