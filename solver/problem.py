"""What a steady solve works on: the fluid, the problem (mesh + boundary conditions + model) and the iterate.

:class:`Problem` is built once per mesh (:meth:`Problem.create`) and read only; :class:`FlowState` is the
mutable iterate that :func:`solver.simple.outer_iteration` updates in place; :func:`initial_state` is the
cold start (:func:`solver.warmstart.mapped_state` the warm start).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .boundary import BoundaryData, resolve_boundaries
from .fvmesh import FVMesh
from .linalg import FVPattern
from .pressure import predicted_velocity_flux
from .turbulence import SST, SSTSetup, initial_fields


@dataclass(frozen=True)
class Fluid:
    """Constant-property fluid: density ``rho`` (kg/m³) and dynamic viscosity ``mu`` (Pa s)."""

    rho: float = 1.0
    mu: float = 1e-3


@dataclass
class FlowState:
    """Mutable iterate: velocity ``(nc, 2)`` m/s, pressure ``(nc,)`` Pa, face mass flux ``(nf,)`` kg/(s m),
    and the last gradients of p ``(nc, 2)`` and u ``(nc, 2, 2)`` (lagged boundary extrapolation).
    Turbulent runs also carry k ``(nc,)`` m²/s², omega ``(nc,)`` 1/s, nu_t ``(nc,)`` m²/s and the wall
    faces' effective viscosity ``mu_wall`` (Pa s, :class:`solver.turbulence.WallValues`); None if laminar."""

    u: np.ndarray
    p: np.ndarray
    flux: np.ndarray
    grad_p: np.ndarray
    grad_u: np.ndarray
    k: np.ndarray | None = None
    omega: np.ndarray | None = None
    nu_t: np.ndarray | None = None
    mu_wall: np.ndarray | None = None

    def copy(self) -> FlowState:
        """A deep copy (the iterate to fall back to after divergence)."""
        def cp(a):
            return None if a is None else a.copy()

        return FlowState(self.u.copy(), self.p.copy(), self.flux.copy(), self.grad_p.copy(), self.grad_u.copy(),
                         cp(self.k), cp(self.omega), cp(self.nu_t), cp(self.mu_wall))


@dataclass(frozen=True, eq=False)
class Problem:
    """A mesh with resolved boundary conditions, fluid and the FV sparsity pattern (built once).

    turbulence: None (laminar) or :class:`solver.turbulence.SST`; turbulence_setup: its per-mesh data
    (wall distance, inlet k and omega), built by :meth:`create`.
    """

    mesh: FVMesh
    bnd: BoundaryData
    fluid: Fluid
    pattern: FVPattern
    body_force: np.ndarray | None = None
    turbulence: SST | None = None
    turbulence_setup: SSTSetup | None = None

    @classmethod
    def create(cls, mesh: FVMesh, boundary_conditions: dict, fluid: Fluid = Fluid(),
               body_force: np.ndarray | None = None, turbulence: SST | None = None) -> Problem:
        """``body_force``: optional ``(nc, 2)`` force per unit volume at the cell centroids, N/m³.
        ``turbulence``: None (laminar) or ``solver.turbulence.SST(wall_treatment=..., constants=...)``;
        inlet turbulence from the ``velocity_inlet`` parameters ``intensity`` and ``viscosity_ratio``."""
        bnd = resolve_boundaries(mesh, boundary_conditions)
        setup = None
        if turbulence is not None:
            if not isinstance(turbulence, SST):
                raise TypeError(f"turbulence must be None or solver.turbulence.SST, not {type(turbulence)}")
            setup = turbulence.setup(mesh, bnd, fluid.rho, fluid.mu)
        return cls(mesh, bnd, fluid, FVPattern.from_mesh(mesh), body_force, turbulence, setup)


def initial_state(problem: Problem, u0=(0.0, 0.0)) -> FlowState:
    """Uniform velocity ``u0`` (m/s), zero pressure, fluxes consistent with the boundary values."""
    m, b = problem.mesh, problem.bnd
    u = np.broadcast_to(np.asarray(u0, float), (m.n_cells, 2)).copy()
    flux = predicted_velocity_flux(m, b, u, b.velocity(m, u), np.zeros((m.n_cells, 2, 2)), problem.fluid.rho)
    s = FlowState(u, np.zeros(m.n_cells), flux, np.zeros((m.n_cells, 2)), np.zeros((m.n_cells, 2, 2)))
    if problem.turbulence is not None:
        s.k, s.omega, s.nu_t = initial_fields(problem.turbulence_setup, m.n_cells)
    return s


def turbulent_fields(problem: Problem, s: FlowState) -> dict:
    """Keyword arguments of :class:`solver.results.FlowResults` for the turbulent fields (empty when
    laminar); ``mu_wall`` spread to all boundary faces (molecular viscosity off the walls)."""
    if problem.turbulence is None:
        return {}
    mu_wall = None
    if s.mu_wall is not None:
        mu_wall = np.full(problem.mesh.n_boundary, problem.fluid.mu)
        mu_wall[problem.turbulence_setup.wall_local] = s.mu_wall
    return dict(k=s.k, omega=s.omega, nu_t=s.nu_t, mu_wall=mu_wall,
                wall_treatment=problem.turbulence.wall_treatment)
