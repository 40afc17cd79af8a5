"""What a run measures: :class:`Observables` (core.py) evaluates the columns of timeseries.csv and the line
profiles from the current state of a Simulation; the force on a body in its own module (forces.py: residual
and surface forms, drag/lift/side); a file scene's named probes, solid points, lines and flow rates in 2D
and 3D (named.py)."""

from .core import BODY, DP_POINTS, POINT_A, Observables
from .forces import COMPONENTS, force_columns, schaefer_turek_coefficients

__all__ = ["BODY", "COMPONENTS", "DP_POINTS", "POINT_A", "Observables", "force_columns",
           "schaefer_turek_coefficients"]
