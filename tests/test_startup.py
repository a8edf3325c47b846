"""The command's start-up stand-in for pkg_resources (fricfem/_startup.py): ufl's
and ffcx's version lookups answered without loading it, anything else of it
served by the real module, loaded then."""

import subprocess
import sys

from rankcheck import serial_env

CHECK = """
import importlib.metadata, sys
from fricfem._startup import lighten_imports
lighten_imports()
import dolfinx.fem, ffcx, ufl
assert ufl.__version__ == importlib.metadata.version("fenics-ufl"), ufl.__version__
assert ffcx.__version__ == importlib.metadata.version("fenics-ffcx"), ffcx.__version__
assert type(sys.modules["pkg_resources"]).__name__ == "_PkgResources"   # the real one never loaded
import pkg_resources
assert pkg_resources.get_distribution("numpy").version == importlib.metadata.version("numpy")
assert pkg_resources.parse_version("1.2") < pkg_resources.parse_version("1.10")  # the real module's
assert type(sys.modules["pkg_resources"]).__name__ == "module" and hasattr(sys.modules["pkg_resources"], "working_set")
try:
    pkg_resources.get_distribution("no-such-distribution-fricfem")
except Exception as err:
    assert type(err).__name__ == "DistributionNotFound", type(err)
else:
    raise AssertionError("an unknown distribution was found")
print("ok")
"""


def test_version_lookups_without_pkg_resources_and_the_real_module_on_demand():
    res = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, timeout=120,
                         env=serial_env())
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-2000:]
