"""Unstructured finite-volume incompressible Navier–Stokes solver (steady; laminar or k-omega SST RANS).

Typical use::

    from solver import Fluid, Problem, SimpleSettings, from_msh, solve_steady
    mesh = from_msh("blade.msh")
    problem = Problem.create(mesh, {"inlet": {"type": "velocity_inlet", "velocity": (1, 0)},
                                    "outlet": "pressure_outlet", "top": "symmetry",
                                    "bottom": "symmetry", "blade": "wall"}, Fluid(rho=1000, mu=1e-3))
    res = solve_steady(problem, SimpleSettings(monitor_groups=("blade",)))
    res.status, res.forces("blade").fx, res.c_max

Turbulent (Menter SST-2003, :mod:`solver.turbulence`; inlet turbulence from the ``velocity_inlet``
parameters ``intensity`` (default 0.05) and ``viscosity_ratio`` (default 10))::

    problem = Problem.create(mesh, bcs, fluid, turbulence=SST(wall_treatment="automatic"))
    res = solve_steady(problem, SimpleSettings(alpha_u=0.7, monitor_groups=("blade",)))
    res.k, res.omega, res.nu_t, res.wall_shear("blade"), res.y_plus("blade")
"""

from .boundary import BOUNDARY_CONDITIONS, resolve_boundaries
from .fvmesh import FVMesh, MeshError, build_fvmesh, from_meshio, from_msh
from .linalg import LINEAR_SOLVERS, SolverSettings
from .results import FlowResults, Forces
from .steady import Fluid, Problem, SimpleSettings, solve_steady
from .turbulence import SST, SSTConstants

__all__ = [
    "BOUNDARY_CONDITIONS", "FVMesh", "FlowResults", "Fluid", "Forces", "LINEAR_SOLVERS", "MeshError",
    "Problem", "SST", "SSTConstants", "SimpleSettings", "SolverSettings", "build_fvmesh", "from_meshio", "from_msh",
    "resolve_boundaries", "solve_steady",
]
