"""The campaign problem: design vectors, geometric feasibility, keys, payloads and the objective policy."""

from __future__ import annotations

import numpy as np
import pytest

from optimizer.campaign.config import load_campaign
from optimizer.campaign.problem import (
    FAILED_VALUE,
    FAILED_VIOLATION,
    BladeProblem,
    EmptySpaceError,
    initial_population,
    judge,
    make_problem,
)
from optimizer.campaign.record import blade_config, evaluate_analytic_payload


def campaign(tmp_path, text: str = "", *overrides: str):
    path = tmp_path / "c.yaml"
    path.write_text("blade: {mode: design, continuity: G1}\nmesh: {level: coarse}\n" + text)
    return load_campaign(path, overrides)


def solved(cls: str = "converged", fy: float = -9000.0, c_max: float = 25.0, monitors: dict | None = None,
           window: dict | None = None) -> dict:
    """A record as :func:`optimizer.campaign.record.record_of` writes it for a solve that ran."""
    return {"status": "solved", "reason": "r", "class": cls,
            "figures": {"fx": 300.0, "fy": fy, "c_l": 0.9, "c_max": c_max, "cp_wall_min": -5.0},
            "window_figures": window or {}, "monitors": monitors or {}, "missing": {}}


def monitors(fy=("stationary", -9000.0, 1.0), c_max=("stationary", 25.0, 0.01), fx=("stationary", 300.0, 0.1)):
    return {m: {"status": s, "mean": mean, "amplitude": amp}
            for m, (s, mean, amp) in (("fy:blade", fy), ("c_max", c_max), ("fx:blade", fx))}


def test_design_vector_is_the_table6_space(tmp_path):
    p = make_problem(campaign(tmp_path))
    assert isinstance(p, BladeProblem)
    assert p.names == ("alpha", "beta1", "beta1bar", "u_s2", "d_s1", "d_s2", "d_s3", "u_p2", "d_p1", "d_p2", "d_p3")
    assert p.lower[0] == -5.0 and p.upper[0] == 25.0
    fixed = campaign(tmp_path, "", "blade.fixed={alpha: 10}", "blade.bounds={beta1: [0, 5]}")
    q = make_problem(fixed)
    assert "alpha" not in q.names and q.blade_parameters(q.lower)["alpha"] == 10.0
    assert (q.lower[0], q.upper[0]) == (0.0, 5.0)


def test_objectives_follow_the_sense_and_abs(tmp_path):
    p = make_problem(campaign(tmp_path))
    a = p.assess(solved())
    assert a.status == "ok" and a.objectives == {"|fy|": 9000.0, "c_max": 25.0}
    assert a.minimised == [-9000.0, 25.0]            # pymoo minimises: |F_Y| negated
    assert a.constraints["evaluation"] == 0.0


def test_figure_constraints_are_scaled_g(tmp_path):
    p = make_problem(campaign(tmp_path, "constraints: [{figure: c_max, upper: 20}, {figure: c_l, lower: 0.5}]\n"))
    assert p.constraint_names == ("eq21_inlet", "eq21_outlet", "sides_simple", "c_max<=20", "c_l>=0.5",
                                  "evaluation")
    a = p.assess(solved(c_max=25.0))
    assert a.constraints["c_max<=20"] == pytest.approx(0.25)     # (25 - 20) / 20 > 0: violated
    assert a.constraints["c_l>=0.5"] == pytest.approx(-0.8)      # (0.5 - 0.9) / 0.5 <= 0: satisfied


def test_failures_enter_as_a_violated_constraint(tmp_path):
    p = make_problem(campaign(tmp_path))
    for status in ("mesh_failed", "diverged", "timeout", "worker_lost", "error"):
        a = p.assess({"status": status, "reason": "why"})
        assert a.status == status and a.objectives is None
        assert a.constraints["evaluation"] == FAILED_VIOLATION and a.minimised == [FAILED_VALUE, FAILED_VALUE]


def test_oscillating_accepted_below_amplitude_with_window_means(tmp_path):
    p = make_problem(campaign(tmp_path))
    small = monitors(fy=("oscillating", -9000.0, 45.0))            # 0.5 % of the mean
    a = p.assess(solved("oscillating", fy=-9100.0, monitors=small, window={"fy": -9000.0, "c_max": 25.0}))
    assert a.status == "ok" and a.convergence == "oscillating"
    assert a.objectives["|fy|"] == 9000.0                           # the window mean, not the last iterate
    large = monitors(fy=("oscillating", -9000.0, 900.0))            # 10 %
    b = p.assess(solved("oscillating", monitors=large))
    assert b.status == "oscillating" and "10.00% of its mean" in b.reason
    assert b.constraints["evaluation"] == FAILED_VIOLATION


def test_oscillating_policies(tmp_path):
    large = monitors(fy=("oscillating", -9000.0, 900.0))
    accept = make_problem(campaign(tmp_path, "convergence: {oscillating: accept_mean}\n"))
    assert accept.assess(solved("oscillating", monitors=large)).status == "ok"
    fail = make_problem(campaign(tmp_path, "convergence: {oscillating: fail}\n"))
    small = monitors(fy=("oscillating", -9000.0, 1.0))
    assert fail.assess(solved("oscillating", monitors=small)).status == "oscillating"


def test_class_is_judged_on_the_objectives_monitors(tmp_path):
    # the case: blades with lift and C_max steady and only the drag drifting
    p = make_problem(campaign(tmp_path))
    drag_drifts = monitors(fx=("not_converged", 300.0, 0.1))
    a = p.assess(solved("not_converged", monitors=drag_drifts))
    assert a.status == "ok" and a.convergence == "stationary"
    lift_drifts = monitors(fy=("not_converged", -9000.0, 1.0))
    b = p.assess(solved("not_converged", monitors=lift_drifts))
    assert b.status == "not_converged" and b.convergence == "not_converged"
    # a figure without a monitor falls back to the whole solve's class
    assert judge(solved("not_converged", monitors=drag_drifts), ["cp_wall_min"])[0] == "not_converged"
    assert judge(solved("converged", monitors=lift_drifts), ["fy"])[0] == "converged"


def test_geometric_feasibility_before_any_mesh(tmp_path):
    p = make_problem(campaign(tmp_path))
    x = p.lower.copy()
    x[p.names.index("alpha")], x[p.names.index("beta1")] = 0.0, 20.0     # beta1 > alpha: Eq. 21 violated
    f = p.check(x)
    assert not f.feasible and "eq21_inlet" in f.reason
    a = p.infeasible(f)
    assert a.status == "infeasible" and a.constraints["eq21_inlet"] > 0 and a.constraints["evaluation"] == 0.0


def test_keys_are_content_hashes(tmp_path):
    p = make_problem(campaign(tmp_path))
    X, _ = initial_population(p, 2, seed=1, max_draws=100)
    assert p.key(X[0]) == p.key(X[0].copy()) and p.key(X[0]) != p.key(X[1])
    medium = make_problem(campaign(tmp_path, "", "mesh.level=medium"))
    assert medium.key(X[0]) != p.key(X[0])                 # the mesh determines the result
    other_policy = make_problem(campaign(tmp_path, "convergence: {oscillating: fail}\n"))
    assert other_policy.key(X[0]) == p.key(X[0])           # the policy does not: the solve is the same


def test_payload_rebuilds_the_blade_config(tmp_path):
    config = campaign(tmp_path)
    p = make_problem(config)
    X, _ = initial_population(p, 1, seed=1, max_draws=100)
    c = blade_config(p.payload(X[0]))
    assert dict(c.blade.blade_spec().values) == p.blade_parameters(X[0])
    assert c.mesh_spec() == config.mesh_spec()


def test_initial_population_is_feasible_and_seeded(tmp_path):
    p = make_problem(campaign(tmp_path))
    X, draws = initial_population(p, 6, seed=4, max_draws=100)
    assert all(p.check(x).feasible for x in X) and draws >= 6
    Y, _ = initial_population(p, 6, seed=4, max_draws=100)
    assert np.array_equal(X, Y)


def test_nearly_empty_space_is_a_clear_error(tmp_path):
    p = make_problem(campaign(tmp_path, "", "blade.bounds={alpha: [-5, -4], beta1: [20, 30]}"))
    with pytest.raises(EmptySpaceError, match=r"only 0 of 40 random designs .* narrow blade.bounds"):
        initial_population(p, 4, seed=1, max_draws=10)


def test_zdt1_front():
    record = evaluate_analytic_payload({"kind": "analytic", "problem": "zdt1", "x": [0.25, 0, 0, 0]})
    assert (record.figures["f1"], record.figures["f2"]) == (0.25, 0.5)      # on the front f2 = 1 - sqrt(f1)
