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
    res = solve_steady(problem, SimpleSettings(monitor_groups=("blade",)))
    res.k, res.omega, res.nu_t, res.wall_shear("blade"), res.y_plus("blade")

Start from another solution with ``solve_steady(problem, settings, mapped_state(problem, other_results))``;
:func:`classify` tells converged, oscillating and drifting monitor histories apart; the classes are the
members of :class:`ConvergenceClass`, best first. The validation cases
(``millfoil validate``) live in :mod:`solver.validation`, which the solver core does not import.
"""

from .boundary import BOUNDARY_CONDITIONS, resolve_boundaries
from .convergence import ConvergenceClass, classify
from .fvmesh import FVMesh, MeshError, build_fvmesh, from_meshio, from_msh
from .linalg import LINEAR_SOLVERS, SolverSettings
from .problem import FlowState, Fluid, Problem, initial_state
from .results import FlowResults, Forces
from .settings import SimpleSettings
from .simple import solve_steady
from .turbulence import SST, SSTConstants
from .warmstart import mapped_state, potential_start

__all__ = [
    "BOUNDARY_CONDITIONS", "ConvergenceClass", "FVMesh", "FlowResults", "FlowState", "Fluid", "Forces",
    "LINEAR_SOLVERS", "MeshError", "Problem", "SST", "SSTConstants", "SimpleSettings", "SolverSettings",
    "build_fvmesh", "classify", "from_meshio", "from_msh", "initial_state", "mapped_state", "potential_start",
    "resolve_boundaries", "solve_steady",
]
