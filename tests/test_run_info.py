"""Figure titles say what loaded the run: Σ0 and V_imp from the interface file,
the experiment's projectile speed instead of its edge's V_imp = 0."""

from fricfem.output.rundir import RunInfo, run_info


def test_edge_velocity_title():
    title = RunInfo(scene="case3", sigma0=10e6, v_imp=20.0).title()
    assert title == r"case3 — $\Sigma_0$ = 10 MPa, $V_{\rm imp}$ = 20 m/s"


def test_experiment_title_names_the_projectile_not_a_zero_v_imp():
    summary = {"scene": "experiment_42",
               "input": {"loading": {"sigma0": 9.4e6, "v_imp": 0.0},
                         "experiment": {"projectile_speed": 42.0, "projectile_length": 0.051}}}

    class Attrs:  # what interface.h5's root attributes hold for it
        attrs = {"scene": "experiment_42", "sigma0": 9.4e6, "v_imp": 0.0}

    info = run_info(interface=Attrs, summary=summary)
    assert info.projectile == 42.0
    title = info.title()
    assert "projectile 42 m/s" in title and "9.4 MPa" in title and "V_{\\rm imp}" not in title


def test_a_scene_without_the_experiment_has_no_projectile():
    info = run_info(summary={"scene": "case1", "input": {"experiment": None}})
    assert info.projectile is None
