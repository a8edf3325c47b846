# # Sweep speed: model reuse, adaptive mode maps, start-up
#
# What a mode map costs, measured in one run of this script (a plain
# ``python``: it launches ``mpirun`` itself), with the machine's load recorded
# beside every number (the machine may be shared: compare ratios within a run):
#
# 1. **8 × 8 map** (``fricfem sweep case1 --grid default``, reference mesh, 2
#    ranks, every point computed): the sweep's wall time against the sum of its
#    points' own time loops / ranks (each point's ``summary.json``
#    ``wall_s.time_loop``), with model reuse (the default) and with
#    ``--no-reuse`` (every model built afresh, as before) in the same run; the
#    labels of the two and of the committed map
#    (``docs/reproduction/modemap_push_v1.json``) compared.
# 2. **Adaptive 32 × 32 map** (``--adaptive --sigma0 0.9:40:32 --v-imp 1:40:32``):
#    scenes, rounds and wall time, and its agreement with the full 32 × 32 map
#    computed once (``--full DIR``: its sweep directory; the labels are kept in
#    ``results/modemap_full32.json``).
# 3. **Case I end to end, warm**: ``mpirun -n 2 fricfem run case1`` (median of
#    ``--warm-repeats`` after one warm-up), with its ``summary.json`` split.
# 4. **The loop's outputs** (``benchmarks/loop_cost.py`` under ``mpirun -n 2``):
#    Case I on the reference mesh, the time loop with its default outputs per
#    step, split by part (``summary.json`` ``loop_cost``), against a bare
#    ``K.mult`` on the same mesh timed after each run; with and without the
#    three field snapshots.
# 5. **Start-up**: ``python -X importtime`` of a run: import time per package;
#    ``import gmsh`` alone (what a run no longer imports); ``mpirun -n 2 python
#    -c 'from mpi4py import MPI'``.
# 6. **Floors**: what Case I's end-to-end time cannot go below whatever the
#    loop and the outputs do — ``mpirun -n 2 python -c`` importing exactly the
#    modules a run imports (fricfem's own excepted), the kernels' and forms'
#    cache loads (``end_to_end.py``'s probe of a warm run), and Case I's steps
#    × a bare MatMult on the reference mesh (no setup, no outputs, a step as
#    cheap as one MatMult); and the step's parts against that MatMult
#    (``step_vs_matmult.py povirk_needleman``).
#
#     .venv/bin/python benchmarks/sweep_speed.py --full runs/sweep32/full
#
# writes ``benchmarks/results/sweep_speed.{json,md}`` and the maps' figures
# ``results/modemap_{default8,full32,adaptive32}.png``.  ``--only`` runs some
# parts (map8, adaptive, case1, loop, startup, floors; full: only read the full map); the
# parts not run keep their last results, each with its date and code.
# ``--smoke``: a 2 × 2 map on the coarse mesh and the start-up part, into
# ``results/smoke/``.

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
PAPER_MAP = ROOT / "docs" / "reproduction" / "modemap_push_v1.json"
FULL32 = ("0.9:40:32", "1:40:32")


# ## Running and the machine's load


def env() -> dict:
    e = dict(os.environ)
    if os.geteuid() == 0:
        e.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    e.update(OMP_NUM_THREADS="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    return e


def busy_s() -> float:
    """CPU seconds the machine has spent busy since boot (/proc/stat)."""
    with open("/proc/stat") as fh:
        v = [int(x) for x in fh.readline().split()[1:]]
    return (sum(v) - v[3] - v[4]) / os.sysconf("SC_CLK_TCK")


def timed(cmd: list) -> dict:
    """Run ``cmd``; its wall time, the load average before and after, and the share
    of the machine's CPUs that other processes took meanwhile."""
    import resource

    r0, b0, la0 = resource.getrusage(resource.RUSAGE_CHILDREN), busy_s(), os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env(), cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1, b1 = resource.getrusage(resource.RUSAGE_CHILDREN), busy_s()
    if proc.returncode not in (0,):
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "load_before": la0, "load_after": os.getloadavg()[0],
            "others_cpu_share": max(b1 - b0 - cpu, 0.0) / (wall * (os.cpu_count() or 1)), "stdout": proc.stdout}


def fricfem(*args) -> list:
    return [sys.executable, "-m", "fricfem.cli", *map(str, args)]


def mpirun(n: int, cmd: list) -> list:
    return ["mpirun", "--oversubscribe", "-n", str(n), *cmd]


# ## 1. The 8 × 8 map, with and without model reuse


def sweep_run(out: Path, ranks: int, args: list) -> dict:
    """A fresh sweep into ``out``: the command's numbers and the map's."""
    shutil.rmtree(out, ignore_errors=True)
    m = timed(mpirun(ranks, fricfem("sweep", *args, "--out", out, "--quiet")))
    doc = json.loads((out / "modemap.json").read_text())
    loops, setups, outputs = [], [], []
    for p in doc["points"]:
        w = json.loads((out / p["dir"] / "summary.json").read_text())["wall_s"]
        loops.append(w["time_loop"])
        setups.append(w["setup"])
        outputs.append(w.get("output", 0.0))
    sweep_wall = doc["calls"][-1]["wall_s"]
    m.pop("stdout")
    return {**m, "sweep_wall_s": sweep_wall, "scenes": len(doc["points"]), "sum_time_loop_s": sum(loops),
            "sum_setup_s": sum(setups), "sum_output_s": sum(outputs), "rank_busy_s": rank_busy(out),
            "diagnose": diagnose_time(out, doc),
            "ratio_to_loops": sweep_wall / (sum(loops) / ranks), "labels": doc["labels"]["values"],
            "incomplete": doc["incomplete"], "dir": str(out)}


def rank_busy(out: Path) -> dict:
    """{rank: the sum of its points' run times [s]} from ``sweep.log`` (how evenly the
    groups were loaded: they take points as they free up)."""
    busy: dict = {}
    for line in (out / "sweep.log").read_text().splitlines():
        m = re.search(r"\[rank (\d+)\] \d+/\d+ \S+: .* \(([\d.]+) s\)$", line)
        if m:
            busy[m.group(1)] = busy.get(m.group(1), 0.0) + float(m.group(2))
    return busy


def diagnose_time(out: Path, doc: dict) -> dict:
    """The run's diagnostics (fronts and the mode, as each point's run does at its
    end) timed again here over every point of the map, serially
    (``diagnose_speed.py``); the labels must be the points' own."""
    from diagnose_speed import load_points, time_points  # beside this script

    took, same = time_points(load_points([out / p["dir"] for p in doc["points"]]))
    return {"points": len(took), "median_ms": 1e3 * statistics.median(took), "total_s": sum(took),
            "same_labels": same}


def committed_labels() -> list:
    """The label grid of the committed 8 × 8 map (either layout of its ``labels``)."""
    labels = json.loads(PAPER_MAP.read_text())["maps"]["main"]["labels"]
    return labels["values"] if isinstance(labels, dict) else labels


def map8(root: Path, ranks: int, smoke: bool) -> dict:
    args = ["case1", "--sigma0", "6,30", "--v-imp", "2,20", "--preset", "coarse", "--set", "time.end=10e-6"] \
        if smoke else ["case1", "--grid", "default"]
    reuse = sweep_run(root / "map8_reuse", ranks, args)
    fresh = sweep_run(root / "map8_fresh", ranks, args + ["--no-reuse"])
    out = {"command": "mpirun -n %d fricfem sweep %s" % (ranks, " ".join(args)), "reuse": reuse, "fresh": fresh,
           "speedup_reuse": fresh["sweep_wall_s"] / reuse["sweep_wall_s"],
           "same_labels_reuse_fresh": reuse["labels"] == fresh["labels"]}
    if not smoke and PAPER_MAP.is_file():
        out["same_labels_as_committed_map"] = reuse["labels"] == committed_labels()
    if not smoke:
        shutil.copy(root / "map8_reuse" / "modemap.png", RESULTS / "modemap_default8.png")
    return out


# ## 2. The adaptive 32 × 32 map against the full one


#: points of the full map recomputed with the current code and compared bit for bit
#: (the pulse/crack and mixed regions, a point beside the recomputed ones, a corner)
RECHECK = ("s0.9_v1", "s13.29_v35.51", "s15.03_v40")


def recheck(full_dir: Path, root: Path) -> dict:
    """benchmarks/recheck_points.py on :data:`RECHECK` (2 ranks, one point per rank)."""
    path = root / "recheck.json"
    m = timed(mpirun(2, [sys.executable, HERE / "recheck_points.py", full_dir, "--sigma0", FULL32[0], "--v-imp",
                         FULL32[1], "--points", ",".join(RECHECK), "--json", path]))
    return {"points": json.loads(path.read_text()), "load_before": m["load_before"],
            "date": time.strftime("%Y-%m-%d %H:%M")}


def full_map(full_dir: Path | None, load_log: Path | None = None) -> dict | None:
    """The full 32 × 32 map: from its sweep directory (and kept, small, in
    results/modemap_full32.json), or from that file.  ``load_log``: lines
    'HH:MM:SS load1 load5 load15' taken while it ran."""
    keep = RESULTS / "modemap_full32.json"
    if full_dir is not None:
        doc = json.loads((Path(full_dir) / "modemap.json").read_text())
        wall = sum(c["wall_s"] for c in doc["calls"] if c["computed"])  # the calls that ran points
        small = {"command": f"mpirun -n 2 fricfem sweep case1 --sigma0 {FULL32[0]} --v-imp {FULL32[1]}",
                 "title": doc["title"], "grid": doc["grid"], "labels": doc["labels"],
                 "confidence": doc["confidence"], "boundary": doc["boundary"],
                 "counts": dict(Counter(lab for row in doc["labels"]["values"] for lab in row)),
                 "scenes": len(doc["points"]), "incomplete": doc["incomplete"], "calls": doc["calls"],
                 "wall_s_all_calls": wall, "point_wall_s_sum": sum(p["wall_s"] or 0 for p in doc["points"])}
        if load_log is not None:
            loads = [float(line.split()[1]) for line in Path(load_log).read_text().splitlines() if line.strip()]
            small["load_1min_while_running"] = {"samples": len(loads), "median": statistics.median(loads),
                                                "min": min(loads), "max": max(loads)}
        keep.write_text(json.dumps(small, indent=1))
        shutil.copy(Path(full_dir) / "modemap.png", RESULTS / "modemap_full32.png")
        return small
    return json.loads(keep.read_text()) if keep.is_file() else None


def adaptive(root: Path, ranks: int, full: dict | None, coarse: int) -> dict:
    out = root / "adaptive32"
    shutil.rmtree(out, ignore_errors=True)
    m = timed(mpirun(ranks, fricfem("sweep", "case1", "--sigma0", FULL32[0], "--v-imp", FULL32[1], "--adaptive",
                                    "--coarse", coarse, "--out", out, "--quiet")))
    m.pop("stdout")
    doc = json.loads((out / "modemap.json").read_text())
    ad = doc["adaptive"]
    res = {**m, "coarse": coarse, "scenes": ad["scenes"], "rounds": ad["rounds"], "finished": ad["finished"],
           "sweep_wall_s": doc["calls"][-1]["wall_s"], "labels": doc["labels"]["values"]}
    if full is not None:
        from fricfem.analysis.modemap import agreement

        fl = full["labels"]["values"]
        res["agreement_with_full"] = agreement(doc["labels"]["values"], fl)
        res["disagree"] = [[i, j, fl[i][j], doc["labels"]["values"][i][j]] for i in range(len(fl))
                           for j in range(len(fl[i])) if fl[i][j] != doc["labels"]["values"][i][j]]
        res["computed_points_agree"] = all(fl[i][j] == doc["labels"]["values"][i][j]
                                           for i, row in enumerate(ad["computed"]) for j, c in enumerate(row) if c)
    shutil.copy(out / "modemap.png", RESULTS / "modemap_adaptive32.png")
    return res


# ## 3. Case I end to end, warm


def case1(root: Path, ranks: int, repeats: int) -> dict:
    out = root / "case1"
    cmd = mpirun(ranks, fricfem("run", "case1", "--out", out, "--overwrite", "--quiet"))
    timed(cmd)  # warm-up: caches
    runs = []
    for _ in range(repeats):
        m = timed(cmd)
        m.pop("stdout")
        w = json.loads((out / "summary.json").read_text())["wall_s"]
        runs.append({**m, "summary_wall_s": w, "startup_s": m["wall_s"] - w["total"]})
    med = lambda k: statistics.median(r[k] for r in runs)  # noqa: E731
    return {"command": " ".join(map(str, cmd[4:])).replace(sys.executable, "python"), "runs": runs,
            "median_wall_s": med("wall_s"), "min_wall_s": min(r["wall_s"] for r in runs),
            "median_startup_s": med("startup_s"),
            "median_split_s": {k: statistics.median(r["summary_wall_s"][k] for r in runs)
                               for k in ("setup", "time_loop", "output", "total")}}


# ## 4. The loop's outputs


def loop(root: Path, ranks: int, repeats: int) -> dict:
    out = {}
    for n, (name, sets) in [(n, v) for n in sorted({ranks, 1}, reverse=True)
                            for v in (("default outputs", []), ("no field snapshots", ["--set", "output.fields=[]"]))]:
        name = f"{name}, {n} rank{'s' if n > 1 else ''}"
        path = root / f"loop_cost_{n}_{len(sets)}.json"
        cmd = [sys.executable, HERE / "loop_cost.py", "--repeats", repeats, "--json", path, *sets]
        m = timed(mpirun(n, [str(c) for c in cmd]))
        out[name] = {**json.loads(path.read_text()), "load_before": m["load_before"], "load_after": m["load_after"],
                     "others_cpu_share": m["others_cpu_share"]}
    return out


# ## 5. Start-up


#: a line of ``python -X importtime``: self [µs], cumulative [µs], nesting, module
IMPORT_LINE = re.compile(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)")


def import_times(lines) -> dict:
    """Self import time per top-level package [s] from ``-X importtime`` lines."""
    by = Counter()
    for line in lines:
        m = IMPORT_LINE.match(line)
        if m:
            by[m.group(4).split(".")[0]] += int(m.group(1)) / 1e6
    return dict(by.most_common())


def ghost_lists(preset: str = "reference", nparts: int = 2) -> dict:
    """The mesh partitioner's ghost lists (each cell's owner and its neighbours'
    parts): the per-cell Python loop fricfem used before against
    :func:`fricfem.model.mesh.ghost_destinations`, same output, timed in this process."""
    import numpy as np

    from fricfem.model import grid, mesh

    x, cells, *_ = grid.grid_arrays(mesh.preset(preset))
    e = np.sort(np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [2, 0]]]), axis=1)
    cid = np.tile(np.arange(len(cells)), 3)
    order = np.lexsort((e[:, 1], e[:, 0]))
    e, cid = e[order], cid[order]
    same = (e[1:] == e[:-1]).all(axis=1)  # cells sharing an edge
    src = np.concatenate([cid[:-1][same], cid[1:][same]])
    dst = np.concatenate([cid[1:][same], cid[:-1][same]])
    o = np.argsort(src, kind="stable")
    src, dst = src[o], dst[o]
    off = np.concatenate([[0], np.cumsum(np.bincount(src, minlength=len(cells)))])
    owner = grid.bisection_parts(x[cells].mean(axis=1), nparts)
    t0 = time.perf_counter()
    loop = [[int(w), *sorted(set(owner[dst[off[i]:off[i + 1]]].tolist()) - {int(w)})] for i, w in enumerate(owner)]
    t1 = time.perf_counter()
    dest, offsets = mesh.ghost_destinations(owner, dst, off, nparts)
    t2 = time.perf_counter()
    same_out = bool(np.array_equal(np.concatenate(loop), dest))
    return {"cells": len(cells), "parts": nparts, "loop_s": t1 - t0, "numpy_s": t2 - t1, "same_output": same_out,
            "load": os.getloadavg()[0]}


def startup(root: Path, smoke: bool) -> dict:
    cmd = [sys.executable, "-X", "importtime", "-m", "fricfem.cli", "run", "case1", "--set", "mesh.preset='coarse'",
           "--set", "time.end=2e-6", "--set", "output.fields=[]", "--out", root / "startup", "--overwrite", "--quiet"]
    per = []
    for _ in range(1 if smoke else 3):
        t0, la = time.perf_counter(), os.getloadavg()[0]
        proc = subprocess.run(list(map(str, cmd)), env=env(), cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        per.append((import_times(proc.stderr.splitlines()), wall, la))
    pk = {k: statistics.median(p[0].get(k, 0.0) for p in per) for k in per[0][0]}
    total = sum(pk.values())
    gmsh = [timed([sys.executable, "-c", "import gmsh"])["wall_s"] for _ in range(1 if smoke else 3)]
    py = [timed([sys.executable, "-c", "pass"])["wall_s"] for _ in range(1 if smoke else 3)]
    mpi = [timed(mpirun(2, [sys.executable, "-c", "from mpi4py import MPI"]))["wall_s"] for _ in range(1 if smoke else 3)]
    return {"imports_s": dict(sorted(pk.items(), key=lambda kv: -kv[1])[:14]), "imports_total_s": total,
            "serial_command_wall_s": statistics.median(p[1] for p in per),
            "load_during": [p[2] for p in per], "modules_not_imported": [m for m in ("gmsh", "matplotlib", "pyvista",
                                                                                     "meshio") if m not in pk],
            "import_gmsh_alone_s": statistics.median(gmsh) - statistics.median(py),
            "python_pass_s": statistics.median(py), "mpirun2_mpi4py_s": statistics.median(mpi),
            "ghost_lists": ghost_lists("coarse" if smoke else "reference")}


# ## 6. Floors: what the goals stand against


def imported_modules(lines) -> list:
    """The modules fricfem's sources import by name (``import x`` / ``from x import``, fricfem's
    own excepted) that a run imported (``-X importtime`` lines), in import order: what they
    import in turn comes with them; what numba or dolfinx import lazily while loading kernels
    and forms does not (it is in their cache loads)."""
    import ast

    named = set()
    for path in (ROOT / "fricfem").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                named.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                named.add(node.module)
    mods = []
    for line in lines:
        m = IMPORT_LINE.match(line)
        if m and m.group(4) in named and not m.group(4).startswith("fricfem"):
            mods.append(m.group(4))
    return mods


def step_split(ranks: int) -> dict:
    """``benchmarks/step_vs_matmult.py povirk_needleman``: the step and its parts against a bare MatMult [µs]."""
    out = timed(mpirun(ranks, [sys.executable, str(HERE / "step_vs_matmult.py"), "povirk_needleman"]))
    line = out["stdout"].strip().splitlines()[-1]
    m = re.search(r"step (\d+) µs \((.*)\), bare MatMult (\d+) µs", line)
    parts = {k: float(v) for k, v in (kv.rsplit(" ", 1) for kv in m.group(2).split(", "))}
    return {"line": line, "step_us": float(m.group(1)), "matmult_us": float(m.group(3)), "parts_us": parts,
            "load_before": out["load_before"], "load_after": out["load_after"],
            "others_cpu_share": out["others_cpu_share"]}


def floors(root: Path, ranks: int, smoke: bool) -> dict:
    """The parts of Case I's end-to-end time and of the step that fricfem's loop
    and outputs do not control, measured in one run (see the module docstring)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("end_to_end", HERE / "end_to_end.py")
    e2e = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(e2e)
    reps = 1 if smoke else 3
    # the modules a run imports (a short serial run), then only those imports under mpirun
    cmd = [sys.executable, "-X", "importtime", "-m", "fricfem.cli", "run", "case1", "--set", "mesh.preset='coarse'",
           "--set", "time.end=2e-6", "--set", "output.fields=[1e-6]", "--out", root / "floors_imports", "--overwrite", "--quiet"]
    proc = subprocess.run(list(map(str, cmd)), env=env(), cwd=ROOT, capture_output=True, text=True, check=True)
    mods = imported_modules(proc.stderr.splitlines())
    code = ("import importlib\nfor m in " + repr(mods) + ":\n    try:\n        importlib.import_module(m)\n"
            "    except Exception:\n        pass\n")
    mpi = [timed(mpirun(ranks, [sys.executable, "-c", "from mpi4py import MPI"]))["wall_s"] for _ in range(reps)]
    imp = [timed(mpirun(ranks, [sys.executable, "-c", code])) for _ in range(reps)]
    # the kernels' and forms' cache loads, and the steps: the probe of a warm run
    sets = ["mesh.preset='coarse'", "time.end=5e-6"] if smoke else []
    probes = []
    for k in range(reps + 1):  # the first warms the caches
        p = e2e.run_probe(ranks, "case1", sets, root / "floors_probe", env(), root / "floors_probe.json")
        if k:
            probes.append(p)
    split = {ph: statistics.median(p["split"][ph] for p in probes) for ph in probes[0]["split"]}
    step = step_split(ranks) if not smoke else None
    steps = probes[0]["steps"]
    mat_us = step["matmult_us"] if step else float("nan")
    jit = split["JIT: numba (compile or cache load)"] + split["JIT: ffcx forms"]
    return {"modules": mods, "mpirun_mpi4py_s": statistics.median(mpi),
            "imports_s": statistics.median(m["wall_s"] for m in imp),
            "imports_load": [(m["load_before"], m["others_cpu_share"]) for m in imp],
            "probe_split_s": split, "cache_loads_s": jit, "steps": steps,
            "steps_x_matmult_s": steps * mat_us * 1e-6, "step": step,
            "floor_s": statistics.median(m["wall_s"] for m in imp) + jit + steps * mat_us * 1e-6}


# ## The report


def _when(m: dict) -> str:
    return f"({m.get('date', '?')}, commit {m.get('commit', '?')})"


def _load(m: dict) -> str:
    return f"load {m['load_before']:.1f} → {m['load_after']:.1f}, others {100 * m['others_cpu_share']:.0f} %"


def markdown(res: dict) -> str:
    lines = ["# Sweep speed\n\n`.venv/bin/python benchmarks/sweep_speed.py` (each part says when it ran and on which "
             f"code), {res['cpus']} CPUs shared with other jobs: the load average and the share of the CPUs other "
             "processes took during each measurement are given beside it; compare ratios within a part.\n"]
    m8 = res.get("map8")
    if m8:
        r, f = m8["reuse"], m8["fresh"]
        lines += [f"## The 8 × 8 map\n\n`{m8['command']}`, every point computed {_when(m8)}.\n",
                  "| | sweep wall [s] | Σ time loops [s] | Σ setup [s] | Σ output [s] | wall / (Σ loops / 2) | load |",
                  "|---|---|---|---|---|---|---|"]
        for name, x in (("model reuse (default)", r), ("`--no-reuse` (as before)", f)):
            lines.append(f"| {name} | {x['sweep_wall_s']:.1f} | {x['sum_time_loop_s']:.1f} | {x['sum_setup_s']:.1f} | "
                         f"{x['sum_output_s']:.1f} | {x['ratio_to_loops']:.2f} | {_load(x)} |")
        lines.append(f"\nReuse is {m8['speedup_reuse']:.2f} × faster; labels identical with and without reuse: "
                     f"{m8['same_labels_reuse_fresh']}"
                     + (f"; identical to the committed map (docs/reproduction/modemap_push_v1.json): "
                        f"{m8['same_labels_as_committed_map']}" if "same_labels_as_committed_map" in m8 else "")
                     + ".\n")
        if "rank_busy_s" in r:
            busy = ", ".join(f"rank {k} {v:.1f} s" for k, v in sorted(r["rank_busy_s"].items()))
            dg = r["diagnose"]
            lines.append(f"With reuse, the points' run times summed per rank (the groups take points as they "
                         f"free up): {busy}. The points' diagnostics (fronts and mode, as each run does at its "
                         f"end), timed again serially over the {dg['points']} points: median {dg['median_ms']:.1f} ms "
                         f"a point, {dg['total_s']:.2f} s in all; the same labels: {dg['same_labels']}.\n")
    ad, full = res.get("adaptive"), res.get("full32")
    if full:
        lines += ["## Full 32 × 32 map (run once)\n",
                  f"`{full['command']}`: {full['scenes']} scenes, {full['wall_s_all_calls']:.0f} s on 2 ranks "
                  f"(Σ of the points' run times {full['point_wall_s_sum']:.0f} s); labels "
                  f"{', '.join(f'{k} {v}' for k, v in sorted(full['counts'].items(), key=str))}"
                  + (". 1-minute load average while it ran: median {median:.1f} (min {min:.1f}, max {max:.1f}, "
                     "{samples} samples).\n".format(**full["load_1min_while_running"])
                     if "load_1min_while_running" in full else ".\n")]
        redo = [c for c in full["calls"][1:] if c["computed"]]
        if redo:
            lines.append("Later calls recomputed points with the code of their day: "
                         + "; ".join(f"{c['finished']}: {c['computed']} points in {c['wall_s']:.0f} s" for c in redo)
                         + " (`--rerun-stopped`: the points an earlier watchdog had stopped at a slip rate above "
                           "c_l, which it now reports instead of stopping).\n")
        rc = full.get("recheck")
        if rc:
            lines.append(f"Rechecked {rc['date']} (`benchmarks/recheck_points.py`): "
                         + ", ".join(f"{p['key']} {'bit-identical' if p['bit_identical'] else 'DIFFERS: ' + str(p['differ'])}"
                                     f" ({p['datasets']} datasets of interface.h5; label {p['label_now']})"
                                     for p in rc["points"])
                         + " — the points computed before are those of the current code.\n")
    if ad:
        lines += [f"## Adaptive 32 × 32 map {_when(ad)}\n",
                  f"`--adaptive --coarse {ad['coarse']}`: {ad['scenes']} scenes in {len(ad['rounds'])} rounds "
                  f"{ad['rounds']}, {ad['sweep_wall_s']:.0f} s on 2 ranks ({_load(ad)})"
                  + (f"; agrees with the full map on {100 * ad['agreement_with_full']:.1f} % of the 1024 points "
                     f"({len(ad['disagree'])} differ; the computed points all agree: {ad['computed_points_agree']})"
                     if "agreement_with_full" in ad else "") + ".\n"]
        if full:
            lines.append(f"Scenes: {ad['scenes']} of {full['scenes']} ({100 * ad['scenes'] / full['scenes']:.0f} %); "
                         f"wall time {ad['sweep_wall_s'] / full['wall_s_all_calls']:.2f} × the full map's (which ran under "
                         "another load). "
                         "Points that differ [i, j, full, adaptive]: "
                         + ", ".join(f"[{i}, {j}, {a}, {b}]" for i, j, a, b in ad.get("disagree", [])) + ".\n")
    lp = res.get("loop")
    if lp:
        lines += [f"## The time loop and its outputs {_when(lp)}\n",
                  "`mpirun -n 2 .venv/bin/python benchmarks/loop_cost.py` (Case I, reference mesh; µs per step, "
                  "median of the runs, the steps after the first; summary.json `loop_cost`):\n",
                  "| outputs, ranks | bare MatMult | step | energy | stations | watch | snapshots | fields | flush | "
                  "loop (wall) | loop / MatMult | step / MatMult | loads |", "|---|" + "---|" * 12]
        for name, x in lp.items():
            if not isinstance(x, dict) or "median" not in x:
                continue
            m = x["median"]
            loads = ", ".join(f"{r['load_before']:.1f}" for r in x["runs"])
            lines.append(f"| {name} | {m['matmult_us']:.0f} | {m['step']:.0f} | {m['energy']:.1f} | "
                         f"{m['stations']:.1f} | {m['watch']:.1f} | {m['snapshots']:.1f} | {m['fields_gauges']:.1f} | "
                         f"{m['flush']:.1f} | {m['wall']:.0f} | **{m['loop_over_matmult']:.2f}** | "
                         f"{m['step_over_matmult']:.2f} | {loads} |")
        lines.append("")
    c1 = res.get("case1")
    if c1:
        sp = c1["median_split_s"]
        loads = ", ".join(f"{r['load_before']:.1f}" for r in c1["runs"])
        lines += [f"## Case I end to end, warm {_when(c1)}\n", f"`mpirun -n 2 fricfem run case1` (median of {len(c1['runs'])} "
                  f"after a warm-up): **{c1['median_wall_s']:.2f} s** (min {c1['min_wall_s']:.2f}): start-up "
                  f"{c1['median_startup_s']:.2f}, setup {sp['setup']:.2f}, time loop {sp['time_loop']:.2f}, output "
                  f"{sp['output']:.2f} s; loads {loads}.\n"]
    st = res.get("startup")
    if st:
        lines += [f"## Start-up {_when(st)}\n", f"Import time of a serial `fricfem run` (`python -X importtime`, self time by "
                  f"package, median of runs; {st['imports_total_s']:.2f} s in all):\n",
                  "| package | [s] | share |", "|---|---|---|"]
        for k, v in st["imports_s"].items():
            lines.append(f"| {k} | {v:.3f} | {100 * v / st['imports_total_s']:.0f} % |")
        lines.append(f"\nNot imported by a run: {', '.join(st['modules_not_imported'])}. `import gmsh` alone "
                     f"(which dolfinx's gmshio pulled in, now avoided): {st['import_gmsh_alone_s']:.2f} s; `python -c "
                     f"pass` {st['python_pass_s']:.2f} s; `mpirun -n 2 python -c 'from mpi4py import MPI'` "
                     f"{st['mpirun2_mpi4py_s']:.2f} s.\n")
        g = st.get("ghost_lists")
        if g:
            lines.append(f"Setting up the mesh: the partitioner's ghost lists for the {g['cells']:,} cells of the "
                         f"reference mesh on {g['parts']} parts took {g['loop_s']:.3f} s as the per-cell loop used "
                         f"before and {g['numpy_s']:.4f} s now (same output: {g['same_output']}; load {g['load']:.1f})."
                         "\n")
    fl = res.get("floors")
    if fl:
        sp = fl["probe_split_s"]
        lines += [f"## Floors {_when(fl)}\n",
                  "What Case I's warm end-to-end time on 2 ranks cannot go below, whatever the loop and the outputs "
                  "do (medians of the repeats):\n",
                  "| part | [s] |", "|---|---|",
                  f"| `mpirun -n 2 python -c 'from mpi4py import MPI'` (launcher, interpreter, MPI) | "
                  f"{fl['mpirun_mpi4py_s']:.2f} |",
                  f"| the same, importing the {len(fl['modules'])} modules fricfem imports by name in a run (with what they "
                  f"import) | "
                  f"{fl['imports_s']:.2f} |",
                  f"| the kernels' (numba) and forms' (ffcx) cache loads, warm | {fl['cache_loads_s']:.2f} |"]
        if fl.get("step"):
            st = fl["step"]
            lines += [f"| Case I's {fl['steps']} steps × a bare MatMult ({st['matmult_us']:.0f} µs) | "
                      f"{fl['steps_x_matmult_s']:.2f} |",
                      f"| **floor** (imports + cache loads + steps × MatMult) | **{fl['floor_s']:.2f}** |"]
        lines.append("\nThe probe's split of the same run (JIT separated; mean over ranks): "
                     + ", ".join(f"{k} {v:.2f}" for k, v in sp.items()) + " s.\n")
        if fl.get("step"):
            st = fl["step"]
            parts = ", ".join(f"{k} {v / st['matmult_us']:.2f}" for k, v in st["parts_us"].items())
            lines.append(f"The step in sliding (`step_vs_matmult.py povirk_needleman`, 2 ranks): {st['step_us']:.0f} µs "
                         f"= {st['step_us'] / st['matmult_us']:.2f} × MatMult; its parts (slowest rank) × MatMult: "
                         f"{parts} ({_load(st)}).\n")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--full", type=Path, help="the full 32 × 32 map's sweep directory (else results/modemap_full32.json)")
    ap.add_argument("--only", default="map8,adaptive,case1,loop,startup,floors",
                    help="parts to run, comma-separated (also 'full': only read the full map of --full)")
    ap.add_argument("--full-load", type=Path, help="load averages logged while the full map ran (one line a minute)")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--coarse", type=int, default=5, help="the adaptive map's first grid, values per axis")
    ap.add_argument("--warm-repeats", type=int, default=5)
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "sweep_speed", help="scratch sweep directories")
    ap.add_argument("--smoke", action="store_true", help="a 2 × 2 coarse map and the start-up, into results/smoke/")
    ap.add_argument("--commit", help="what code ran, for the record (default: git describe of the repository)")
    args = ap.parse_args(argv)
    global RESULTS
    if args.smoke:
        RESULTS = HERE / "results" / "smoke"
        args.only = "map8,startup"
    RESULTS.mkdir(parents=True, exist_ok=True)
    parts = set(args.only.split(","))
    commit = args.commit or subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True,
                                           text=True).stdout.strip()
    name = "sweep_speed"
    # the parts not run now are kept from the last run, each with its own date and code
    old = RESULTS / f"{name}.json"
    res = json.loads(old.read_text()) if old.is_file() and not args.smoke else {}
    import fricfem

    stamp = {"date": time.strftime("%Y-%m-%d %H:%M"), "commit": commit, "cpus": os.cpu_count(),
             "ranks": args.ranks, "code": str(Path(fricfem.__file__).parent)}
    res.update(stamp)
    def save():  # after every part: a later part's failure keeps the earlier ones
        (RESULTS / f"{name}.json").write_text(json.dumps(res, indent=1, default=str))
        (RESULTS / f"{name}.md").write_text(markdown(res))

    if "map8" in parts:
        res["map8"] = {**map8(args.work, args.ranks, args.smoke), **stamp}
        save()
    if "full" in parts or "adaptive" in parts:
        res["full32"] = full_map(args.full, args.full_load)
        if args.full is not None and res["full32"] is not None:
            res["full32"]["recheck"] = recheck(args.full, args.work)
        save()
    if "adaptive" in parts:
        res["adaptive"] = {**adaptive(args.work, args.ranks, res["full32"], args.coarse), **stamp}
        save()
    if "case1" in parts:
        res["case1"] = {**case1(args.work, args.ranks, args.warm_repeats), **stamp}
        save()
    if "loop" in parts:
        res["loop"] = {**loop(args.work, args.ranks, 3), **stamp}
        save()
    if "startup" in parts:
        res["startup"] = {**startup(args.work, args.smoke), **stamp}
        save()
    if "floors" in parts:
        res["floors"] = {**floors(args.work, args.ranks, args.smoke), **stamp}
    (RESULTS / f"{name}.json").write_text(json.dumps(res, indent=1, default=str))
    (RESULTS / f"{name}.md").write_text(markdown(res))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
