"""The Python API: ``from cosserat_fsi import ...`` (cosserat_fsi/__init__.py, docs/api.md)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import cosserat_fsi

API = ["load_scene", "validate_scene", "load_mesh", "Simulation", "Observables", "run_scene", "read_timeseries",
       "read_summary", "load_study", "run_study"]


@pytest.mark.parametrize("name", API)
def test_each_public_name_is_the_module_object(name):
    """Each top-level name is the object of its module (what docs/api.md documents), listed in __all__."""
    module, attribute = cosserat_fsi._EXPORTS[name]
    assert getattr(cosserat_fsi, name) is getattr(__import__(module, fromlist=[attribute]), attribute)
    assert name in cosserat_fsi.__all__ and name in dir(cosserat_fsi)


def test_the_api_is_the_documented_one():
    assert sorted(cosserat_fsi._EXPORTS) == sorted(API)
    with pytest.raises(AttributeError, match="no attribute 'simulate'"):
        cosserat_fsi.simulate  # noqa: B018


def test_importing_the_package_stays_light():
    """``import cosserat_fsi`` (the command line's first import) loads neither dolfinx nor PETSc."""
    code = "import sys, cosserat_fsi; print(sorted(m for m in ('dolfinx', 'petsc4py', 'ufl') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
