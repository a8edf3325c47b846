"""Two traps of a rate-and-state nucleation problem, each named before anything
is built: a parameter of another law (Dc for the slip distance L) gets a hint of
the law's own name and of how its state starts; a nucleation patch under the
default 'local' initial state (which starts the patch in steady sliding: it
never nucleates) gets a warning, and the shipped scene ('background') none."""

import pytest

from fricfem import load_scene
from fricfem.scene import SceneError


def test_a_parameter_of_another_law_names_its_owner_and_the_laws_own_name():
    with pytest.raises(SceneError, match=r"friction.params.Dc: unknown parameter for friction law 'rate_state_slip'; "
                                         r"allowed: .* \(Dc is a parameter of slip_weakening; the slip distance of "
                                         r"rate_state_slip is L; the state of rate_state_slip starts at steady "
                                         r"sliding at V_ini, .*friction.initial_state\)"):
        load_scene("rsf_slip_2d", ["friction.params.Dc=1e-6"])
    with pytest.raises(SceneError, match=r"friction.params.zzz: unknown parameter .*allowed: [^(]*$"):
        load_scene("rsf_slip_2d", ["friction.params.zzz=1"])  # nobody's: no hint


def test_a_patch_that_cannot_nucleate_is_warned_about():
    local = load_scene("rsf_slip_2d", ["friction.initial_state='local'"])
    assert any("friction.initial_state = 'local' sets each point's state from its own traction" in w
               and "set friction.initial_state = 'background'" in w for w in local.warnings)
    assert not any("initial_state" in w for w in load_scene("rsf_slip_2d").warnings)
    assert not any("initial_state" in w for w in load_scene("tpv205_2d").warnings)  # slip weakening: no state
