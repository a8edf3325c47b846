"""A read-only model and one state (fricfem/step/state.py): stepping leaves every
array of the model unchanged, two states of one model give the same bits, and a
state restored from its snapshot steps on with the same bits.  Run under
``mpirun -n 2`` (and on one rank)."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from mpi4py import MPI

from fricfem import load_scene
from fricfem.model.build import build_model
from fricfem.step import State, evolve, run

#: scenes by what they exercise: the elastic interface (Povirk–Needleman), the
#: rigid one (slip weakening), rate and state (aging), the experiment's bodies (contact)
SCENES = {
    "elastic": ("case3", ["mesh.preset='coarse'", "output.fields=[]"]),
    "rigid": ("rupture_sw", ["mesh.preset='coarse'", "interface.kind='rigid'", "output.fields=[]"]),
    "rate_state": ("rsf_aging_2d", ["mesh.dx=1e-3", "mesh.dy=1e-3", "output.fields=[]"]),
    "bodies": ("experiment_42", ["mesh.preset='coarse'", "output.fields=[]"]),
    "spectral": ("tpv205_2d", ["mesh.degree=3", "mesh.dx=1.6e-3", "mesh.dy=1.6e-3", "output.fields=[]"]),
    "spectral_elastic": ("tpv205_2d", ["mesh.degree=3", "mesh.dx=1.6e-3", "mesh.dy=1.6e-3", "output.fields=[]",
                                       "interface.kind='elastic'"]),
}

#: arrays of the model that a step writes as scratch, before it reads them
#: (path suffixes of :func:`model_arrays`): K u at the interface rows, the gathered
#: off-rank displacements, the rigid pairs' slot for this step's edge velocity, the
#: spectral elements' K u and their kernel's work space
SCRATCH = (".sp_ku", ".ug", ".fk", ".scratch")


def model_arrays(obj, path="model", seen=None) -> dict:
    """Every numpy array reachable from the model ``obj`` (its fields, NamedTuples,
    tuples, and the attributes of fricfem's own objects), by path; PETSc and
    dolfinx objects are not walked (their vectors are the step's scratch)."""
    seen = set() if seen is None else seen
    out = {}
    if id(obj) in seen:
        return out
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        out[path] = obj
        return out
    if isinstance(obj, tuple) and hasattr(obj, "_fields"):
        items = zip(obj._fields, obj)
    elif isinstance(obj, (tuple, list)):
        items = ((str(k), v) for k, v in enumerate(obj))
    elif type(obj).__module__.startswith("fricfem") and hasattr(obj, "__dict__"):
        items = vars(obj).items()
    else:
        return out
    for name, value in items:
        out.update(model_arrays(value, f"{path}.{name}", seen))
    return out


def digests(model) -> dict:
    """SHA-256 of every model array but the scratch ones (the rigid pairs' ``edge``
    without its last slot, this step's edge velocity)."""
    out = {}
    for path, a in model_arrays(model).items():
        if path.endswith(SCRATCH):
            continue
        data = a[:-1] if path.endswith(".geometry.edge") else a
        out[path] = hashlib.sha256(np.ascontiguousarray(data).tobytes()).hexdigest()
    return out


def same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def same_snapshots(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(same_bits(a[k], b[k]) for k in a)


def everywhere(comm, ok: bool) -> bool:
    return bool(comm.allreduce(int(ok), op=MPI.MIN))


def _model(kind, comm):
    name, overrides = SCENES[kind]
    scene = load_scene(name, overrides)
    return scene, build_model(scene, comm)[1]


def _state(scene, model):
    st = State(model, skip_quiet=scene.skip_quiet)
    if model.bodies is not None:  # the projectile moves at t = 0
        from fricfem.model.bodies import launch

        launch(model, st)
    return st


def _step(model, st, steps: int) -> None:
    for _ in evolve(model, st, st.t + steps * model.dt + 0.5 * model.dt, energy_every=7):
        pass


@pytest.mark.parametrize("kind", list(SCENES))
def test_stepping_leaves_the_model_unchanged_and_two_states_agree(comm, kind):
    """Two states of one model, the second stepped after the first and then both in
    turn: every model array keeps its bits, and the two states have the same bits
    at every point (nothing of a run is kept in the model).  The model's arrays
    are read-only."""
    scene, model = _model(kind, comm)
    before = digests(model)
    arrays = model_arrays(model)
    assert before and any(p.endswith(".initial.param_rows") for p in arrays)
    # every array is read-only but the step's scratch, written before it is read in every step: K u at the
    # interface rows, the gathered off-rank displacements, the rigid pairs' slot for the step's edge velocity,
    # a Kelvin–Voigt layer's force (empty without one), the spectral elements' K u and their kernel's work space
    scratch = (".bulk.sp_ku", ".bulk.ug", ".geometry.edge", ".bulk.fd", ".bulk.fk", ".bulk.scratch")
    assert [p for p, a in arrays.items() if a.flags.writeable and not p.endswith(scratch)] == []
    a = _state(scene, model)
    _step(model, a, 60)
    after_a = a.snapshot()
    assert everywhere(comm, digests(model) == before), "a run changed the model"
    b = _state(scene, model)
    _step(model, b, 60)
    assert everywhere(comm, same_snapshots(after_a, b.snapshot())), "a second state of the model differs"
    for _ in range(3):  # in turn: a state's step sees nothing of the other's
        _step(model, a, 5)
        _step(model, b, 5)
    assert everywhere(comm, same_snapshots(a.snapshot(), b.snapshot()))
    assert everywhere(comm, digests(model) == before)
    moved = comm.allreduce(float(np.abs(a.u.array_r).max(initial=0.0)), op=MPI.MAX)
    assert moved > 0
    if kind == "bodies":
        assert a.contact is not None and comm.allreduce(float(np.abs(a.contact.Tn).max(initial=0.0)),
                                                       op=MPI.MAX) > 0  # the projectile struck


@pytest.mark.parametrize("kind", list(SCENES))
def test_a_restored_state_steps_on_with_the_same_bits(comm, kind):
    """A state stepped 50 steps, snapshot, 40 more; a new state of the same model
    restored from the snapshot and stepped 40: the same bits everywhere (u, v, t,
    n, the interface's and the contact's points, the memories, the rows awake)."""
    scene, model = _model(kind, comm)
    a = _state(scene, model)
    _step(model, a, 50)
    saved = a.snapshot()
    _step(model, a, 40)
    b = State(model)
    b.restore(saved)
    assert b.n == 50 and b.t == saved["t"]
    _step(model, b, 40)
    assert a.n == b.n == 90
    assert everywhere(comm, same_snapshots(a.snapshot(), b.snapshot()))
    sliding = comm.allreduce(int(np.count_nonzero(a.points.slip_rate > 0)))
    assert sliding > 0 or kind == "bodies", "the interface should slide by then"


def test_restore_names_what_does_not_fit(comm):
    scene, model = _model("elastic", comm)
    st = State(model)
    saved = st.snapshot()
    with pytest.raises(ValueError, match=r"'points.slip' is float64\[3\], this state's float64\["):
        st.restore({**saved, "points.slip": np.zeros(3)})
    missing = dict(saved)
    del missing["t"]
    with pytest.raises(ValueError, match="'t' is missing"):
        st.restore(missing)


class _Counting:
    """A communicator that counts its Allreduce calls (the rest goes to ``comm``)."""

    def __init__(self, comm):
        self.comm = comm
        self.allreduces = 0

    def Allreduce(self, *args, **kwargs):
        self.allreduces += 1
        return self.comm.Allreduce(*args, **kwargs)

    def __getattr__(self, name):
        return getattr(self.comm, name)


def test_the_loop_reduces_once_a_step_whatever_its_observers(comm):
    """The observers that need global values (the interface's look, the watchdog, the
    signals, a flusher's wall clock) share the loop's one MAX-Allreduce a step in
    named slots: N steps, N reductions; the stop reasons and the slots' values as
    one reduction per observer would give them."""
    from fricfem import observe

    scene, model = _model("rigid", comm)
    counting = _Counting(comm)
    model = model._replace(comm=counting)
    st = State(model)
    look = observe.Look(model.interface.geometry.x1)
    watchdog = observe.Watchdog(model, scene.watchdog, look, 0)
    tip = observe.Tip(look, stop_at=0.0)
    with observe.Signals() as signals:
        stop = run(evolve(model, st, 40 * model.dt, 0, [look, watchdog, tip, signals]))
    assert stop is None and st.n == 40
    assert counting.allreduces == 40
    # the tip over all ranks: what a reduction of its own gives
    mine = st.points.slip_rate > 0
    tip_own = comm.allreduce(float(model.interface.geometry.x1[mine].max(initial=-1.0)), op=MPI.MAX)
    assert look.tip == tip_own and (tip_own > 0) == (len(tip.tip_x) > 0)
    assert watchdog.stopped is None and watchdog.diverged is None
