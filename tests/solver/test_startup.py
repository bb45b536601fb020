"""The gentle start-up of a solve: the first ``startup_iterations`` run at ``min(alpha_u, startup_alpha_u)``."""

import pytest

pytest.importorskip("gmsh")

import solver.simple as simple  # noqa: E402
from solver import Problem, solve_steady  # noqa: E402
from solver.validation.cylinder import BOUNDARY_CONDITIONS, FLUID, LEVELS, cylinder_settings  # noqa: E402
from solver.validation.meshes import dfg_cylinder  # noqa: E402


def _relaxations(monkeypatch, settings) -> list[float]:
    """alpha_u of every outer iteration of a short cylinder solve."""
    seen, real = [], simple.outer_iteration

    def spy(problem, state, cfg, solver_state):
        seen.append(cfg.alpha_u)
        return real(problem, state, cfg, solver_state)

    monkeypatch.setattr(simple, "outer_iteration", spy)
    problem = Problem.create(dfg_cylinder(**LEVELS["coarse"]), BOUNDARY_CONDITIONS, FLUID)
    solve_steady(problem, settings)
    return seen


def test_first_iterations_run_at_the_start_up_relaxation(monkeypatch):
    cfg = cylinder_settings(max_iter=8, alpha_u=0.95, startup_iterations=3, startup_alpha_u=0.7, startup_ramp=0)
    assert _relaxations(monkeypatch, cfg) == [0.7] * 3 + [0.95] * 5


def test_start_up_never_raises_the_relaxation(monkeypatch):
    cfg = cylinder_settings(max_iter=4, alpha_u=0.5, startup_iterations=3, startup_alpha_u=0.7)
    assert _relaxations(monkeypatch, cfg) == [0.5] * 4


def test_start_up_off(monkeypatch):
    cfg = cylinder_settings(max_iter=4, alpha_u=0.9, startup_iterations=0)
    assert _relaxations(monkeypatch, cfg) == [0.9] * 4

