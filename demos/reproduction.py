# # Reproducing the paper: every checkable statement, one reading of the loading at a time
#
# The paper (Coker, Lykotrafitis, Needleman & Rosakis) states numbers for its
# symmetric-loading run, Cases I–V and lines A and B of its mode map.  This
# script runs the shipped scenes under one *reading* of the model — the
# direction of the edge velocity (`push` into the specimen, or `pull` as
# eq. (2) reads literally), a factor on every V_imp and a factor on the
# interface stiffnesses C_n, C_s — evaluates each statement against the run
# outputs with a stated tolerance, and writes `statements.json` and a Markdown
# table.  The same reading is used for every scene: nothing is fitted per case.
#
# Run: `mpirun -n 2 .venv/bin/python demos/reproduction.py --reading push --v-scale 1 --out runs/repro/push_v1`
# Points are spread over the ranks (each run on one rank); finished runs are reused.

from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from fricfem import batch, load_scene, open_run
from fricfem.analysis import measures
from fricfem.analysis.measures import first_slip, loading_front, mode, pulse_train, tip_and_behind

logging.getLogger().setLevel(logging.WARNING)

#: scenes the statements need
SCENES = ["symmetric", "case1", "case2", "case3", "case4", "case5",
          "lineA_v2", "lineA_v7", "lineA_v10", "lineA_v20", "lineA_v40",
          "lineB_s6", "lineB_s10", "lineB_s16", "lineB_s30"]


#: the per-figure demo (demos/paper/) showing each statement group's quantities next to the paper's figure
DEMOS = {"symmetric": "fig07_symmetric.py", "case1": "fig08_09_case1.py", "case2": "fig10_11_case2.py",
         "case3": "fig12_13_case3.py", "case4": "fig15_16_case4.py", "case5": "fig17_18_case5.py",
         "all": "fig06_tip_speed.py", "lineA": "fig20_lineA.py", "lineB": "fig21_lineB.py"}


def overrides_for(reading) -> list:
    return [f"loading.direction='{reading.direction}'",
            f"interface.Cn={3e11 * reading.stiffness_scale}", f"interface.Cs={1e11 * reading.stiffness_scale}",
            "output.fields=[]", f"mesh.preset='{reading.preset}'"]


def run_all(reading, out: Path, comm) -> dict:
    """Run every scene under ``reading``: resumable, one run per rank at a time
    (the batch runner, :mod:`fricfem.batch`)."""
    jobs = []
    for name in SCENES:
        base = load_scene(name)
        ov = overrides_for(reading) + [f"loading.v_imp={base.pulse.v_imp * reading.v_scale}"]
        if name == "case4":  # Case IV: the paper's C_n, C_s ÷ 10, relative to the reading's
            ov += [f"interface.Cn={3e10 * reading.stiffness_scale}", f"interface.Cs={1e10 * reading.stiffness_scale}"]
        scene = load_scene(name, ov)  # validate everything first
        jobs.append(batch.Job(name, out / name, scene, batch.expected_cost(scene)))
    batch.run_jobs([j for j in jobs if batch.status(j) != "done"], comm)
    comm.Barrier()
    return {j.key: j.dir for j in jobs}


# ## Statements
# Each returns (fricfem's value as text, verdict).  Tolerances are stated in
# the statement text; "≈" comparisons use ±25 % unless said otherwise.

def close(value, target, rel=None, abs_=None):
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return False
    tol = abs_ if abs_ is not None else rel * abs(target)
    return abs(value - target) <= tol


def statements(runs: dict, speeds) -> list:
    R = {k: open_run(v) for k, v in runs.items()}
    out = []

    def add(group, text, value, ok):
        out.append({"group": group, "statement": text, "fricfem": value, "ok": bool(ok),
                    "demo": f"demos/paper/{DEMOS[group]}"})

    sy = R["symmetric"]
    add("symmetric", "no sliding", f"max slip rate {sy.slip_rate.max():.3g} m/s", sy.slip_rate.max() == 0)
    lf = loading_front(sy, 16e-6, 10e6)
    add("symmetric", "loading front 34 mm in at 16 µs (±3 mm)", f"{lf:.1f} mm", close(lf, 34, abs_=3))

    c1 = R["case1"]
    t0, x0 = first_slip(c1)
    add("case1", "crack-like", mode(c1), mode(c1) == "crack-like")
    add("case1", "sliding starts at the impact edge (x1 < 2 mm) at 16 µs (±2 µs)",
        "no sliding" if t0 is None else f"{t0:.1f} µs at {x0:.1f} mm",
        t0 is not None and close(t0, 16, abs_=2) and x0 < 2)
    tip_v, behind_v = tip_and_behind(c1, 32e-6, c1.slip_rate)
    add("case1", "peak Δu̇_slip ≈ 7 m/s at the tip, ≈ 5 m/s behind, at 32 µs (±25 %)",
        f"{tip_v:.2f} / {behind_v:.2f} m/s", close(tip_v, 7, 0.25) and close(behind_v, 5, 0.25))
    lf = loading_front(c1, 32e-6, 6e6)
    add("case1", "loading front at 71 mm at 32 µs (±3 mm)", f"{lf:.1f} mm", close(lf, 71, abs_=3))
    a, b = tip_and_behind(c1, 32e-6, np.abs(c1.shear_traction))
    add("case1", "T_s ≈ 3.9 MPa at the tip, 3.6 MPa behind (±0.2 MPa)", f"{a / 1e6:.2f} / {b / 1e6:.2f} MPa",
        close(a / 1e6, 3.9, abs_=0.2) and close(b / 1e6, 3.6, abs_=0.2))
    a, b = tip_and_behind(c1, 32e-6, c1.normal_traction)
    add("case1", "T_n 6.39 MPa at the tip, 6.14 MPa behind (±0.15 MPa)", f"{a / 1e6:.2f} / {b / 1e6:.2f} MPa",
        close(a / 1e6, 6.39, abs_=0.15) and close(b / 1e6, 6.14, abs_=0.15))
    mu = np.divide(np.abs(c1.shear_traction), c1.normal_traction, out=np.zeros_like(np.abs(c1.shear_traction)), where=c1.normal_traction > 0)
    a, b = tip_and_behind(c1, 32e-6, mu)
    add("case1", "μ_app 0.609 at the tip, 0.585 behind (±0.01)", f"{a:.3f} / {b:.3f}",
        close(a, 0.609, abs_=0.01) and close(b, 0.585, abs_=0.01))
    tip = c1.tip(32e-6) * 1e3
    add("case1", "sliding tip near 44 mm at 32 µs (±4 mm)", f"{tip:.1f} mm", close(tip, 44, abs_=4))

    c2 = R["case2"]
    t0, x0 = first_slip(c2)
    add("case2", "pulse-like", mode(c2), mode(c2) == "pulse")
    add("case2", "sliding starts at 28 µs (±2 µs)", "no sliding" if t0 is None else f"{t0:.1f} µs",
        t0 is not None and close(t0, 28, abs_=2))
    n32, n34 = len(measures.regions(c2, c2.at(32e-6))), len(measures.regions(c2, c2.at(34e-6)))
    add("case2", "2 pulses at 32 µs, 3 at 34 µs", f"{n32} / {n34}", (n32, n34) == (2, 3))
    pk = float(c2.slip_rate.max())
    add("case2", "peak slip rate ≈ 700 m/s (±25 %)", f"{pk:.0f} m/s", close(pk, 700, 0.25))
    tip = c2.tip(32e-6) * 1e3
    add("case2", "leading pulse near 22 mm at 32 µs (±4 mm)", f"{tip:.1f} mm", close(tip, 22, abs_=4))

    c3 = R["case3"]
    add("case3", "train of pulses", mode(c3), mode(c3) == "pulse-train")
    k = c3.at(32e-6)
    train = pulse_train(c3, 32e-6)
    width, spacing = train["width_mm"], train["spacing_mm"]
    add("case3", "pulse width 1.33 mm, spacing 2.21 mm at 32 µs (±25 %)", f"{width:.2f} / {spacing:.2f} mm",
        close(width, 1.33, 0.25) and close(spacing, 2.21, 0.25))
    pk = float(c3.slip_rate[k].max())
    add("case3", "peak ≈ 120 m/s at 32 µs (±25 %)", f"{pk:.0f} m/s", close(pk, 120, 0.25))
    tip = c3.tip(32e-6) * 1e3
    add("case3", "leading front near 55 mm at 32 µs (±4 mm)", f"{tip:.1f} mm", close(tip, 55, abs_=4))

    c4 = R["case4"]
    t0, _ = first_slip(c4)
    add("case4", "sliding starts at 14 µs (±2 µs)", "no sliding" if t0 is None else f"{t0:.1f} µs",
        t0 is not None and close(t0, 14, abs_=2))
    n22 = len(measures.regions(c4, c4.at(22e-6)))
    tip22 = c4.tip(22e-6) * 1e3
    add("case4", "3 pulses at 22 µs, tip at 18 mm (±3 mm)", f"{n22} regions, tip {tip22:.1f} mm",
        n22 == 3 and close(tip22, 18, abs_=3))
    tip32 = c4.tip(32e-6) * 1e3
    add("case4", "tip at 41 mm at 32 µs (±4 mm)", f"{tip32:.1f} mm", close(tip32, 41, abs_=4))
    fast = [f for f in c4.summary.get("fronts", []) if f.get("kind") == "rupture" and f.get("mean_speed")]
    vmax = max((f["mean_speed"] for f in fast), default=float("nan"))
    add("case4", "a trailing pulse at ≈ 2700 m/s, faster than c_l (±10 %)", f"fastest rupture front {vmax:.0f} m/s",
        close(vmax, 2700, 0.10))
    k41 = c4.at(41e-6)
    n41 = len(measures.regions(c4, k41))
    tip41 = c4.tip(41e-6) * 1e3
    add("case4", "one crack-like region by 41 µs, tip ≈ 60 mm (±5 mm)", f"{n41} regions, tip {tip41:.1f} mm",
        n41 == 1 and close(tip41, 60, abs_=5))
    add("case4", "pulses coalescing into a crack (mixed)", mode(c4), mode(c4) == "mixed")

    c5 = R["case5"]
    t0, _ = first_slip(c5)
    add("case5", "starts at 31 µs (±2 µs) as a pulse", "no sliding" if t0 is None else f"{t0:.1f} µs",
        t0 is not None and close(t0, 31, abs_=2))
    pk = float(c5.slip_rate[c5.at(44e-6)].max()) if len(c5.t) else float("nan")
    add("case5", "peak slip rate ≈ 392 m/s at 44 µs (±25 %)", f"{pk:.0f} m/s", close(pk, 392, 0.25))
    add("case5", "a pulse followed by a crack (mixed)", mode(c5), mode(c5) == "mixed")

    vt = []
    for name in ("case1", "case2", "case3", "case4", "case5"):
        tip = R[name].summary.get("tip") or {}
        v = np.asarray(tip.get("v_tip_m_s") or [], dtype=float)
        if len(v):
            vt.append(float(np.median(v)))
    ok = len(vt) == 5 and all(v > speeds["sqrt2_c_s"] for v in vt)
    add("all", "leading tip faster than √2 c_s (1776 m/s), near c_l, in all five cases",
        ", ".join(f"{v:.0f}" for v in vt) + " m/s (median V_tip)", ok)

    want = {"lineA_v2": "crack-like", "lineA_v7": "mixed", "lineA_v10": "pulse-train",
            "lineA_v20": "pulse-train", "lineA_v40": "pulse-train",
            "lineB_s6": "crack-like", "lineB_s10": "crack-like", "lineB_s16": "pulse-train", "lineB_s30": "pulse"}
    for name, label in want.items():
        add(name.split("_")[0], f"{name}: {label}", mode(R[name]), mode(R[name]) == label)
    st = R["lineA_v2"].stations.get("x16.1mm", {})
    mu = st.get("mu_app", np.zeros(1))
    late = float(np.abs(mu[-len(mu) // 4:]).mean()) if len(mu) > 4 else float("nan")
    add("lineA", "V_imp = 2 m/s: steady μ_app ≈ 0.598 at x1 = 16.1 mm (±0.01)", f"{late:.3f}",
        close(late, 0.598, abs_=0.01))
    pk = float(R["lineB_s30"].slip_rate.max())
    add("lineB", "Σ0 = 30 MPa: narrow pulses with peak ≈ 820 m/s (±25 %)", f"{pk:.0f} m/s", close(pk, 820, 0.25))
    return out


class Reading(NamedTuple):
    direction: str = "push"
    v_scale: float = 1.0
    stiffness_scale: float = 1.0
    preset: str = "reference"


def markdown(rows, reading) -> str:
    lines = [f"Reading: direction = {reading.direction}, V_imp × {reading.v_scale:g}, "
             f"C_n, C_s × {reading.stiffness_scale:g}, mesh {reading.preset}: "
             f"**{sum(r['ok'] for r in rows)} / {len(rows)} ✓**", "",
             "| | paper | fricfem | | figure demo |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['group']} | {r['statement']} | {r['fricfem']} | {'✓' if r['ok'] else '✗'} "
                     f"| `{r['demo']}` |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description="evaluate the paper's statements under one reading")
    ap.add_argument("--reading", default="push", choices=("push", "pull"))
    ap.add_argument("--v-scale", type=float, default=1.0)
    ap.add_argument("--stiffness-scale", type=float, default=1.0)
    ap.add_argument("--preset", default="reference")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    reading = Reading(a.reading, a.v_scale, a.stiffness_scale, a.preset)
    comm = MPI.COMM_WORLD
    out = Path(a.out or f"runs/repro/{a.reading}_v{a.v_scale:g}_k{a.stiffness_scale:g}_{a.preset}")
    runs = run_all(reading, out, comm)
    if comm.rank == 0:
        rows = statements(runs, load_scene("case1").material.speeds())
        (out / "statements.json").write_text(json.dumps({"reading": reading._asdict(), "rows": rows}, indent=2))
        md = markdown(rows, reading)
        (out / "statements.md").write_text(md)
        print(md)
    return 0


if __name__ == "__main__":
    main()
