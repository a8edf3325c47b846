# # The spectral elements' K u: matrix-free (sum-factorized) against assembled
#
# For p = 2..6, on one GLL lattice of the same node count for every degree (a
# 0.2 m × 0.1 m rectangle cut into (S/p) × (S/p) elements: (S+1)² nodes,
# S = --side, default 540: 292 681 nodes, 585 362 dofs), one material, the
# nodes numbered along x1 first and the elements in the same order:
#
# - mf:   fricfem.kernels.sem.element_ku (the production kernel, one call a
#         product; serial, no threads), and, when the module has one kernel a
#         degree (KERNELS), "mf generic": the same body compiled once for every
#         degree with p + 1 a run-time value (what the specialisation buys);
#         "mf moduli/el": the production kernel with λ, μ one an element (what
#         several materials cost);
# - bcsr: the same operator assembled from sem.element_blocks into 2×2 block
#         rows (the fused step's layout: uint32 ptr/col, 4 values a block) and
#         multiplied by a numba loop over the rows with fricfem.kernels.bulk's
#         row kernel (_row: what the sweep does for K u on the linear triangles);
# - aij:  PETSc's MatMult of the same matrix as scalar AIJ (createAIJ with csr,
#         USE_INODES off as fricfem.model.assembly does), one process.
#
# Timing: each method's mean over a loop of calls (≥ ~0.2 s), the loops of all
# methods interleaved, the best of --repeats rounds; ratios against the bare AIJ
# MatMult of the same run.  The three products are checked equal (relative to
# max |K u|) before timing.  Counts: nnz (scalar) of K, flops as coded (AIJ 2 nnz;
# mf per element (p+1)² (20 (p+1) + 19)), bytes of the data streamed (AIJ 12 nnz
# + 4 (rows + 1); bcsr 36 nnzb; mf 8 (p+1)² + 16 an element) plus x and y.
#
# Instruction counts (when valgrind is on the path and --callgrind-side > 0):
# the script reruns itself under callgrind with instrumentation off, on a
# smaller lattice (--callgrind-side, default 120), and turns it on only around
# --callgrind-calls products of each method (client requests through a small C
# helper compiled on the fly); Ir per call / dof.
#
# Run: `.venv/bin/python benchmarks/sem_operator.py` (writes
# benchmarks/results/sem_operator.{json,md}; `--out ''` writes nothing).

from __future__ import annotations

import argparse
import ctypes
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from petsc4py import PETSc

from fricfem.kernels import bulk
from fricfem.kernels import sem as sem_kernels
from fricfem.model import sem

ROOT = Path(__file__).resolve().parent.parent
LX, LY = 0.2, 0.1  # [m]: hx = 2 hy
LMBDA, MU = 5.48e9, 1.94e9  # [Pa]


def lattice(side: int, p: int):
    """Element nodes int64[n_el, (p+1)²] (node j (p+1) + i: GLL index i along x1,
    j along x2), hx, hy float64[n_el] of the (side/p)² elements of LX × LY;
    nodes numbered along x1 first; (side+1)² nodes."""
    ne = side // p
    n1, nx = p + 1, side + 1
    I, J = np.meshgrid(np.arange(ne), np.arange(ne), indexing="xy")
    i, j = np.meshgrid(np.arange(n1), np.arange(n1), indexing="xy")
    nodes = ((J.ravel()[:, None] * p + j.ravel()[None, :]) * nx + I.ravel()[:, None] * p + i.ravel()[None, :])
    return nodes.astype(np.int64), np.full(ne * ne, LX / ne), np.full(ne * ne, LY / ne)


@numba.njit(cache=True)
def _assemble(nodes, which, blocks, n_nodes):
    """Block CSR (ptr uint32[n+1], col uint32, val float64[4 nnzb]) of Σ_e the
    element blocks ``blocks[which[e]]`` (float64[m, nn, nn, 4]); each row's
    columns increasing, its blocks summed over its elements in list order."""
    n_el, nn = nodes.shape
    cnt = np.zeros(n_nodes + 1, dtype=np.int64)  # node -> elements (CSR, list order)
    for e in range(n_el):
        for a in range(nn):
            cnt[nodes[e, a] + 1] += 1
    inc_ptr = np.cumsum(cnt)
    fill = inc_ptr[:-1].copy()
    inc_el = np.empty(inc_ptr[-1], dtype=np.int64)
    inc_loc = np.empty(inc_ptr[-1], dtype=np.int64)
    for e in range(n_el):
        for a in range(nn):
            r = nodes[e, a]
            inc_el[fill[r]] = e
            inc_loc[fill[r]] = a
            fill[r] += 1
    mark = np.full(n_nodes, -1, dtype=np.int64)
    ptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for r in range(n_nodes):
        c = 0
        for q in range(inc_ptr[r], inc_ptr[r + 1]):
            e = inc_el[q]
            for b in range(nn):
                s = nodes[e, b]
                if mark[s] != r:
                    mark[s] = r
                    c += 1
        ptr[r + 1] = ptr[r] + c
    col = np.empty(ptr[-1], dtype=np.uint32)
    val = np.zeros(4 * ptr[-1])
    pos = np.empty(n_nodes, dtype=np.int64)
    mark[:] = -1
    for r in range(n_nodes):
        c = ptr[r]
        for q in range(inc_ptr[r], inc_ptr[r + 1]):
            e = inc_el[q]
            for b in range(nn):
                s = nodes[e, b]
                if mark[s] != r:
                    mark[s] = r
                    col[c] = s
                    c += 1
        col[ptr[r]:ptr[r + 1]] = np.sort(col[ptr[r]:ptr[r + 1]])
        for k in range(ptr[r], ptr[r + 1]):
            pos[col[k]] = k
        for q in range(inc_ptr[r], inc_ptr[r + 1]):
            e = inc_el[q]
            a = inc_loc[q]
            blk = blocks[which[e]]
            for b in range(nn):
                k = 4 * pos[nodes[e, b]]
                for t in range(4):
                    val[k + t] += blk[a, b, t]
    return ptr.astype(np.uint32), col, val


@numba.njit(cache=True)
def _aij(ptr, col, val):
    """The scalar CSR (indptr, indices int32, data) of the block rows: row 2 I + c
    holds, block by block, (K_c0, K_c1) at columns 2 J, 2 J + 1."""
    n = ptr.size - 1
    nnzb = ptr[n]
    indptr = np.empty(2 * n + 1, dtype=np.int32)
    indices = np.empty(4 * nnzb, dtype=np.int32)
    data = np.empty(4 * nnzb)
    indptr[0] = 0
    k = 0
    for r in range(n):
        for c in range(2):
            for q in range(ptr[r], ptr[r + 1]):
                indices[k] = 2 * col[q]
                indices[k + 1] = 2 * col[q] + 1
                data[k] = val[4 * q + 2 * c]
                data[k + 1] = val[4 * q + 2 * c + 1]
                k += 2
            indptr[2 * r + c + 1] = k
    return indptr, indices, data


@numba.njit(cache=True, _nrt=False)
def bcsr_mult(ptr, col, val, x, y):
    """y = K x over the block rows, with the fused sweep's row kernel."""
    for r in range(ptr.size - 1):
        s0, s1 = bulk._row(ptr, col, val, x, r)
        y[2 * r] = s0
        y[2 * r + 1] = s1


if hasattr(sem_kernels, "KERNELS"):  # one kernel a degree in fricfem: compare with one for all degrees
    @numba.njit(cache=True, _nrt=False)
    def mf_generic(nodes, hx, hy, lmbda, mu, D, w, u, ug, n_owned, f, scratch):
        """The production body with p + 1 a run-time value (one compilation for all p)."""
        sem_kernels._element_ku(nodes, hx, hy, lmbda, mu, D, w, D.shape[0], u, ug, n_owned, f, scratch)
else:
    mf_generic = None


def mf_flops(p: int, n_el: int) -> int:
    """Floating-point operations of the matrix-free product as coded: per node of
    an element 8 (p+1) (derivatives), 17 (weighted stresses), 12 (p+1) + 2
    (transposed products and the sum into f)."""
    n1 = p + 1
    return n_el * n1 * n1 * (20 * n1 + 19)


def setup(side: int, p: int) -> dict:
    """The lattice, its operators and the vectors of one degree."""
    nodes, hx, hy = lattice(side, p)
    n = (side + 1) ** 2
    blocks = sem.element_blocks(hx[:1], hy[:1], p, LMBDA, MU)  # one element shape: one set of blocks
    t0 = time.perf_counter()
    ptr, col, val = _assemble(nodes, np.zeros(len(nodes), dtype=np.int64), blocks, n)
    indptr, indices, data = _aij(ptr, col, val)
    A = PETSc.Mat().createAIJ((2 * n, 2 * n), csr=(indptr, indices, data), comm=PETSc.COMM_SELF)
    A.setOption(PETSc.Mat.Option.USE_INODES, False)
    A.assemble()
    t_asm = time.perf_counter() - t0
    nnz = int(indptr[-1])
    del indptr, indices, data
    D, w = sem.derivative(p).copy(), sem.gll(p)[1].copy()
    x = np.random.default_rng(p).standard_normal(2 * n)
    px, py = A.createVecRight(), A.createVecLeft()
    px.array[:] = x
    return dict(p=p, n=n, nodes=nodes, hx=hx, hy=hy, D=D, w=w, ptr=ptr, col=col, val=val, A=A, nnz=nnz,
                x=x, px=px, py=py, f=np.zeros(2 * n), y=np.zeros(2 * n), ug=np.zeros(0),
                scratch=np.zeros((3, p + 1, p + 1, 2)), t_assemble=t_asm)


def methods(c: dict) -> dict:
    """name -> one product (closures over the degree's data)."""
    args = (c["nodes"], c["hx"], c["hy"], LMBDA, MU, c["D"], c["w"], c["x"], c["ug"], c["n"], c["f"], c["scratch"])
    out = {"aij": lambda: c["A"].mult(c["px"], c["py"]),
           "bcsr": lambda: bcsr_mult(c["ptr"], c["col"], c["val"], c["x"], c["y"]),
           "mf": lambda: sem_kernels.element_ku(*args)}
    n_el = len(c["nodes"])
    per_element = args[:3] + (np.full(n_el, LMBDA), np.full(n_el, MU)) + args[5:]
    out["mf moduli/el"] = lambda: sem_kernels.element_ku(*per_element)
    if mf_generic is not None:
        out["mf generic"] = lambda: mf_generic(*args)
    return out


def check(c: dict, ms: dict) -> dict:
    """Each product against AIJ's: max |difference| / max |K x|."""
    for fn in ms.values():
        fn()
    ref = c["py"].array.copy()
    scale = float(np.abs(ref).max())
    out = {"bcsr": float(np.abs(c["y"] - ref).max()) / scale, "mf": float(np.abs(c["f"] - ref).max()) / scale}
    for name in ("mf generic", "mf moduli/el"):
        if name in ms:
            ms[name]()
            out[name] = float(np.abs(c["f"] - ref).max()) / scale
    return out


def timed(ms: dict, repeats: int, budget: float) -> dict:
    """Best mean seconds per call of each method, loops interleaved."""
    calls = {}
    for name, fn in ms.items():
        t0 = time.perf_counter()
        fn()
        calls[name] = max(3, int(budget / max(time.perf_counter() - t0, 1e-6)))
    best = dict.fromkeys(ms, float("inf"))
    for _ in range(repeats):
        for name, fn in ms.items():
            t0 = time.perf_counter()
            for _ in range(calls[name]):
                fn()
            best[name] = min(best[name], (time.perf_counter() - t0) / calls[name])
    return best


# ---------------------------------------------------------------- callgrind

HELPER_C = r"""
#include <valgrind/callgrind.h>
void cg_start(void) { CALLGRIND_START_INSTRUMENTATION; CALLGRIND_ZERO_STATS; }
void cg_stop(const char *label) { CALLGRIND_DUMP_STATS_AT(label); CALLGRIND_STOP_INSTRUMENTATION; }
"""


def callgrind_child(side: int, degrees, calls: int, lib_path: str) -> None:
    """Under callgrind (instrumentation off at start): instrument only ``calls``
    products of each method and dump them, labelled ``p<p>:<method>``."""
    lib = ctypes.CDLL(lib_path)
    for p in degrees:
        c = setup(side, p)
        ms = methods(c)
        for name, fn in ms.items():
            fn()  # compiled, caches loaded, outside the counts
            lib.cg_start()
            for _ in range(calls):
                fn()
            lib.cg_stop(f"p{p}:{name}".encode())
        c["A"].destroy()


def callgrind(side: int, degrees, calls: int) -> dict | None:
    """{p: {method: Ir per product}} measured under callgrind, or None without valgrind or a C compiler."""
    valgrind, cc = shutil.which("valgrind"), shutil.which("cc") or shutil.which("gcc")
    if valgrind is None or cc is None or not Path("/usr/include/valgrind/callgrind.h").exists():
        return None
    with tempfile.TemporaryDirectory() as tmp:
        src, lib = Path(tmp) / "cg.c", Path(tmp) / "libcg.so"
        src.write_text(HELPER_C)
        subprocess.run([cc, "-O1", "-shared", "-fPIC", "-o", str(lib), str(src)], check=True)
        cmd = [valgrind, "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={tmp}/cg.out",
               sys.executable, __file__, "--callgrind-child", str(lib), "--side", str(side),
               "--callgrind-calls", str(calls), "--degrees", *map(str, degrees)]
        env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONHASHSEED="0")
        run = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if run.returncode != 0:
            print(run.stderr[-3000:], file=sys.stderr)
            raise RuntimeError(f"callgrind run failed ({run.returncode})")
        out: dict = {}
        for f in Path(tmp).glob("cg.out.*"):
            text = f.read_text(errors="replace")
            m = re.search(r"^desc: Trigger: Client Request: (.+)$", text, re.M)
            tot = re.search(r"^(?:summary|totals): (\d+)", text, re.M)
            if m is None or tot is None or ":" not in m.group(1):
                continue
            pp, name = m.group(1).split(":", 1)
            out.setdefault(int(pp[1:]), {})[name] = int(tot.group(1)) / calls
        return out


# ---------------------------------------------------------------- main

#: the degrees of the committed table (2 to 6: a side of 540 intervals divides by each; 7 and 8 with
#: ``--degrees 7 8 --side 560``)
TABLE_DEGREES = (2, 3, 4, 5, 6)


def main(argv=None) -> dict:
    """Run the benchmark (``argv`` as the command line's); returns what the JSON holds."""
    ap = argparse.ArgumentParser(description="spectral elements: K u matrix-free against assembled")
    ap.add_argument("--side", type=int, default=540, help="lattice intervals a side (a multiple of every p)")
    ap.add_argument("--degrees", type=int, nargs="+", default=list(TABLE_DEGREES))
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--budget", type=float, default=0.2, help="seconds a timed loop")
    ap.add_argument("--callgrind-side", type=int, default=120, help="0: no instruction counts")
    ap.add_argument("--callgrind-calls", type=int, default=3)
    ap.add_argument("--callgrind-child", default="", help=argparse.SUPPRESS)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "sem_operator"))
    a = ap.parse_args(argv)
    for p in a.degrees:
        if p not in sem.DEGREES or a.side % p:
            raise SystemExit(f"sem_operator: --side {a.side} must be a multiple of every degree (p = {p}), "
                             f"degrees from {sem.DEGREES}")
    if a.callgrind_child:
        callgrind_child(a.side, a.degrees, a.callgrind_calls, a.callgrind_child)
        return {}

    load_start = os.getloadavg()[0]  # the machine is shared: how busy it was
    rows = []
    for p in a.degrees:
        c = setup(a.side, p)
        ms = methods(c)
        diff = check(c, ms)
        best = timed(ms, a.repeats, a.budget)
        n_el, n_dofs = len(c["nodes"]), 2 * c["n"]
        nnzb = int(c["ptr"][-1])
        vec_bytes = 16 * n_dofs  # x read, y written
        row = dict(p=p, nodes=c["n"], dofs=n_dofs, elements=n_el, nnz=c["nnz"], nnz_per_row=c["nnz"] / n_dofs,
                   flops_aij=2 * c["nnz"], flops_mf=mf_flops(p, n_el),
                   bytes_aij=12 * c["nnz"] + 4 * (n_dofs + 1) + vec_bytes, bytes_bcsr=36 * nnzb + vec_bytes,
                   bytes_mf=n_el * (8 * (p + 1) ** 2 + 16) + vec_bytes,
                   seconds={k: v for k, v in best.items()}, max_rel_diff_to_aij=diff,
                   ratio_to_aij={k: v / best["aij"] for k, v in best.items()},
                   ns_per_node={k: 1e9 * v / c["n"] for k, v in best.items()}, assemble_s=c["t_assemble"])
        rows.append(row)
        print(f"p={p}: {c['n']} nodes, {n_el} elements, nnz/row {row['nnz_per_row']:.1f}; "
              + ", ".join(f"{k} {1e3 * v:.2f} ms ({v / best['aij']:.3f})" for k, v in best.items())
              + f"; max rel diff {', '.join(f'{k} {v:.1e}' for k, v in diff.items())}", flush=True)
        c["A"].destroy()
        del c, ms

    load_end = os.getloadavg()[0]
    cg = None
    if a.callgrind_side > 0:
        cg_degrees = [p for p in a.degrees if a.callgrind_side % p == 0]
        print(f"callgrind: side {a.callgrind_side}, p = {cg_degrees} ...", flush=True)
        cg = callgrind(a.callgrind_side, cg_degrees, a.callgrind_calls)
        if cg is None:
            print("callgrind: valgrind, a C compiler or callgrind.h missing: no instruction counts")
        else:
            for p in sorted(cg):
                dofs = 2 * (a.callgrind_side + 1) ** 2
                print(f"p={p}: Ir per dof " + ", ".join(f"{k} {v / dofs:.1f}" for k, v in sorted(cg[p].items())))

    meta = dict(command="python benchmarks/sem_operator.py " + " ".join(sys.argv[1:] if argv is None else argv),
                side=a.side, repeats=a.repeats, budget_s=a.budget, lx_m=LX, ly_m=LY, lmbda_pa=LMBDA, mu_pa=MU,
                numba=numba.__version__, petsc=".".join(map(str, PETSc.Sys.getVersion())),
                machine=platform.processor() or platform.machine(), cpus=os.cpu_count(),
                date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                load_average_1min=[round(load_start, 2), round(load_end, 2)],
                callgrind_side=a.callgrind_side if cg else 0, callgrind_calls=a.callgrind_calls)
    if cg:
        meta["callgrind_dofs"] = 2 * (a.callgrind_side + 1) ** 2
    doc = dict(meta=meta, rows=rows, callgrind_ir_per_call=cg)
    if a.out:
        Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
        Path(a.out + ".md").write_text(markdown(meta, rows, cg))
        print(f"wrote {a.out}.json, {a.out}.md")
    return doc


def markdown(meta: dict, rows: list, cg: dict | None) -> str:
    names = list(rows[0]["seconds"])
    lines = ["# Spectral elements: K u matrix-free against assembled", "",
             f"`.venv/bin/python benchmarks/sem_operator.py` (method: its header; {meta['date']}, numba "
             f"{meta['numba']}, PETSc {meta['petsc']}, one process on a {meta['cpus']}-core machine shared with "
             f"other work, 1-minute load average {meta.get('load_average_1min', '?')} at the timings' start and "
             f"end). A {meta['lx_m']} m × {meta['ly_m']} m rectangle of {meta['side']} GLL intervals a side "
             f"for every p: {rows[0]['nodes']} nodes, {rows[0]['dofs']} dofs. Best of {meta['repeats']} "
             "interleaved loops; ratios against PETSc's AIJ MatMult of the same matrix in the same run "
             "(< 1: faster). mf: fricfem.kernels.sem.element_ku; bcsr: the assembled 2×2 block rows with "
             "the fused sweep's row kernel; max diff: relative to max |K x|.", "",
             "| p | elements | nnz/row | " + " | ".join(f"{k} [ms]" for k in names) + " | "
             + " | ".join(f"{k}/aij" for k in names if k != "aij") + " | mf ns/node | max diff mf | "
             "GFlop/s aij | GFlop/s mf | flops mf/aij | bytes mf/aij |",
             "|" + "---|" * (2 * len(names) + 8)]
    for r in rows:
        s = r["seconds"]
        lines.append(
            f"| {r['p']} | {r['elements']} | {r['nnz_per_row']:.1f} | "
            + " | ".join(f"{1e3 * s[k]:.2f}" for k in names) + " | "
            + " | ".join(f"{r['ratio_to_aij'][k]:.3f}" for k in names if k != "aij")
            + f" | {r['ns_per_node']['mf']:.1f} | {r['max_rel_diff_to_aij']['mf']:.1e} | "
            f"{r['flops_aij'] / s['aij'] / 1e9:.2f} | {r['flops_mf'] / s['mf'] / 1e9:.2f} | "
            f"{r['flops_mf'] / r['flops_aij']:.3f} | {r['bytes_mf'] / r['bytes_aij']:.3f} |")
    if cg:
        cnames = sorted({k for v in cg.values() for k in v})
        dofs = meta["callgrind_dofs"]
        lines += ["", f"Instructions (callgrind Ir) per dof of one product, lattice of {meta['callgrind_side']} "
                  f"intervals a side ({dofs} dofs), {meta['callgrind_calls']} products counted:", "",
                  "| p | " + " | ".join(cnames) + " | " + " | ".join(f"{k}/aij" for k in cnames if k != "aij")
                  + " |", "|" + "---|" * (1 + 2 * len(cnames) - 1)]
        for p in sorted(cg):
            v = cg[p]
            lines.append(f"| {p} | " + " | ".join(f"{v[k] / dofs:.1f}" for k in cnames) + " | "
                         + " | ".join(f"{v[k] / v['aij']:.3f}" for k in cnames if k != "aij") + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
