#!/usr/bin/env bash
# Every benchmark of fricfem, as `make bench` runs it (2 MPI ranks; results in benchmarks/results/).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
MPI="mpirun -n 2"
PY=.venv/bin/python
$PY benchmarks/throughput.py                         # serial
$MPI $PY benchmarks/throughput.py                    # 2 ranks
$MPI $PY benchmarks/interface_cost.py --law stuck
$MPI $PY benchmarks/interface_cost.py
$MPI $PY benchmarks/dt_convergence.py
$PY benchmarks/end_to_end.py
$MPI $PY benchmarks/skipping.py
$MPI $PY benchmarks/stability.py
$PY benchmarks/spike_theory.py                       # serial
$MPI $PY benchmarks/work_precision.py --quick
# accuracy against independent references (benchmarks/README.md)
$PY benchmarks/point_reference.py                    # serial, scipy Radau
$MPI $PY benchmarks/mms.py
$PY benchmarks/absorbing_reflection.py
$PY benchmarks/peer/score.py
$PY benchmarks/peer/score.py --ranks 1 --tag serial --note "fricfem as in this tree, on 1 rank"
$PY benchmarks/peer/report.py
$PY benchmarks/rigid_convergence.py
$MPI $PY benchmarks/experiment_dt.py
# robustness
$PY benchmarks/faults.py
$PY benchmarks/bad_input.py
$PY benchmarks/rank_reproducibility.py
