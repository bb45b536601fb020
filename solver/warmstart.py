"""Initial iterates other than the uniform start: a converged solution on another mesh (warm start), or the
potential flow (:func:`potential_start`).

Warm start: an initial iterate on one mesh from a converged solution on another.

In a campaign, neighbouring blades have similar flows; starting a solve from a neighbour's solution
instead of the free stream saves outer iterations (the paper starts every blade from the solution of
the blade in the middle of the parameter ranges, §3.2). The meshes differ (each blade has its own), so
the fields are transferred cell by cell: each target cell takes the values of the source cell whose
centroid is nearest (k and ω floored to the cold-start minimum); the pressure starts from zero. The
donor's pressure is not transferred: its stagnation and suction peaks sit where the donor blade had them,
and on the benchmark blade (coarse, SIMPLE) that start diverged within 6 iterations, while velocity and
turbulence alone converged in 750 iterations against 1 030 from the free stream (cold turbulence with
the donor's velocity: 1 550). No gradient extrapolation either: a target
centroid inside the donor blade lies next to the donor's boundary layer, where the velocity gradient is
~U/y and extrapolating over millimetres gave 3e4 m/s and an immediate divergence. Fluxes are rebuilt
from the transferred velocity; the first outer iterations repair the mismatch near the new wall.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from .gradient import ls_gradient
from .linalg import SolverSettings
from .pressure import correct_flux, predicted_velocity_flux, pressure_correction_system
from .problem import FlowState, Problem, initial_state
from .results import FlowResults


def mapped_state(problem: Problem, source: FlowResults) -> FlowState:
    """Initial :class:`FlowState` on ``problem.mesh`` from ``source`` (a solution on any other mesh of the
    same domain). Turbulence fields are transferred when both sides have them, else initialised as for a
    cold start."""
    mesh = problem.mesh
    _, near = cKDTree(source.mesh.centroid).query(mesh.centroid)
    u = source.u[near].copy()
    state = initial_state(problem)
    state.u = u
    state.flux = predicted_velocity_flux(mesh, problem.bnd, u, problem.bnd.velocity(mesh, u),
                                         np.zeros((mesh.n_cells, 2, 2)), problem.fluid.rho)
    if state.k is not None and getattr(source, "k", None) is not None:
        floor_k, floor_w = state.k.min(), state.omega.min()
        state.k = np.maximum(source.k[near], floor_k)
        state.omega = np.maximum(source.omega[near], floor_w)
        if getattr(source, "nu_t", None) is not None:
            state.nu_t = np.maximum(source.nu_t[near], 0.0)
    return state


#: Linear solver of the potential-flow projection of :func:`potential_start` (converged tightly: the start
#: must be divergence free).
POTENTIAL_SOLVER = SolverSettings("amg", 1e-10, 500)


def potential_start(problem: Problem, u_inf, solver: SolverSettings = POTENTIAL_SOLVER) -> FlowState:
    """Initial state: the potential flow around the walls (slip there) and its Bernoulli pressure;
    ``u_inf`` the free-stream velocity (m/s, 2-vector).

    An impulsive start (uniform U∞ through the wall) leaves cells at the leading edge with a net inflow
    larger than their outflow, so that the SIMPLEC coefficient ``a_P/alpha - sum a_nb`` is negative there
    at high Re and the first iterations explode (measured on this mesh: Re >= 1e4). One projection of the
    uniform flow with the solver's own pressure-correction operator (``D̃ = 1``) gives discretely
    divergence-free fluxes: ``F = F0 - grad_f phi``, ``u = U∞ - grad phi``, ``p = (|U∞|² - |u|²)/2``.
    """
    m, b, rho = problem.mesh, problem.bnd, problem.fluid.rho
    s = initial_state(problem, tuple(u_inf))
    pc = pressure_correction_system(m, problem.pattern, b, s.flux, np.ones(m.n_cells), rho)
    phi, _ = solver.solve(pc.system, {})
    s.flux = correct_flux(m, s.flux, pc.coef, phi)
    phi_b = np.where(b.p_fixed, 0.0, phi[m.owner[m.n_internal:]])
    s.u = s.u - ls_gradient(m, phi, phi_b)
    s.p = 0.5 * rho * (float(np.dot(u_inf, u_inf)) - (s.u**2).sum(axis=1))
    return s


#: Initial fields by name: ``f(problem, u_inf) -> FlowState`` with ``u_inf`` the free-stream velocity (m/s,
#: 2-vector): ``freestream`` (uniform ``u_inf``), ``rest`` (zero velocity) or ``potential`` (the potential flow
#: around the walls, :func:`potential_start`). docs/decisions/0016-initial-field.md.
INITIAL_FIELDS: dict[str, Callable[[Problem, tuple[float, float]], FlowState]] = {
    "freestream": lambda problem, u_inf: initial_state(problem, tuple(u_inf)),
    "rest": lambda problem, u_inf: initial_state(problem, (0.0, 0.0)),
    "potential": potential_start,
}
