"""What a validated scene is: the :class:`Scene` record (plain data, everything a
run needs; :func:`fricfem.scene.validate.validate` makes it) and its typed
settings.

``scene.output`` and ``scene.watchdog`` are frozen dataclasses generated from
the schema's sections (:data:`fricfem.scene.schema.SCHEMA`), one typed
attribute per key (``scene.output.energy_every`` is an int), so a key added to
the schema is a setting at once.  They are also read-only mappings
(``scene.output["energy_every"]``, ``.get``, ``dict(...)``) for code written
against the tables.  Defaults are resolved here, at validation:
``watchdog.max_slip_rate = 0`` becomes the material's c_l.  ``scene.raw`` keeps
the merged TOML tables as given (the run's identity; 0 stays 0 there).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import NamedTuple

from ..keys import NUM
from ..model.loading import ImpactPulse
from ..model.material import Material
from ..model.mesh import MeshSpec
from .schema import SCHEMA


class _Settings(Mapping):
    """A frozen dataclass of settings that reads as a mapping too (key -> value)."""

    def __getitem__(self, key):
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter(self.__dataclass_fields__)

    def __len__(self) -> int:
        return len(self.__dataclass_fields__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.items())})"


_TYPES = {NUM: float, int: int, bool: bool, str: str, list: list, dict: dict}


def _settings(name: str, section: str, doc: str) -> type:
    """A frozen settings dataclass with one typed field per key of ``SCHEMA[section]``."""
    fields = [(key, _TYPES.get(k.kind, object)) for key, k in SCHEMA[section].items()]
    cls = dataclasses.make_dataclass(name, fields, bases=(_Settings,), frozen=True, eq=True, repr=False,
                                     namespace={"__doc__": doc, "__module__": __name__})
    cls.__qualname__ = name
    return cls


OutputSettings = _settings("OutputSettings", "output", "The checked ``[output]`` section (docs/scenes.md).")
WatchdogSettings = _settings("WatchdogSettings", "watchdog",
                             "The checked ``[watchdog]`` section, ``max_slip_rate`` resolved (0: the material's c_l).")


def settings(cls: type, values: dict):
    """``cls`` from a section's checked values: a number key as float, the rest as given."""
    kinds = {f.name: f.type for f in dataclasses.fields(cls)}
    return cls(**{k: (float(v) if kinds[k] is float else v) for k, v in values.items()})


class Scene(NamedTuple):
    """A validated scene (plain data; everything a run needs)."""

    name: str
    description: str
    mesh: MeshSpec
    material: Material
    pulse: ImpactPulse
    sigma0: float
    symmetric: bool
    Cn: float
    Cs: float
    tau0: float
    tau0_patches: tuple
    law: str
    params: dict
    regions: tuple
    t_end: float
    dt_safety: float
    dt: float | None
    stop_at_tip: float
    allow_unstable_dt: bool
    skip_quiet: bool
    output: OutputSettings
    watchdog: WatchdogSettings
    raw: dict  # the merged TOML tables, for the record
    warnings: tuple = ()  # one line each: scale checks that did not refuse the scene
    interface_kind: str = "elastic"  # model.grid.INTERFACE_KINDS
    absorbing: tuple = ()  # outer edges with dashpots (model.grid.OUTER)
    profiles: tuple = ()  # ((parameter name, ((x1, value), ...)), ...): piecewise-linear along x1
    initial_state: str = "local"  # the traction the initial friction state comes from: 'local' or 'background'
    damping_eta: float = 0.0  # Kelvin–Voigt layer: η as a fraction of dt (0: none)
    damping_width: float = 0.0  # its half-height about x2 = 0 [m]
    experiment: object = None  # the experiment's steel bodies (fricfem.model.bodies.Experiment), or None


def field_steps(times, dt: float, t_end: float) -> list:
    """The steps at which field snapshots at ``times`` are written: each at its
    nearest step, kept within the run's steps 1 … floor(t_end/dt) (a validated
    time lies in (0, t_end], so it moves by less than one step)."""
    n_end = int(math.floor(t_end / dt + 1e-9))
    return sorted({min(max(int(round(t / dt)), 1), n_end) for t in times})
