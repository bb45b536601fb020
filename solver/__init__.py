"""Unstructured finite-volume incompressible Navier–Stokes solver (steady, laminar core).

Typical use::

    from solver import Fluid, Problem, SimpleSettings, from_msh, solve_steady
    mesh = from_msh("blade.msh")
    problem = Problem.create(mesh, {"inlet": {"type": "velocity_inlet", "velocity": (1, 0)},
                                    "outlet": "pressure_outlet", "top": "symmetry",
                                    "bottom": "symmetry", "blade": "wall"}, Fluid(rho=1000, mu=1e-3))
    res = solve_steady(problem, SimpleSettings(monitor_groups=("blade",)))
    res.status, res.forces("blade").fx, res.c_max
"""

from .boundary import BOUNDARY_CONDITIONS, resolve_boundaries
from .fvmesh import FVMesh, MeshError, build_fvmesh, from_meshio, from_msh
from .linalg import LINEAR_SOLVERS, SolverSettings
from .results import FlowResults, Forces
from .steady import Fluid, Problem, SimpleSettings, solve_steady

__all__ = [
    "BOUNDARY_CONDITIONS", "FVMesh", "FlowResults", "Fluid", "Forces", "LINEAR_SOLVERS", "MeshError",
    "Problem", "SimpleSettings", "SolverSettings", "build_fvmesh", "from_meshio", "from_msh",
    "resolve_boundaries", "solve_steady",
]
