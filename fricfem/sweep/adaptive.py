"""The adaptive mode map: ``fricfem sweep --adaptive``.

The grid given (``--sigma0``, ``--v-imp``, e.g. ``0.9:40:32`` and ``1:40:32``)
is the finest resolution.  The map starts from a coarse grid of ``--coarse``
values per axis (both ends included) and refines in rounds: a cell whose
labelled points — its corners, and any point on its sides labelled for a
neighbour — carry more than one label is bisected in log Σ0 and in log V_imp
(at the middle index of each side); its centre is computed in the next round,
and so is the midpoint of each side whose two ends differ (the side is
bisected), while the midpoint of a side whose ends agree takes their label
(a side is taken to hold no boundary when its ends agree).  Cells whose
points all agree stay as they are.  It ends when no cell needs refining
(every cell left is uniform, or one interval of the finest grid wide).  Each
point neither computed nor taken from its side gets the label of the uniform
cell it lies in (:func:`fricfem.analysis.modemap.refine`, ``fill``).

A round is an ordinary batch of scenes (:func:`.rounds.run_round`): the
points are the same scenes, in the same directories, as the full map's, so a
stopped adaptive map resumes like any sweep (complete points are reused, the
rounds replay to where it stopped), and the refinement is deterministic.  If
a round leaves a point incomplete (a failed or interrupted run) the
refinement stops there: the map is written with that point unlabelled and
the command exits 1; rerun to resume.

What it can miss: a region that touches no labelled point of a cell (an
island inside a uniform cell), or that crosses a side twice between two
agreeing ends (a thin band).  On the 32 × 32 map of case1 this rule took 203
scenes and agreed with the full map on 99.3 % of the points, against 363
scenes and 99.8 % when every new corner is computed (both simulated on the
full map's labels of the time); run on the full map as it is now, it took 189
scenes and agreed on 99.3 % (``benchmarks/sweep_speed.py`` runs the adaptive
map and compares it with the full one computed once).
"""

from __future__ import annotations

from ..analysis.modemap import coarse_cells, fill, refine
from .planning import VARIANTS
from .records import point_label
from .rounds import run_round

#: Rounds at most (each halves the cells' sides: 2 log2(MAX_AXIS) is plenty).
MAX_ROUNDS = 32


def _start(maps: list, ni: int, nj: int, coarse: tuple) -> dict:
    """Rank 0: per map its leaf cells, the known labels {(i, j): label} and the
    points per round."""
    return {m: {"cells": coarse_cells(ni, nj, *coarse), "known": {}, "guessed": {}, "rounds": []} for m in maps}


def _first(state: dict) -> dict:
    return {m: sorted(set().union(*(c.corners() for c in st["cells"]))) for m, st in state.items()}


def run_adaptive(pool, spec: dict, log, coarse: tuple) -> tuple:
    """Run the rounds (collective on ``pool.comm``): ``(maps, points, results,
    refined)``; ``refined`` {map: {"labels", "computed", "coarse", "rounds",
    "scenes", "finished"}} and results on rank 0 (None elsewhere)."""
    comm = pool.comm
    ni, nj = len(spec["sigma0"]), len(spec["v_imp"])
    state = select = None
    if comm.rank == 0:
        state = _start([""] + (list(VARIANTS) if spec["variants"] else []), ni, nj, coarse)
        select = _first(state)
    points, results, maps, stopped = {}, [], None, False
    for rnd in range(MAX_ROUNDS):
        select = comm.bcast(select, root=0)
        if not any(select.values()):
            break
        maps, new, _, res = run_round(pool, spec, log, select, note=f"adaptive round {rnd + 1}: ")
        for p in new:
            points[(p.map, p.ij)] = p
        if comm.rank != 0:
            continue
        results += res
        labels = {(p.map, p.ij): point_label(p) for p in new}
        for m, st in state.items():
            st["known"].update({ij: lab for (mm, ij), lab in labels.items() if mm == m})
            st["rounds"].append(sum(1 for mm, _ in labels if mm == m))
        if any(lab is None for lab in labels.values()):  # failed or interrupted: stop, rerun resumes
            stopped = True
            select = {}
            log("adaptive: a point of this round is incomplete; the refinement stops here (rerun to resume)")
            continue
        select = {}
        for m, st in state.items():
            st["cells"], select[m] = refine(st["cells"], st["known"], st["guessed"])
    refined = None
    if comm.rank == 0:
        refined = {}
        for m, st in state.items():
            labels, computed = fill(ni, nj, st["cells"], st["known"], st["guessed"])
            refined[m] = {"labels": labels, "computed": computed, "coarse": list(coarse),
                          "rounds": [r for r in st["rounds"] if r], "scenes": len(st["known"]),
                          "from_sides": len(st["guessed"]), "finished": not stopped,
                          "method": "coarse grid, then cells whose labelled points differ bisected in log Σ0 and "
                                    "log V_imp down to the finest grid: the centre computed, a side's midpoint "
                                    "computed when its ends differ, else given their label ('from_sides'); the "
                                    "other points take their uniform cell's label"}
    return maps, list(points.values()), results if comm.rank == 0 else None, refined
