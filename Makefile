# fricfem: every target installs what is missing first (scripts/setup.sh,
# quick when everything is present).
#
#   make setup   Debian packages + .venv (pyvista, meshio, fricfem editable)
#   make test    pytest under 2 MPI ranks     (PYTEST_ARGS='-m "not slow"' ...)
#   make demo    demos/impact.py under 2 MPI ranks
#   make bench   benchmarks/run_all.sh
#
# NP=4 changes the number of ranks.

SHELL := /bin/bash
.DEFAULT_GOAL := help

NP          ?= 2
PY          := .venv/bin/python
PYTEST_ARGS ?=
MPIRUN      := mpirun -n $(NP) --oversubscribe

# OpenMPI refuses to run as root without these; allow more ranks than cores.
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1
# One thread per MPI rank (BLAS, OpenMP, numba).
export OMP_NUM_THREADS := 1
# pyvista/VTK render off-screen through EGL, no X server.
export VTK_DEFAULT_OPENGL_WINDOW ?= vtkEGLRenderWindow

.PHONY: help setup test demo bench

help:
	@sed -n 's/^#   //p' $(firstword $(MAKEFILE_LIST))

setup:
	@bash scripts/setup.sh

test: setup
	$(MPIRUN) $(PY) -m pytest tests $(PYTEST_ARGS)

demo: setup
	$(MPIRUN) $(PY) demos/impact.py

bench: setup
	@if [ -f benchmarks/run_all.sh ]; then \
		bash benchmarks/run_all.sh; \
	else \
		echo "bench: benchmarks/run_all.sh not present, nothing to run"; \
	fi
