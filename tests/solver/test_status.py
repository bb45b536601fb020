"""The solver's convergence status: early stop on settled monitors, classification at the cap."""

import dataclasses

import pytest

from solver import Problem, solve_steady
from solver.validation.cylinder import BOUNDARY_CONDITIONS, FLUID, LEVELS, coefficients, cylinder_settings
from solver.validation.meshes import dfg_cylinder


@pytest.fixture(scope="module")
def problem():
    return Problem.create(dfg_cylinder(**LEVELS["coarse"]), BOUNDARY_CONDITIONS, FLUID)


@pytest.mark.slow
def test_drifting_solve_at_the_cap_is_not_converged(problem):
    """Heavy under-relaxation makes the forces creep towards their value: a drift, not an oscillation."""
    res = solve_steady(problem, dataclasses.replace(cylinder_settings(), alpha_u=0.05, max_iter=60,
                                                    classify_window=30))
    assert res.status == "not_converged" and res.classification is not None
    assert "reached max_iter = 60" in res.message and "drifting" in res.message
    assert res.classification.drift["fx:cylinder"] is not None


@pytest.mark.slow
def test_stalled_residuals_with_settled_forces_stop_as_converged(problem):
    reference = solve_steady(problem, cylinder_settings())
    stalled = dataclasses.replace(cylinder_settings(), tol=1e-14, stall_tol=1e-4, stop_window=30,
                                  stop_tol=1e-4, max_iter=1000)
    res = solve_steady(problem, stalled)
    assert res.status == "converged" and res.iterations < 1000
    assert "scaled residuals < 0.0001" in res.message
    assert coefficients(res).as_dict()["C_D"] == pytest.approx(coefficients(reference).as_dict()["C_D"], rel=1e-3)
