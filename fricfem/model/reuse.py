"""One model for many scenes: what a batch of scenes on the same mesh shares.

A mode map runs dozens to hundreds of scenes that differ only in the loading
and the friction (Σ0, V_imp, a law's parameters).  Their models differ only
in the interface points (tractions, state, parameters), the law and the load;
the mesh, K, the lumped mass, the grid numbering, the interface geometry and
its scatters, λmax and dt, and the fused step's rows and scatters are the
same.  :func:`model_key` is the part of a scene that defines those;
:class:`ModelCache` builds the first model of a key in full and every later
scene of the key with ``build_model(scene, comm, like=...)``, which makes only
the new points, law and load.

Exact by construction: a model is read-only once built (its numpy arrays are
marked so; the scatters' work vectors are scratch, overwritten before being
read in every step) and everything a run changes is its
:class:`fricfem.step.State`, so nothing is reset between runs: a scene of the
same key gets the shared parts as they are, with its own interface points'
constants, law and load, and λmax depends only on the key (K, the mass and
the interface springs C_n, C_s).  A reused model gives the same bits as a
fresh one (``tests/test_model_reuse.py``), and a model stepped by any number
of runs keeps its bits (``tests/test_state.py``).

    cache = ModelCache()
    for scene in scenes:                          # same communicator, one run at a time
        run_scene(scene, out, comm, build=cache.build)
"""

from __future__ import annotations

import collections
import gc
import json

from .build import build_model, impact_tags


#: Scene keys (section -> keys; "*" every key of the section) that only the
#: interface points, the law, the load or the run's own bookkeeping depend on:
#: scenes may differ in these and share one model.  Every other key of a
#: scene's tables is part of :func:`model_key` (so a key added to the schema
#: later counts as model-defining until it is listed here).
PER_SCENE = {
    "": ("name", "description", "base"),
    "loading": ("sigma0", "v_imp", "t_rise", "t_hold_end", "t_fall", "direction", "impedance"),
    "interface": ("tau0", "patches"),
    "friction": "*",
    "time": ("end", "skip_quiet", "stop_at_tip", "allow_unstable_dt"),
    "watchdog": "*",
    "output": "*",
}


def _defining_tables(raw: dict) -> str:
    """The scene's tables without the :data:`PER_SCENE` keys, as canonical JSON."""
    out = {}
    for sec, value in raw.items():
        if isinstance(value, dict):
            skip = PER_SCENE.get(sec, ())
            if skip == "*":
                continue
            kept = {k: v for k, v in value.items() if k not in skip}
            if kept:
                out[sec] = kept
        elif value is not None and sec not in PER_SCENE[""]:
            out[sec] = value
    return json.dumps(out, sort_keys=True, default=str)


def model_key(scene) -> tuple:
    """The part of a scene that defines its mesh and assembled parts (hashable):
    every table entry but the :data:`PER_SCENE` ones, and what follows from
    them — the mesh definition, material, interface kind and stiffnesses
    (λmax includes the springs), the struck edges (none without an impact) and
    whether the load is a prescribed velocity (the special rows; the rigid
    interface's pairs), the step (fixed, or the safety factor on the stable
    step), the absorbing edges and a Kelvin–Voigt layer."""
    return (scene.mesh, scene.material, scene.interface_kind, float(scene.Cn), float(scene.Cs),
            scene.dt, scene.dt_safety if scene.dt is None else None, tuple(scene.absorbing),
            impact_tags(scene), bool(scene.pulse.prescribed), float(scene.damping_eta), float(scene.damping_width),
            _defining_tables(scene.raw))


class ModelCache:
    """Models by :func:`model_key`, for scenes run one after another on one
    communicator (the few most recent keys are kept; ``size``).

    :meth:`build` has the signature of :func:`fricfem.model.build.build_model`
    and is collective in the same way (every rank of the communicator asks for
    the same scenes in the same order, so every rank hits or misses alike).
    """

    def __init__(self, size: int = 3):
        if size < 1:
            raise ValueError(f"ModelCache(size={size}): must be >= 1")
        self.size = size
        self.comm = None
        self._models = collections.OrderedDict()  # key -> (plate mesh, model) built in full
        self.hits = 0
        self.misses = 0

    def build(self, scene, comm) -> tuple:
        """``(plate mesh, model)`` of ``scene`` on ``comm``: reused parts when a
        model of the same key was built on the same communicator."""
        if self.comm is not comm:
            self.clear()
            self.comm = comm
        key = model_key(scene)
        base = self._models.get(key)
        if base is None:
            self.misses += 1
            base = build_model(scene, comm)
            self._models[key] = base
            while len(self._models) > self.size:
                self._models.popitem(last=False)
                # a batch freezes what survives each job (fricfem.batch._free): let the
                # next collection look at everything again, so the dropped model goes
                gc.unfreeze()
            return base
        self.hits += 1
        self._models.move_to_end(key)
        return build_model(scene, comm, like=base)

    def clear(self) -> None:
        """Forget every model (their PETSc objects go with the next garbage collection)."""
        if self._models:
            gc.unfreeze()  # as for a dropped model (build)
        self._models.clear()
        self.comm = None

    def __len__(self) -> int:
        return len(self._models)
