"""Friction regions in ``interface.h5``: which ``friction.regions`` entry holds each
interface point, and the entries themselves.

``regions/index`` int16[n_point] — the index k of the ``friction.regions[k]``
entry whose [x1_min, x1_max] holds the point (the rule the model applies:
:func:`fricfem.model.build.param_field`), −1 for a point in none (the scene's
``friction.params``); the points are those of ``x1``, in its order.  Its
attributes: ``x1_min``, ``x1_max`` [m] float64[n_regions] and ``params``, each
entry's parameter overrides as JSON.  (A group of its own: the file's root
datasets other than ``x1`` are rows in time.)
"""

from __future__ import annotations

import json

import numpy as np

REGION = "regions/index"


def region_index(regions, x1) -> np.ndarray:
    """int16[n]: the ``regions`` entry holding each point of ``x1`` [m], −1 for none
    (entries do not overlap: scene validation; the last one wins if they did)."""
    x1 = np.asarray(x1, dtype=np.float64)
    out = np.full(len(x1), -1, dtype=np.int16)
    for k, reg in enumerate(regions):
        out[(x1 >= reg["x1_min"]) & (x1 <= reg["x1_max"])] = k
    return out


def write_regions(f, regions, x1) -> None:
    """Write the ``regions/index`` dataset of the points ``x1`` (sorted as in the file) into
    the open h5py file ``f`` (once, when the file is laid out)."""
    d = f.create_dataset(REGION, data=region_index(regions, x1))
    d.attrs.update(unit="", meaning="index k of the friction.regions[k] entry holding the point, -1: none",
                   x1_min=np.array([r["x1_min"] for r in regions], dtype=np.float64),
                   x1_max=np.array([r["x1_max"] for r in regions], dtype=np.float64),
                   params=json.dumps([r.get("params", {}) for r in regions]))


def region_spans(f, x1) -> list:
    """[(k, x_a, x_b, params), ...]: each friction region of the file ``f`` (an h5py
    file holding ``regions/index``) as the span of the points it holds [m];
    [] when the file has no regions."""
    if REGION not in f:
        return []
    idx = np.asarray(f[REGION][...])
    try:
        params = json.loads(f[REGION].attrs.get("params", "[]"))
    except (TypeError, ValueError):
        params = []
    out = []
    for k in np.unique(idx[idx >= 0]):
        held = np.flatnonzero(idx == k)
        out.append((int(k), float(x1[held].min()), float(x1[held].max()),
                    params[k] if k < len(params) else {}))
    return out
