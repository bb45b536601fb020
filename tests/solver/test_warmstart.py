"""Warm start from a solution on another mesh: same converged answer, fields transferred sensibly."""

import numpy as np
import pytest

from solver import Problem, solve_steady
from solver.validation.cylinder import BOUNDARY_CONDITIONS, FLUID, LEVELS, coefficients, cylinder_settings
from solver.validation.meshes import dfg_cylinder
from solver.warmstart import mapped_state


@pytest.mark.slow
def test_warm_start_from_another_mesh_converges_to_the_same_answer():
    coarse = Problem.create(dfg_cylinder(**LEVELS["coarse"]), BOUNDARY_CONDITIONS, FLUID)
    source = solve_steady(coarse, cylinder_settings())
    target = Problem.create(dfg_cylinder(**{**LEVELS["coarse"], "n_quarter": 10}), BOUNDARY_CONDITIONS, FLUID)
    state = mapped_state(target, source)
    # the transferred field is the source flow, not a cold start: inlet-like speed in the channel core
    assert np.all(np.isfinite(state.u)) and np.abs(state.u).max() > 0.2 and not state.p.any()
    cold = solve_steady(target, cylinder_settings())
    warm = solve_steady(target, cylinder_settings(), state=state)
    assert cold.converged and warm.converged
    a, b = coefficients(cold).as_dict(), coefficients(warm).as_dict()
    for key in ("C_D", "dp"):
        assert b[key] == pytest.approx(a[key], rel=1e-5)


def test_potential_start_is_discretely_divergence_free_and_keeps_the_inflow():
    """The potential start (:func:`solver.potential_start`, the NACA 0012 case's start and the blades'
    ``solver.initial: potential``) projects the uniform flow onto the discretely divergence-free fluxes:
    every cell's net outflow vanishes to the projection's tolerance, the inlet flux is unchanged, and the
    flow speeds up past the cylinder (no uniform flow through it)."""
    from solver import potential_start

    problem = Problem.create(dfg_cylinder(**LEVELS["coarse"]), BOUNDARY_CONDITIONS, FLUID)
    m = problem.mesh
    state = potential_start(problem, (0.2, 0.0))
    ni = m.n_internal
    net = np.zeros(m.n_cells)
    np.add.at(net, m.owner, state.flux)
    np.add.at(net, m.neighbour[:ni], -state.flux[:ni])
    scale = np.abs(state.flux).max()
    assert np.abs(net).max() < 1e-6 * scale
    assert state.flux[ni:].sum() == pytest.approx(0.0, abs=1e-6 * scale)         # what enters leaves
    assert np.isfinite(state.u).all() and np.isfinite(state.p).all()
    assert np.linalg.norm(state.u, axis=1).max() > 1.3 * 0.2                        # accelerated past the body
