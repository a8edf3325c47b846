"""The scene schema: every key a scene may set, with type, default, unit,
allowed range and meaning — one table (:data:`SCHEMA`).

Keys that belong to a model dataclass are declared once, on its fields
(:func:`fricfem.keys.field`): the mesh (:class:`~fricfem.model.mesh.MeshSpec`),
the material (:class:`~fricfem.model.material.Material`), the impact pulse
(:class:`~fricfem.model.loading.ImpactPulse`) and the experiment's steel bodies
(:class:`~fricfem.model.bodies.Experiment`).  Friction parameters are the
law's own (:class:`fricfem.friction.Param`).  All values are SI.
"""

from __future__ import annotations

from .. import friction
from ..keys import NUM, Key, keys_of
from ..model.grid import INTERFACE_KINDS, OUTER
from ..model.bodies import Experiment
from ..model.loading import ImpactPulse
from ..model.material import Material
from ..model.mesh import MeshSpec


class SceneError(ValueError):
    """A scene is malformed; the message names the key, the value and what is allowed."""


def shown(v, width: int = 80) -> str:
    """``repr(v)``, shortened to about ``width`` characters for a message."""
    text = repr(v)
    return text if len(text) <= width else f"{text[:width - 20]}… ({len(text)} characters)"


def _mesh_keys() -> dict:
    """The MeshSpec fields as scene keys; unset ones come from the preset (default None)."""
    return {name: k._replace(default=None, doc=f"{k.doc} (default: the preset's)")
            for name, k in keys_of(MeshSpec).items()}


def _loading_keys() -> dict:
    pulse = keys_of(ImpactPulse)
    return {
        "sigma0": Key(NUM, 6e6, "Pa", 1.0, 1e9, "initial compression Σ0 (> 0: every law's strength is "
                      "proportional to it; docs/scenes.md)", band=(1e4, 1e9)),
        "v_imp": pulse["v_imp"]._replace(band=(0.1, 1e3)),
        **{k: pulse[k] for k in ("t_rise", "t_hold_end", "t_fall")},
        "symmetric": Key(bool, False, doc="strike both plates (|x2| <= b)"),
        **{k: pulse[k] for k in ("direction", "kind", "impedance")},
    }


#: The schema: section -> key -> :class:`fricfem.keys.Key` ("" is the top level).
SCHEMA = {
    "": {
        "name": Key(str, "scene", doc="scene name, an identifier: 1–128 letters, digits, '_', '-', '.', not "
                                      "'.' or '..' (default: the file's name); the run directory is runs/<name>"),
        "description": Key(str, "", doc="one line on what the scene shows (at most 2000 characters)"),
        "base": Key(str, "", doc="shipped scene or .toml file this one starts from"),
    },
    "mesh": {"preset": Key(str, "reference", doc="a mesh of meshes/ (coarse, reference, half, fine, "
                                                 "rupture_band) or a path to a .toml mesh file"),
             **_mesh_keys(),
             "absorbing": Key(list, [], doc="outer edges with absorbing dashpots (ρc_l normal, ρc_s "
                                            f"tangential), any of {', '.join(map(repr, OUTER))}; the "
                                            "others are traction-free")},
    "material": {**keys_of(Material), "E": keys_of(Material)["E"]._replace(band=(1e6, 1e12))},
    "loading": _loading_keys(),
    # the paper's experiment: steel buffer bonded to the struck edge, steel projectile (fricfem.model.bodies)
    "experiment": {**keys_of(Experiment),
                   "projectile_speed": keys_of(Experiment)["projectile_speed"]._replace(band=(0.1, 1e3))},
    "interface": {
        "kind": Key(str, "elastic", doc="'elastic' (the paper's: springs C_n, C_s at the Gauss points) or "
                                        "'rigid' (split-node pairs, no spring: the traction from the pairs' "
                                        "trial velocities; Cn and Cs unused)", choices=INTERFACE_KINDS),
        "Cn": Key(NUM, 3e11, "Pa/m", 1e6, 1e16, "normal stiffness C_n (a stiff spring shrinks the step: "
                                                 "see the cost estimate)"),
        "Cs": Key(NUM, 1e11, "Pa/m", 1e6, 1e16, "shear stiffness C_s"),
        "tau0": Key(NUM, 0.0, "Pa", -1e9, 1e9, "initial shear traction"),
        "patches": Key(list, [], doc="[{x1_min, x1_max, tau0}] initial shear traction patches; they may not "
                                     "overlap and each holds an interface point"),
        "damping_eta": Key(NUM, 0.0, "dt", 0.0, 1.0, "Kelvin-Voigt damping of the bulk in a layer about the "
                                                     "interface (SEM2DPACK's ETA): the stress there is "
                                                     "C:eps(u + eta v), eta this fraction of the time step; 0: "
                                                     "none (docs/interface_kinds.md; the stable step shrinks "
                                                     "by 1/sqrt(1 + 2 damping_eta))"),
        "damping_width": Key(NUM, 0.0, "m", 0.0, 1.0, "half-height of the damped layer: the cells whose centroid "
                                                      "has |x2| < damping_width (set with damping_eta)"),
    },
    "friction": {
        "law": Key(str, "povirk_needleman", doc="friction law name"),
        "params": Key(dict, {}, doc="law parameters (friction.params.<name>, below)"),
        "regions": Key(list, [], doc="[{x1_min, x1_max, params}] piecewise-constant overrides; they may not "
                                     "overlap and each holds an interface point"),
        "profiles": Key(dict, {}, doc="parameter name -> [[x1, value], ...]: the parameter piecewise-linear "
                                      "along x1 through these knots (x1 strictly increasing on the plate, at "
                                      "least 2, values in the parameter's range; constant beyond the first and "
                                      "last knot); replaces friction.params.<name> everywhere, and a parameter "
                                      "with a profile may not be set in friction.regions"),
        "initial_state": Key(str, "local", doc="the shear traction each point's initial friction state is set "
                                               "from: 'local' (its own initial traction, interface.patches "
                                               "included) or 'background' (interface.tau0 everywhere, so a patch "
                                               "starts away from the state its traction would give: nucleation "
                                               "by overstress, as SCEC TPV101-102 and SEM2DPACK)",
                             choices=("local", "background")),
    },
    "time": {
        "end": Key(NUM, 40e-6, "s", 0.0, 1.0, "end time (at least one step)", open_low=True),
        "dt_safety": Key(NUM, 0.9, "", 0.0, 1.0, "fraction of the stable step", open_low=True, open_high=True),
        "dt": Key(NUM, 0.0, "s", 0.0, 1e-3, "fixed step (0: from dt_safety; a step > 0 must fit "
                                             "time.end at least once)"),
        "allow_unstable_dt": Key(bool, False, doc="accept a time.dt above the stable step (stability "
                                                  "experiments; the watchdog guards the run)"),
        "stop_at_tip": Key(NUM, 0.0, "m", 0.0, 10.0, "end the run once the sliding tip passes this x1 "
                                                     "(0: never; at most mesh.length), e.g. the fine region's end"),
        "skip_quiet": Key(bool, True, doc="skip the rows the motion has not reached yet (bit-identical "
                                          "to computing every row; false: compute every row)"),
    },
    "watchdog": {
        "enabled": Key(bool, True, doc="stop a diverging run with a message: non-finite interface values or "
                                       "energies, a negative discrete kinetic energy, or an energy budget that "
                                       "does not close (docs/model.md, \"The watchdog\")"),
        "max_slip_rate": Key(NUM, 0.0, "m/s", 0.0, 1e9,
                             "report threshold of slip-rate spikes (0: the material's c_l): a slip rate above it "
                             "is reported with its peak, place and time in summary.json (slip_rate_spike) and on "
                             "the progress line, never a stop — such peaks are genuine at strong loading "
                             "(docs/friction_reference.md §4)"),
        "energy_tol": Key(NUM, 1e-6, "", 0.0, 1.0,
                          "stop when the energy balance error, or a negative kinetic energy, exceeds this × the "
                          "energy scale (the budget closes to round-off, ≤ 2.1e-13 measured)", open_low=True),
        "energy_factor": Key(NUM, 1.5, "", 1.0, 1e6, "older form of the energy bound, kept so that older scenes "
                                                     "load: the bound is min(energy_tol, energy_factor − 1)",
                             open_low=True),
    },
    "output": {
        "fields": Key(list, [], "s", doc="times of field snapshots (displacement, velocity, σ1 − σ2), each in "
                                         "(0, time.end], distinct; written at the nearest step"),
        "interface_every": Key(NUM, 0.2e-6, "s", 0.0, 1.0, "cadence of interface snapshots", open_low=True),
        "stations": Key(dict, {"x16.1mm": 16.1e-3}, "m", doc="station name -> x1 in [0, mesh.length] "
                                                             "(histories every step); a name is 1–64 letters, "
                                                             "digits, '_', '-', '.', not '.' or '..', unique "
                                                             "ignoring case; a scene's table replaces its base's"),
        "energy_every": Key(int, 50, "steps", 0, 10**9, "energy evaluation cadence (0: never)"),
        "flush_every": Key(NUM, 2.0, "s", 0.0, 1e6, "wall-clock seconds between flushes (the rows also flush "
                           "every 10 interface rows) and between rewrites of summary.json while the run goes",
                           open_low=True),
        "checkpoint_every": Key(NUM, 0.0, "s", 0.0, 1.0, "simulated time between checkpoints of the whole run "
                                "state (checkpoint.fricfem, replaced atomically; fricfem run --resume DIR "
                                "continues from the last one, bit-identical); 0: none by simulated time"),
        "checkpoint_wall": Key(NUM, 0.0, "s", 0.0, 1e7, "wall-clock seconds between checkpoints (decided on "
                               "rank 0, e.g. 1800 under a batch system's time limit); 0: none by wall time"),
        "diagnostics": Key(bool, True, doc="tip, fronts and mode classification in summary.json"),
        "rupture_threshold": Key(NUM, 1e-3, "m/s", 0.0, 1e3, "slip rate whose first crossing is a point's "
                                 "rupture time t_r (summary.json 'rupture': t_r(x1), rupture speed, supershear "
                                 "transition; fricfem/analysis/rupture.py)", open_low=True),
        # gauges, frames and the photoelastic constants: fricfem/scene/output_keys.py checks them
        "gauges": Key(dict, {}, "m", doc="gauge name -> [x1, x2] inside a plate (x2 != 0: not on the interface): "
                                         "velocity, strain and sigma1 - sigma2 there every output.gauges_every "
                                         "steps, into gauges.h5; names as stations'; tables merge key by key, so "
                                         "a scene's gauges add to its base's"),
        "gauges_every": Key(int, 1, "steps", 1, 10**6, "gauge cadence"),
        "frames": Key((list, dict), [], "s", doc="isochromatic frames, as a camera takes them: a list of times, "
                                                 "or {start, interval, count}; each in (0, time.end], written "
                                                 "as a field snapshot at its nearest step and drawn by fricfem "
                                                 "plot as a frame series"),
        "thickness": Key(NUM, 9.525e-3, "m", 0.0, 1.0, "specimen thickness h of the fringe order N = "
                                                        "(sigma1 - sigma2) h / f_sigma (figures only: the model "
                                                        "is two-dimensional)", open_low=True),
        "f_sigma": Key(NUM, 22.6e3, "N/m", 0.0, 1e9, "stress-optic (fringe) constant f_sigma of the specimen "
                                                     "(Homalite-100: 22.6 kN/m)", open_low=True),
    },
}


def _key_line(name: str, k: Key) -> str:
    unit = f" {k.unit}" if k.unit else ""
    rng = f" {k.range_text()}" if k.range_text() else ""
    if k.band:
        rng += f" (plausible {k.band[0]:g} … {k.band[1]:g}{unit}: warned outside)"
    choices = f" one of {', '.join(map(repr, k.choices))}" if k.choices else ""
    return f"{name} = {k.default!r}{unit}{rng}{choices}: {k.doc}"


def describe_keys() -> str:
    """Every scene key, one line each: ``section.key = default [unit] range: meaning``,
    then every friction law's parameters (``friction.params.<name>``)."""
    lines = [_key_line(f"{section}.{key}" if section else key, k)
             for section, keys in SCHEMA.items() for key, k in keys.items()]
    for name, law in friction.LAWS.items():
        lines.append(f"# friction.law = {name!r}: {law.doc}")
        for p in law.params:
            k = Key(NUM, p.default, p.unit, p.low, p.high, p.doc)
            lines.append(_key_line(f"friction.params.{p.name}", k))
    return "\n".join(lines)
