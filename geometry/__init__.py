"""Blade geometry: Bezier camber line and sides, design or milling tool-path mode, N-buffer machining.

Knows nothing of meshing, the solver or the optimiser. Units are SI (metres) except angles in
configuration values (degrees); see :mod:`geometry.parameters` and ``docs/explanation/geometry.md``.
"""

from geometry.bezier import BezierCurve
from geometry.blade import BladeCurves, blade_curves, tool_path_pieces
from geometry.camber import CamberError, camber_line
from geometry.feasibility import BladeResult, Constraint, constraint_names, evaluate_blade
from geometry.nbuffer import MachinedBoundary, machine
from geometry.parameters import (
    BladeSpec,
    Continuity,
    Mode,
    Parameter,
    ParameterError,
    ParameterSpace,
    parameters_of,
)
from geometry.profile import DEFAULT_TOLERANCE, GeometryError, Profile, build_profile

__all__ = [
    "DEFAULT_TOLERANCE",
    "BezierCurve",
    "BladeCurves",
    "BladeResult",
    "BladeSpec",
    "CamberError",
    "Constraint",
    "Continuity",
    "GeometryError",
    "MachinedBoundary",
    "Mode",
    "Parameter",
    "ParameterError",
    "ParameterSpace",
    "Profile",
    "blade_curves",
    "build_profile",
    "camber_line",
    "constraint_names",
    "evaluate_blade",
    "machine",
    "parameters_of",
    "tool_path_pieces",
]
