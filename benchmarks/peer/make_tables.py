#!/usr/bin/env python3
"""Station tables and summary JSON from SEM2DPACK fault output.

usage: make_tables.py <problem> <label> <run dir> [--every N] [--note TEXT]

writes  <problem>/sem2dpack_<label>.txt   (station table)
and updates <problem>/sem2dpack_summary.json (entry <label>)
(paths relative to this script's folder).
"""
import argparse
import json
import os
import re

import numpy as np

from make_par import GEOMETRY  # fault length [m] and stations [mm] of each problem
from read_sem2dpack import read_fault
V_RUPT = 1e-3  # m/s, rupture-time threshold

HERE = os.path.dirname(os.path.abspath(__file__))


def rupture_time(t, v, thr=V_RUPT):
    """First time slip rate exceeds thr (linear interpolation between the
    two output samples that bracket the first crossing); None if never."""
    idx = np.nonzero(v > thr)[0]
    if idx.size == 0:
        return None
    i = idx[0]
    if i == 0:
        return float(t[0])
    v0, v1 = v[i - 1], v[i]
    return float(t[i - 1] + (thr - v0) / (v1 - v0) * (t[i] - t[i - 1]))


def parse_info(run):
    info = open(os.path.join(run, "info.txt")).read()
    tim = open(os.path.join(run, "time.txt")).read()
    par = open(os.path.join(run, "Par.inp")).read()
    dt = float(re.search(r"Time step \(secs\)\s*=\s*([-\d.E+]+)", info).group(1))
    nst = int(re.search(r"Number of time steps\s*=\s*(\d+)", info).group(1))
    user = float(re.search(r"User time \(seconds\):\s*([\d.]+)", tim).group(1))
    syst = float(re.search(r"System time \(seconds\):\s*([\d.]+)", tim).group(1))
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\):\s*(\S+)", tim).group(1)
    ngll = int(re.search(r"ngll=(\d+)", par).group(1))
    nelem = [int(v) for v in re.search(r"nelem=(\d+),(\d+)", par).groups()]
    ngllpts = int(re.search(r"Total number of GLL points[ .]*=\s*(\d+)", info).group(1))
    return dict(dt_s=dt, n_steps=nst, cpu_user_s=user, cpu_sys_s=syst,
                cpu_s=round(user + syst, 2), wall=wall, ngll=ngll,
                poly_degree=ngll - 1, nelem_x=nelem[0], nelem_z=nelem[1],
                n_gll_points=ngllpts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("problem")
    ap.add_argument("label")
    ap.add_argument("run")
    ap.add_argument("--every", type=int, default=0,
                    help="keep every N-th output sample in the table "
                         "(0: smallest N keeping the file < --max-bytes)")
    ap.add_argument("--max-bytes", type=float, default=1.95e6)
    ap.add_argument("--note", default="")
    args = ap.parse_args()

    lx, STATIONS_MM = GEOMETRY[args.problem]
    d = read_fault(os.path.join(args.run, "Flt05_sem2d"))
    t, x = d["t"], d["x"]
    meta = parse_info(args.run)
    elem = lx / meta["nelem_x"]
    # SEM2DPACK uses the leapfrog scheme: the record written at step k holds
    # slip and traction at t_k = k dt but the slip rate at t_k + dt/2
    # (mid-step velocity).  Re-centre the slip rate on t_k by averaging the
    # records k-1 and k (requires output at every time step).
    if abs(d["dt"] - meta["dt_s"]) > 1e-3 * meta["dt_s"]:
        raise SystemExit("fault output is not at every time step; "
                         "cannot re-centre the slip rate")
    meta["dt_s"] = float(d["dt"])  # full precision (info.txt prints 5 digits)
    v_half = d["Slip_Rate"]
    v_c = v_half.copy()
    v_c[1:] = 0.5 * (v_half[1:] + v_half[:-1])
    d["Slip_Rate"] = v_c
    if args.every == 0:  # choose the smallest stride giving < max_bytes
        row_bytes = (1 + 3 * len(STATIONS_MM)) * 14 + 1
        args.every = int(np.ceil(t.size * row_bytes / args.max_bytes))

    st_info = []
    for xs_mm in STATIONS_MM:
        k = int(np.argmin(np.abs(x - xs_mm * 1e-3)))
        st_info.append((xs_mm, k, x[k]))
    # ------------------------------------------------------------ table
    sel = np.arange(0, t.size, args.every)
    if sel[-1] != t.size - 1:
        sel = np.append(sel, t.size - 1)
    table = [t[sel]]
    names = ["t_s"]
    for xs_mm, k, xk in st_info:
        table += [d["Slip"][sel, k], d["Slip_Rate"][sel, k], d["Shear_Stress"][sel, k]]
        names += [f"slip_x{xs_mm}mm_m", f"sliprate_x{xs_mm}mm_mps",
                  f"shear_x{xs_mm}mm_Pa"]
    table = np.column_stack(table)
    # Round-off on locked nodes gives tiny negative slip / slip rate
    # (|slip| < 1e-20 m, |V| < 1e-15 m/s).  Set negatives smaller in size than
    # these tolerances to 0 so that the tables obey slip >= 0, V >= 0; larger
    # negative values (none in these runs) would be kept and reported.
    n_clip = 0
    for j, nm in enumerate(names):
        tol = 1e-15 if nm.startswith("slip_") else 1e-12 if nm.startswith("sliprate_") else 0
        if tol:
            m = (table[:, j] < 0) & (table[:, j] > -tol)
            n_clip += int(m.sum())
            table[:, j][m] = 0.0
    n_neg = int(sum((table[:, j] < 0).sum() for j, nm in enumerate(names)
                    if nm.startswith(("slip_", "sliprate_"))))
    out_dir = os.path.join(HERE, args.problem)
    os.makedirs(out_dir, exist_ok=True)
    fn = os.path.join(out_dir, f"sem2dpack_{args.label}.txt")
    hdr = [
        f"SEM2DPACK peer solution, problem {args.problem}, resolution {args.label}",
        f"element size {elem*1e3:.6g} mm, ngll {meta['ngll']} (polynomial degree "
        f"{meta['poly_degree']}), fault node spacing mean {elem/(meta['ngll']-1)*1e3:.6g} mm "
        f"(min {np.diff(x).min()*1e3:.4g}, max {np.diff(x).max()*1e3:.4g} mm: GLL nodes)",
        f"solver time step dt = {meta['dt_s']:.9e} s; table interval = "
        f"{(t[1]-t[0])*args.every:.9e} s (every {args.every} fault output(s); "
        f"fault output every {t[1]-t[0]:.9e} s)",
        "values at the fault node NEAREST to each station (no interpolation);",
        "station x_requested_mm -> x_node_mm: " + ", ".join(
            f"{xs}->{xk*1e3:.6f}" for xs, k, xk in st_info),
        "slip [m] = u_x(upper block, y>0) - u_x(lower block, y<0); slip rate [m/s] its rate;",
        "shear [Pa] = total shear traction sigma_xy on the fault (initial included);",
        "positive shear drives positive slip (upper block moving +x relative to lower).",
        "slip rate re-centred on t (SEM2DPACK's leapfrog stores it at t+dt/2: "
        "average of consecutive steps);",
        "values were stored by SEM2DPACK as float32 (about 7 significant digits).",
        f"{n_clip} round-off values (-1e-15 < slip < 0 m or -1e-12 < slip rate < 0 m/s, "
        f"locked nodes) set to 0; remaining negative slip/slip-rate values: {n_neg}.",
    ]
    if args.note:
        hdr.append(args.note)
    hdr.append(" ".join(names))
    np.savetxt(fn, table, fmt="%.6e", header="\n".join(hdr), comments="# ")

    # ------------------------------------------------------------ summary
    stations = []
    for xs_mm, k, xk in st_info:
        v = d["Slip_Rate"][:, k]
        tr = rupture_time(t, v)
        stations.append(dict(
            x_mm=xs_mm, x_node_mm=round(float(xk) * 1e3, 9),
            rupture_time_s=tr,
            peak_slip_rate_mps=float(v.max()),
            t_peak_slip_rate_s=float(t[int(np.argmax(v))]),
            final_slip_m=(0.0 if -1e-15 < d["Slip"][-1, k] < 0
                          else float(d["Slip"][-1, k])),
        ))
    entry = dict(meta)
    entry.update(dict(
        element_size_m=elem,
        mean_fault_node_spacing_m=elem / (meta["ngll"] - 1),
        min_fault_node_spacing_m=float(np.diff(x).min()),
        max_fault_node_spacing_m=float(np.diff(x).max()),
        n_fault_nodes=int(x.size),
        fault_output_interval_s=float(t[1] - t[0]),
        end_time_s=float(t[-1]),
        rupture_time_definition="first time slip rate > 1e-3 m/s (linear "
                                "interpolation between output samples)",
        station_value="nearest fault node",
        slip_rate_centering="leapfrog mid-step slip rate averaged over "
                            "consecutive steps to sit at t = k dt",
        table_interval_s=float((t[1] - t[0]) * args.every),
        stations=stations,
    ))
    if args.note:
        entry["note"] = args.note
    sj = os.path.join(out_dir, "sem2dpack_summary.json")
    summ = json.load(open(sj)) if os.path.exists(sj) else {}
    summ.setdefault("problem", args.problem)
    summ.setdefault("resolutions", {})
    summ["resolutions"][args.label] = entry
    with open(sj, "w") as f:
        json.dump(summ, f, indent=1)
    print(fn, os.path.getsize(fn), "bytes")
    for s in stations:
        print(f"{s['x_mm']:3d} mm tr={s['rupture_time_s']} "
              f"Vpk={s['peak_slip_rate_mps']:.4g} D={s['final_slip_m']:.4g}")


if __name__ == "__main__":
    main()
