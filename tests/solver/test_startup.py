"""The gentle start-up of a solve: the first ``startup_iterations`` run at ``min(alpha_u, startup_alpha_u)``."""

import dataclasses

import solver.simple as simple
from solver import Problem, solve_steady
from solver.validation.cylinder import BOUNDARY_CONDITIONS, FLUID, LEVELS, cylinder_settings
from solver.validation.meshes import dfg_cylinder


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



def test_start_up_pressure_relaxation(monkeypatch):
    """``startup_alpha_p``: the start-up's iterations apply it, ``alpha_p`` is applied after them (the
    blades: 1, then 0.7: docs/decisions/0001-blade-pressure-gradient.md); None keeps ``alpha_p`` throughout, and so
    does SIMPLE, which needs its small ``alpha_p`` from the first iteration."""
    seen, real = [], simple.outer_iteration

    def spy(problem, state, cfg, solver_state):
        seen.append((cfg.alpha_u, cfg.pressure_relaxation))
        return real(problem, state, cfg, solver_state)

    monkeypatch.setattr(simple, "outer_iteration", spy)
    problem = Problem.create(dfg_cylinder(**LEVELS["coarse"]), BOUNDARY_CONDITIONS, FLUID)
    cfg = cylinder_settings(max_iter=5, alpha_u=0.95, alpha_p=0.7, startup_iterations=2, startup_alpha_u=0.95,
                            startup_alpha_p=1.0)
    solve_steady(problem, cfg)
    assert seen == [(0.95, 1.0)] * 2 + [(0.95, 0.7)] * 3
    seen.clear()
    solve_steady(problem, dataclasses.replace(cfg, startup_alpha_p_iterations=4))      # longer than the start-up
    assert seen == [(0.95, 1.0)] * 4 + [(0.95, 0.7)]
    seen.clear()
    solve_steady(problem, cylinder_settings(max_iter=3, alpha_p=0.7, startup_iterations=2, startup_alpha_p=None))
    assert [a_p for _, a_p in seen] == [0.7] * 3
    seen.clear()
    solve_steady(problem, cylinder_settings(max_iter=3, algorithm="simple", alpha_u=0.7, alpha_p=0.3,
                                            startup_iterations=2, startup_alpha_p=1.0))
    assert [a_p for _, a_p in seen] == [0.3] * 3
