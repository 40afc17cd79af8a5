"""cosserat-fsi: monolithic Eulerian FSI of an elastic body in a Cosserat (micropolar) fluid.

Implements the scheme of Hussain, Khan & Liu (seed paper, eqs. 29-32) on FEniCSx.

The Python API, importable as ``from cosserat_fsi import ...`` (each name is loaded on first use, so that
``import cosserat_fsi`` and the command line stay light):

- scenes: :func:`load_scene` (a YAML file, with ``--set``-style overrides), :func:`validate_scene` (a dict);
- meshes: :func:`load_mesh` (the scene's mesh and tags, built by gmsh and cached);
- runs: :class:`Simulation` (the loop of one scene), :class:`Observables` (forces, probes, point A),
  :func:`run_scene` (what ``cosserat-fsi run`` does: a run folder with XDMF, CSV and summary.json);
- results: :func:`read_timeseries` (a run's timeseries.csv), :func:`read_summary` (its summary.json);
- studies: :func:`load_study`, :func:`run_study` (what ``cosserat-fsi study`` does).
"""

from importlib import import_module

__version__ = "0.1.0"

_EXPORTS = {
    "load_scene": ("cosserat_fsi.config", "load_scene"),
    "validate_scene": ("cosserat_fsi.config", "validate_scene"),
    "load_mesh": ("cosserat_fsi.app.runner", "load_mesh"),
    "Simulation": ("cosserat_fsi.simulation", "Simulation"),
    "Observables": ("cosserat_fsi.observables", "Observables"),
    "run_scene": ("cosserat_fsi.app.runner", "run_scene"),
    "read_timeseries": ("cosserat_fsi.io.timeseries", "read_timeseries"),
    "read_summary": ("cosserat_fsi.app.study", "read_summary"),
    "load_study": ("cosserat_fsi.app.study", "load_study"),
    "run_study": ("cosserat_fsi.app.study", "main_study"),
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    """The public names of the package, imported from their modules on first use (PEP 562)."""
    try:
        module, attribute = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'cosserat_fsi' has no attribute {name!r}") from None
    value = getattr(import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
