"""fricfem — dynamic frictional sliding between two elastic plates under shear impact.

Explicit finite elements (dolfinx/PETSc) for the bulk, one numba kernel for the
rate- and state-dependent frictional interface, after Coker, Lykotrafitis,
Needleman & Rosakis, *Frictional sliding modes along an interface between
identical elastic plates subject to shear impact loading*, J. Mech. Phys.
Solids 53 (2005) 884–922.

The Python API (docs/api.md; a tour: demos/api_tour.py):

    scene = fricfem.load_scene("case3", ["loading.v_imp=40"])   # validated, before any heavy work
    summary = fricfem.run(scene, "runs/c3v40")                   # the run directory; its summary
    run = fricfem.open_run("runs/c3v40")                         # arrays with units
    run.slip_rate, run.t, run.x1, run.units["slip_rate"], run.gauges
    fricfem.register_law(my_law)                                 # a friction law of your own

Importing fricfem loads nothing heavy; each function imports what it needs, inside it
(start-up time: the imports there are the only ones of the package, on purpose).
"""

__version__ = "0.1.0"


def _ranks() -> int:
    """The job's rank count as mpirun tells it (without initialising MPI)."""
    # here, not at the top: fricfem's namespace is its API alone (see the docstring)
    import os

    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"):
        value = os.environ.get(var, "")
        if value.isdigit():
            return int(value)
    return 1


def _end_job_on_uncaught() -> None:
    """On more than one rank, an exception no one catches ends the whole job: one line
    naming the rank, then ``MPI_Abort`` (otherwise the other ranks wait forever in
    their next collective: a law registered on one rank only, then ``load_scene``
    raising on the others).  Installed by the API's entry points; a hook of the
    user's own (anything but Python's default) is left alone."""
    # here, not at the top: fricfem's namespace is its API alone (see the docstring)
    import sys

    if _ranks() <= 1 or sys.excepthook is not sys.__excepthook__:
        return

    def hook(kind, value, tb):
        # lazy: start-up time (import fricfem loads no MPI, dolfinx, numba or h5py)
        from mpi4py import MPI

        if issubclass(kind, ValueError):  # SceneError and the other bad-input errors: their one line
            what = f"{kind.__name__}: {value}"
        else:
            sys.__excepthook__(kind, value, tb)
            what = f"{kind.__name__}: {' '.join(str(value).split())}"
        comm = MPI.COMM_WORLD
        sys.stderr.write(f"fricfem: error: rank {comm.rank} of {comm.size}: {what}; ending every rank (MPI_Abort)\n")
        sys.stderr.flush()
        comm.Abort(1)

    sys.excepthook = hook


def load_scene(ref, overrides=()):
    """A validated scene (:class:`fricfem.scene.Scene`) from a shipped name or a
    .toml path, with ``--set``-style overrides (``"section.key=value"``).
    Raises :class:`fricfem.scene.SceneError` naming the key on bad input."""
    # lazy: start-up time (import fricfem loads no MPI, dolfinx, numba or h5py)
    from .scene import SceneError, load

    _end_job_on_uncaught()
    try:
        return load(ref, overrides)
    except SceneError as err:
        if _ranks() > 1 and "unknown friction law" in str(err):
            raise SceneError(f"{err} (under MPI, fricfem.register_law must run on every rank: was the law "
                             "registered on some ranks only?)") from None
        raise


def run(scene, out=None, *, comm=None, overwrite=False, quiet=True, on_step=None) -> dict:
    """Run a scene (a :class:`~fricfem.scene.Scene`, or a name/path to load)
    into the run directory ``out`` (default ``runs/<name>``); returns the
    summary (every rank).  Collective over ``comm`` (default MPI.COMM_WORLD)."""
    # here, not at the top: fricfem's namespace is its API alone (see the docstring)
    from pathlib import Path

    from mpi4py import MPI

    from .runner import run_scene
    from .scene import Scene, load

    _end_job_on_uncaught()
    if not isinstance(scene, Scene):
        scene = load(scene)
    out = Path(out) if out else Path("runs") / scene.name
    return run_scene(scene, out, comm or MPI.COMM_WORLD, overwrite=overwrite, quiet=quiet, on_step=on_step)


def open_run(rundir):
    """A run directory's results as arrays with units (:class:`fricfem.output.rundir.Run`):
    ``t``, ``x1``, every interface quantity (``slip_rate``, ``shear_traction``, ...),
    ``stations``, ``energy``, ``summary``, ``units``; ``gauges``: the point histories
    inside the plates (:class:`fricfem.output.gauges.GaugeFile`, None if the scene
    had no ``output.gauges``).  A run still going or killed reads as far as it was
    flushed."""
    # lazy: start-up time (import fricfem loads no MPI, dolfinx, numba or h5py)
    from .output.gauges import open_gauges
    from .output.rundir import open_run as _open

    run = _open(rundir)
    run.damaged = {}  # {file: why it could not be read}: the optional files a damaged copy of is left out
    try:
        run.gauges = open_gauges(rundir)
    except OSError as err:  # an optional file: the rest of the run is still read
        # here, not at the top: fricfem's namespace is its API alone (see the docstring)
        import warnings

        run.gauges = None
        run.damaged[str(err.filename)] = err.strerror
        warnings.warn(f"{err.filename}: {err.strerror}; run.gauges is None", stacklevel=2)
    return run


def register_law(law, *, replace=False):
    """Register a friction law of your own (a :class:`fricfem.friction.Law` on the
    contract of :mod:`fricfem.friction.base`) so that scenes can name it in
    ``friction.law``; its functions are compiled and checked once here
    (:func:`fricfem.friction.register_law`; docs/api.md, "A law of your own")."""
    # lazy: start-up time (import fricfem loads no MPI, dolfinx, numba or h5py)
    from .friction import register_law as _register

    _end_job_on_uncaught()
    return _register(law, replace=replace)
