"""The run directory's one table: every quantity fricfem writes, its unit, how
it is read off the interface points, and how figures label it.

Everything that writes or reads a run directory (:mod:`.recorder`,
:mod:`.rundir`, :mod:`fricfem.plot`) takes names, units and labels from here.

Run directory (format version :data:`FORMAT`):

- ``interface.h5`` — ``x1`` [m] of every interface Gauss point (4 per segment),
  ``time`` [s], and one ``[n_time, n_point]`` array per :data:`QUANTITIES`
  entry and per law state variable (``state/<name>``); station histories at
  every step under ``stations/<name>`` (``time`` and each quantity); the
  energy history under ``energy/`` (:data:`ENERGY`).  Each dataset carries a
  ``unit`` attribute.  Every dataset has the size of the whole run, laid out
  with NaN when the run starts; the valid rows are the leading rows whose
  time is finite (a finished run that stopped early is trimmed to them;
  :mod:`.recorder`).  Files of format 2 counted them in the root attribute
  ``n_time`` (``n`` per station); the readers take either.
- ``fields.xdmf`` + ``fields/`` (``mesh.h5``, one ``tNNNN.h5`` per snapshot) —
  :data:`FIELDS` at the requested times, one temporal collection
  (:mod:`.fields`).
- ``summary.json`` — the run's record for people (scene, sizes, step, timing,
  initiation, tip, fronts, mode, the energy at the end time), with a ``units``
  block; ``evidence.json`` — its per-step arrays (:mod:`.record`).
- ``.fricfem-manifest.json`` — what fricfem writes there; ``.fricfem.lock`` while
  a run writes (:mod:`.directory`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

FORMAT = 3  # interface.h5 / summary.json layout version

INTERFACE_FILE = "interface.h5"
SUMMARY_FILE = "summary.json"
FIELDS_FILE = "fields.xdmf"
GAUGES_FILE = "gauges.h5"


class Quantity(NamedTuple):
    """One interface quantity of ``interface.h5``.

    name    dataset name
    unit    SI unit ("1": dimensionless, as UDUNITS/CF write it; never empty)
    read    function of :class:`fricfem.model.interface.Points` -> float64[n_points]
    label   figure label (mathtext)
    signed  True when it changes sign with the sliding direction; figures then
            draw it times the sliding sign, labelled ``neg_label`` when flipped
    neg_label  label of the flipped quantity
    doc     meaning
    dtype   HDF5 dtype
    attr    the :class:`~fricfem.model.interface.Points` array ``read`` returns as it
            is ("" for a quantity computed from others: ``read`` of an object
            holding those arrays computes it, e.g. from the stations' rows)
    """

    name: str
    unit: str
    read: object
    label: str
    signed: bool = False
    neg_label: str = ""
    doc: str = ""
    dtype: str = "f8"
    attr: str = ""


def _mu_app(p):
    # T_s/T_n where T_n > 0, else 0 (the same values as np.divide(..., where=T_n > 0),
    # whose masked loop took ~17 µs for the reference mesh's 912 points against ~9)
    pos = p.Tn > 0
    return np.where(pos, p.Ts / np.where(pos, p.Tn, 1.0), 0.0)


#: interface.h5 snapshot quantities, in file order.
QUANTITIES = (
    Quantity("slip_rate", "m/s", lambda p: p.slip_rate, r"$\Delta\dot u_{\rm slip}$",
             doc="frictional slip rate Δu̇_slip >= 0", attr="slip_rate"),
    Quantity("jump_rate_s", "m/s", lambda p: p.rate_s, r"$\Delta\dot u_s$", True, r"$-\Delta\dot u_s$",
             doc="tangential jump rate Δu̇_s over the last step", attr="rate_s"),
    Quantity("shear_traction", "Pa", lambda p: p.Ts, r"$T_s$", True, r"$-T_s$", doc="shear traction T_s", attr="Ts"),
    Quantity("normal_traction", "Pa", lambda p: p.Tn, r"$T_n$", doc="normal traction T_n, compression positive", attr="Tn"),
    Quantity("shear_traction_increment", "Pa", lambda p: p.dTs, r"$dT_s = \dot T_s\,dt$", True,
             r"$-dT_s = -\dot T_s\,dt$", doc="change of T_s over the last step", attr="dTs"),
    Quantity("slip", "m", lambda p: p.slip, r"$\Delta u_{\rm slip}$", doc="accumulated frictional slip", attr="slip"),
    Quantity("jump_s", "m", lambda p: p.jump_s, r"$\Delta u_s$", True, r"$-\Delta u_s$",
             doc="tangential jump Δu_s = u⁺ − u⁻", attr="jump_s"),
    Quantity("mu_app", "1", _mu_app, r"$\mu_{\rm app} = T_s/T_n$", True, r"$-\mu_{\rm app} = -T_s/T_n$",
             doc="apparent friction T_s/T_n (0 where open)"),
    Quantity("open", "1", lambda p: p.is_open, "open", doc="1 where the interface is open", dtype="i1",
             attr="is_open"),
)
BY_NAME = {q.name: q for q in QUANTITIES}

#: when a quantity of an interface.h5 row holds, in steps after the row's ``time``
#: (t^n, the time of the tractions), by interface kind; 0 when not named.  The
#: rigid kind's slip rate and jump rate are the step's V^{n+½}, its slip
#: δ^{n+1} (δ^n + V^{n+½} dt) and the law's state (``state/…``) Ψ^{n+1}; the
#: elastic kind's jump rate is that of the step that ended at t^n, V^{n−½} (its
#: slip rate and slip are the law's at t^n).
#: Written on each dataset as ``time_shift_s`` (:func:`time_shift`); readers take
#: ``InterfaceFile.time_of`` / ``Station.time_of``.
TIME_SHIFT_STEPS = {"rigid": {"slip_rate": 0.5, "jump_rate_s": 0.5, "slip": 1.0, "state/": 1.0},
                    "elastic": {"jump_rate_s": -0.5}}


def time_shift(kind: str, name: str, dt: float) -> tuple:
    """(shift [s], what it means) of quantity ``name`` of an ``kind`` interface."""
    k = TIME_SHIFT_STEPS.get(kind, {}).get("state/" if name.startswith("state/") else name, 0.0)
    where = {0.0: "at time (t^n)", 0.5: "at time + dt/2 (t^{n+1/2}: the step's rate)",
             1.0: "at time + dt (t^{n+1}: after the step's slip)",
             -0.5: "at time - dt/2 (t^{n-1/2}: the rate of the step that ended at t^n)"}[k]
    return k * dt, where

#: energy history (``energy/``) and summary energy keys -> unit.
ENERGY = {"time": "s", "kinetic": "J/m", "strain": "J/m", "interface_work": "J/m", "interface_elastic": "J/m",
          "dissipated": "J/m", "external": "J/m", "absorbed": "J/m", "viscous": "J/m", "balance_error": "J/m"}

#: field snapshot functions in ``fields.xdmf`` -> unit (the arrays the goldens fingerprint).
FIELDS = {"displacement": "m", "velocity": "m/s", "stress_difference": "Pa"}
#: functions derived from :data:`FIELDS` for viewers, written beside them -> unit:
#: σ1 − σ2 at the nodes (the cells' values, lumped-L2 projected to P1) so that
#: ParaView draws it smooth without "Cell Data to Point Data".
DERIVED_FIELDS = {"stress_difference_nodal": "Pa"}
#: what each field function is, written into fields.xdmf (Information elements)
#: and onto each HDF5 dataset (``meaning``): the stress includes the prestress,
#: the displacement and velocity are the dynamic part only.
FIELD_MEANING = {
    "displacement": "dynamic part only: the displacement since t = 0 of the prestressed plates (the static "
                    "deformation under the prestress is not included)",
    "velocity": "particle velocity v^(n-1/2) (half a step before the snapshot's time), dynamic part only",
    "stress_difference": "sigma1 - sigma2 of the TOTAL in-plane stress, prestress included "
                         "(S22 = -Sigma0, S12 = tau0 added to the dynamic stress), constant per cell",
    "stress_difference_nodal": "stress_difference (prestress included) at the nodes: the cells' values "
                               "averaged with the cells' areas as weights (lumped L2 projection to P1); "
                               "for viewing, the cell values are the computed ones",
}

#: ``gauges.h5``'s per-gauge histories (:mod:`.gauges`), in file order: dataset -> (unit, component
#: names, meaning).
GAUGE_QUANTITIES = {
    "displacement": ("m", ("u1", "u2"), "displacement u at time"),
    "velocity": ("m/s", ("v1", "v2"), "velocity v at velocity_time = time - dt/2 (central differences)"),
    "strain": ("1", ("e11", "e22", "e12"), "infinitesimal strain of the triangle holding the gauge, at time"),
    "stress": ("Pa", ("s11", "s22", "s12"), "in-plane stress of that triangle, prestress included, at time"),
    "stress_difference": ("Pa", (), "sigma1 - sigma2 (prestress included), at time"),
}

#: Units of law state variables (``state/<name>`` of interface.h5), by name, for
#: the shipped laws: slip weakening's slip, rate and state's ψ, Povirk–Needleman's θ.
STATE_UNITS = {"slip": "m", "psi": "1", "theta0": "s", "theta1": "Pa", "theta2": "Pa"}
#: the unit written for a state variable of a user law that is not in :data:`STATE_UNITS`
UNDECLARED_UNIT = "undeclared (a user law's state variable; fricfem.output.quantities.STATE_UNITS)"

#: Reference wave speeds (summary ``speeds``) and their figure labels.
SPEED_LABEL = {"c_R": r"$c_R$", "c_s": r"$c_s$", "sqrt2_c_s": r"$\sqrt{2}\,c_s$", "c_l": r"$c_l$"}


def label(name: str, sign: float = 1.0) -> str:
    """Figure label of quantity ``name`` as drawn times ``sign`` (±1)."""
    q = BY_NAME.get(name)
    if q is None:
        return name
    return q.neg_label if (sign < 0 and q.signed) else q.label


def unit(name: str) -> str:
    """SI unit of an interface quantity, a ``state/<θ>`` dataset or an energy ("1":
    dimensionless; a user law's undeclared state: :data:`UNDECLARED_UNIT`; "" only
    for a name that is none of these)."""
    if name in BY_NAME:
        return BY_NAME[name].unit
    if name.startswith("state/"):
        return STATE_UNITS.get(name[len("state/"):], UNDECLARED_UNIT)
    return ENERGY.get(name, "")
