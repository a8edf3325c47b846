"""Named parameter fields (fricfem/friction/base.py ``param_index``): each law's
module-level indices into the packed parameter array are derived from its PARAMS'
names, so what :func:`fricfem.friction.pack` writes and what the kernels read agree
by construction."""

import numpy as np
import pytest

from fricfem.friction import get_law, pack, validate
from fricfem.friction import povirk_needleman_equations as pne
from fricfem.friction import rate_state as rs
from fricfem.friction import slip_weakening as sw
from fricfem.friction.base import Param, param_index

# the constants each law's kernels read, by the parameter name they stand for
FIELDS = {
    "slip_weakening": (sw, {"MU_S": "mu_s", "MU_D": "mu_d", "DC": "Dc"}),
    "rate_state_slip": (rs, {"A": "a", "B": "b", "L": "L", "V0": "V0", "F0": "f0", "V_INI": "V_ini",
                             "GAMMA": "gamma", "SUB_TOL": "substep_tol", "SUB_STIFF": "substep_stiff",
                             "F_W": "f_w", "V_W": "V_w"}),
    "rate_state_aging": (rs, {"A": "a", "B": "b", "L": "L", "V0": "V0", "F0": "f0", "V_INI": "V_ini",
                              "GAMMA": "gamma", "SUB_TOL": "substep_tol", "SUB_STIFF": "substep_stiff"}),
    "povirk_needleman": (pne, {"MU_S": "mu_s", "MU_D": "mu_d", "V0": "V0", "V1": "V1", "B": "B", "P": "p",
                               "M": "m", "L0": "L0", "L1": "L1", "L2": "L2", "C": "C", "D": "D",
                               "THETA0_INIT": "theta0_init", "GAMMA": "gamma", "SUB_TOL": "substep_tol",
                               "SUB_STIFF": "substep_stiff"}),
}


@pytest.mark.parametrize("name", sorted(FIELDS))
def test_each_index_reads_its_parameter_from_the_packed_array(name):
    law = get_law(name)
    module, fields = FIELDS[name]
    defaults = {p.name: p.default for p in law.params}
    values = {n: defaults[n] * (1.0 + 1e-3 * (k + 1)) if defaults[n] else 1e-3 * (k + 1)
              for k, n in enumerate(defaults)}  # every value distinct
    values = validate(law, {n: v for n, v in values.items()
                            if next(p for p in law.params if p.name == n).high is None
                            or v <= next(p for p in law.params if p.name == n).high})
    packed = pack(law, values)
    for const, pname in fields.items():
        assert packed[getattr(module, const)] == values[pname], (name, const, pname)


def test_indices_follow_a_reordered_table_and_a_missing_name_is_refused():
    a, b, c = (Param(n, 1.0, "", 0.0, 2.0, n) for n in ("x", "y", "z"))
    assert param_index((a, b, c), "x", "y", "z") == (0, 1, 2)
    assert param_index((c, a, b), "x", "y", "z") == (1, 2, 0)
    with pytest.raises(ValueError, match="w"):
        param_index((a, b), "x", "w")
    assert np.array_equal(np.arange(3), param_index((a, b, c), "x", "y", "z"))
