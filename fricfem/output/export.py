"""``fricfem export RUN --format scec|csv``: station time series of a run in the
formats codes are compared in.

- ``scec``: one ASCII file per station, ``<station>.dat``, in the layout of the
  SCEC/USGS spontaneous-rupture code-verification exercise (a ``#`` header with
  problem, code, element size, time step, number of steps and location; the
  column descriptions; the line of field names ``t h-slip h-slip-rate
  h-shear-stress n-stress``; then one row per step in E15.7).  The in-plane
  interface has one slip direction, so the 2-D form has the horizontal columns
  and the normal stress only.  Stresses in MPa, the rest SI.
- ``csv``: one file ``stations.csv``, one row per station and step, SI units:
  ``station,x1_m,t_s,slip_m,slip_rate_m_s,shear_stress_Pa,normal_stress_Pa``.

Signs (both formats, as the exercise's): slip and slip rate as fricfem stores
them (Δu_slip ≥ 0 accumulated, Δu̇_slip ≥ 0); the shear stress is the total
shear traction (prestress included) counted positive in the direction of
sliding, i.e. T_s times the run's sliding sign (:func:`..rundir.sliding_sign`);
the normal stress is −T_n, negative in compression.
"""

from __future__ import annotations

import datetime
import math
import os
from importlib.metadata import version
from pathlib import Path

import numpy as np

from ..scene import validate
from .rundir import INTERFACE_FILE, open_interface, read_summary, sliding_sign

FORMATS = ("scec", "csv")
CSV_COLUMNS = ("station", "x1_m", "t_s", "slip_m", "slip_rate_m_s", "shear_stress_Pa", "normal_stress_Pa")


def station_series(rundir) -> dict:
    """{station: {"x1": m, "t": s, "slip": m, "slip_rate": m/s, "shear_stress": Pa, "normal_stress": Pa}}
    with the exercise's signs (module docstring)."""
    path = Path(rundir) / INTERFACE_FILE
    if not path.is_file():
        raise ValueError(f"{rundir}: not a run directory (no {INTERFACE_FILE})")
    with open_interface(path) as itf:
        sign = sliding_sign(itf)
        stations = itf.stations()
    if not stations:
        raise ValueError(f"{rundir}: the run has no stations (output.stations of the scene); nothing to export")
    out = {}
    for name, st in stations.items():
        missing = [k for k in ("slip", "slip_rate", "shear_traction", "normal_traction") if k not in st.data]
        if missing:
            raise ValueError(f"{rundir}: station {name} has no {', '.join(missing)}")
        t = np.asarray(st.time, dtype=float)
        # every column at the row's time t^n: a quantity held at another time (the rigid kind's slip rate
        # at t^{n+½}, slip at t^{n+1}) is interpolated linearly to it (the mean of two steps' rates; the
        # previous row's slip)
        at = {k: np.interp(t, st.time_of(k), st.data[k]) if st.shift.get(k) else st.data[k]
              for k in ("slip", "slip_rate")}
        out[name] = {"x1": st.x1, "t": t, "slip": at["slip"],
                     "slip_rate": at["slip_rate"], "shear_stress": sign * st.data["shear_traction"] + 0.0,
                     "normal_stress": -st.data["normal_traction"] + 0.0}  # + 0.0: no −0
    return out


def _element_size(summary: dict):
    """The cell size along the interface [m] of the run's scene (None if it cannot be told)."""
    try:
        return float(validate(summary["input"]).mesh.dx)
    except Exception:  # an old or partial summary: the header says unknown
        return None


def scec_text(name: str, s: dict, summary: dict, date: str, author: str = "") -> str:
    """The SCEC-format text of one station."""
    h = _element_size(summary)
    t = s["t"]
    lines = [
        f"# problem={summary.get('scene', '?')}",
        f"# author={author}",
        f"# date={date}",
        "# code=fricfem",
        f"# code_version={_version()}",
        f"# element_size={'unknown' if h is None else f'{h:.6g} m'}",
        f"# time_step={summary.get('dt_s', float('nan')):.6g}",
        f"# num_time_steps={len(t)}",
        f"# location= on the interface, x1 = {s['x1'] * 1e3:.4f} mm from the struck edge (station {name})",
        "# run complete" if summary.get("complete") else "# run incomplete (a live or killed run: rows so far)",
        "# Time series in 5 columns of E15.7",
        "# Column #1 = Time (s)",
        "# Column #2 = horizontal slip (m)",
        "# Column #3 = horizontal slip rate (m/s)",
        "# Column #4 = horizontal shear stress (MPa), total, positive in the direction of sliding",
        "# Column #5 = normal stress (MPa), negative in compression",
        "#",
        "# The line below lists the names of the data fields:",
        "t h-slip h-slip-rate h-shear-stress n-stress",
        "#",
        "# Here is the time-series data.",
    ]
    data = np.column_stack([t, s["slip"], s["slip_rate"], s["shear_stress"] / 1e6, s["normal_stress"] / 1e6])
    lines += [" ".join(f"{v:15.7E}" for v in row) for row in data]
    return "\n".join(lines) + "\n"


def _version() -> str:
    try:
        return version("fricfem")
    except Exception:
        return "unknown"


def export(rundir, fmt: str = "scec", out=None, author: str = "") -> list:
    """Write the station series of ``rundir`` in ``fmt`` into ``out`` (default RUNDIR/export/<fmt>);
    returns the files written."""
    if fmt not in FORMATS:
        raise ValueError(f"--format {fmt!r}: expected one of {', '.join(FORMATS)}")
    rundir = Path(rundir)
    series = station_series(rundir)
    summary = read_summary(rundir)
    out = Path(out) if out is not None else rundir / "export" / fmt
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r}: exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if fmt == "scec":
        stamp = os.path.getmtime(rundir / INTERFACE_FILE)
        date = datetime.datetime.fromtimestamp(stamp, datetime.timezone.utc).strftime("%Y/%m/%d")
        for name, s in series.items():
            path = out / f"{name}.dat"
            _write(path, scec_text(name, s, summary, date, author))
            written.append(path)
    else:
        rows = [",".join(CSV_COLUMNS)]
        for name, s in series.items():
            x1 = repr(float(s["x1"]))
            for k in range(len(s["t"])):
                rows.append(",".join([name, x1] + [repr(float(s[q][k])) if math.isfinite(s[q][k]) else "nan"
                                                   for q in ("t", "slip", "slip_rate", "shear_stress",
                                                             "normal_stress")]))
        path = out / "stations.csv"
        _write(path, "\n".join(rows) + "\n")
        written.append(path)
    return written


def _write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def read_scec(path) -> tuple:
    """(header lines, field names, float64[n, 5] data) of a SCEC-format file."""
    header, names, rows = [], None, []
    for line in Path(path).read_text().splitlines():
        if line.startswith("#"):
            header.append(line)
        elif names is None:
            names = line.split()
        elif line.strip():
            rows.append([float(v) for v in line.split()])
    return header, names, np.array(rows)
