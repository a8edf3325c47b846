"""Start-up of the ``fricfem`` command: what a run does not need, not loaded.

ufl and ffcx (under dolfinx) import ``pkg_resources`` only to read their own
version (``pkg_resources.get_distribution(name).version``); importing it scans
every installed distribution, ~0.1 s of each rank's start-up.  The command
puts a stand-in in its place that answers that one call from
:mod:`importlib.metadata` and loads the real module the first time anything
else of it is asked for (so nothing that needs more is changed).  The Python
API leaves the import system alone.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import sys
import types


class _Distribution:
    def __init__(self, name: str):
        self.project_name = name
        self.version = importlib.metadata.version(name)


class _PkgResources(types.ModuleType):
    """``pkg_resources`` until something other than ``get_distribution(name).version`` is used."""

    def get_distribution(self, name):
        try:
            return _Distribution(str(name))
        except importlib.metadata.PackageNotFoundError:
            return self._real().get_distribution(name)  # the real module's answer, or its error

    def _real(self):
        if sys.modules.get("pkg_resources") is self:
            del sys.modules["pkg_resources"]
        return importlib.import_module("pkg_resources")

    def __getattr__(self, attr):
        if attr.startswith("__"):
            raise AttributeError(attr)
        return getattr(self._real(), attr)


def lighten_imports() -> None:
    """Install the stand-in, unless ``pkg_resources`` is already loaded."""
    if "pkg_resources" not in sys.modules:
        sys.modules["pkg_resources"] = _PkgResources("pkg_resources")
