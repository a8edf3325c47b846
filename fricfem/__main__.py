"""``python -m fricfem ...``: the ``fricfem`` command (:func:`fricfem.cli.main`),
for an interpreter whose scripts directory is not on PATH (a conda or wheel
environment, ``mpiexec -n 2 python -m fricfem run case1``)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
