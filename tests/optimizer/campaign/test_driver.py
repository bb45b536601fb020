"""The campaign loop without CFD: ZDT1 through the driver (STYLE.md §8), and blade campaigns whose pipeline
is replaced by a stand-in that fails on purpose (a blade that cannot be meshed, a diverged solve)."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from optimizer.campaign import record
from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import CampaignError, final_population, resume_campaign, run_campaign
from optimizer.campaign.problem import FAILED_VIOLATION
from optimizer.campaign.runner import TaskResult
from optimizer.campaign.store import STORE_NAME, Store
from optimizer.evaluation import Evaluation
from solver.convergence import Classification


def zdt1_campaign(tmp_path, *overrides):
    path = tmp_path / "zdt1.yaml"
    path.write_text("analytic: {problem: zdt1, variables: 6}\n"
                    "objectives: [{figure: f1, reference: 1.1}, {figure: f2, reference: 1.1}]\n"
                    "algorithm: {population: 12, generations: 6, seed: 2}\n"
                    "execution: {backend: inline}\noutput: {sync: normal}\n")
    return load_campaign(path, overrides)


def zdt1_front_hypervolume() -> float:
    """Hypervolume of the ZDT1 front f2 = 1 - sqrt(f1), f1 in [0, 1], against (1.1, 1.1): the box
    1.1² minus the area under the front (1/3)."""
    return 1.1 * 1.1 - 1.0 / 3.0


class CountingRunner:
    """The inline runner, counting the keys it is asked to evaluate (a key twice would be a bug)."""

    def __init__(self):
        self.keys: list[str] = []
        self.workers = 1

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass

    def run(self, fn, tasks):
        for task in tasks:
            self.keys.append(task.key)
            yield TaskResult(task.key, task.generation, fn(task.payload), "done", "", "", 0.0)


def test_zdt1_stores_every_evaluation_and_generation(tmp_path):
    # a reference far enough for the first generations' designs to count (the default 1.1 is for the front)
    config = zdt1_campaign(tmp_path, "objectives=[{figure: f1, reference: 1.1}, {figure: f2, reference: 10}]")
    runner = CountingRunner()
    outcome = run_campaign(config, tmp_path / "run", runner=runner)
    assert outcome.state == "finished" and outcome.generations == 6
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        rows = list(store.evaluations())
        generations = store.generations()
        assert store.campaign().state == "finished"
    assert len(rows) == len(runner.keys) == len(set(runner.keys))     # each design evaluated once
    assert [g.generation for g in generations] == list(range(6))
    assert all(len(g.members) == 12 for g in generations)
    hv = [g.hypervolume for g in generations]
    # (not monotone in general: crowding truncation of a first front larger than the population may drop
    # a design that held hypervolume)
    assert all(h is not None and h > 0 for h in hv) and hv[-1] > hv[0]
    assert outcome.front and all(r.feasible for r in outcome.front)


@pytest.mark.slow
def test_zdt1_converges_to_the_known_front(tmp_path):
    """NSGA-II through the campaign loop reaches 97 % of the hypervolume of ZDT1's front (Deb et al. 2002
    report near-complete convergence on ZDT1 in 250 generations of 100; 60 of 40 suffice for 97 %)."""
    config = zdt1_campaign(tmp_path, "algorithm.population=40", "algorithm.generations=60")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        hv = store.last_generation().hypervolume
    assert hv >= 0.97 * zdt1_front_hypervolume()


def test_a_run_directory_is_not_overwritten(tmp_path):
    config = zdt1_campaign(tmp_path, "algorithm.generations=1")
    run_campaign(config, tmp_path / "run")
    with pytest.raises(CampaignError, match="already holds a campaign.*millfoil resume"):
        run_campaign(config, tmp_path / "run")


def test_resume_after_an_interrupt_equals_an_uninterrupted_run(tmp_path):
    config = zdt1_campaign(tmp_path)
    run_campaign(config, tmp_path / "whole")

    def interrupt_in_generation_3(p):
        if p.generation == 3 and p.done == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(config, tmp_path / "cut", progress=interrupt_in_generation_3)
    with Store(tmp_path / "cut" / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "interrupted"
        before = {r.key: r.finished for r in store.evaluations()}
        assert len(store.generations()) == 3
    runner = CountingRunner()
    resume_campaign(tmp_path / "cut", runner=runner)
    assert not set(runner.keys) & set(before)          # nothing stored is evaluated again
    with Store(tmp_path / "whole" / STORE_NAME, readonly=True) as a, \
            Store(tmp_path / "cut" / STORE_NAME, readonly=True) as b:
        assert final_population(a) == final_population(b)
        assert {r.key for r in a.evaluations()} == {r.key for r in b.evaluations()}
        assert all(b.get(k).finished == t for k, t in before.items())     # stored rows untouched


# ---------------------------------------------------------------------------------------- blades
def fake_pipeline(config, *, log=None, every=0, warm_start=None):
    """A stand-in for :func:`optimizer.pipeline.evaluate` with failures on purpose: blades with
    α > 18° cannot be meshed, α < 2° diverge, the rest converge with |F_Y| and C_max growing with α."""
    alpha = config.blade.parameters["alpha"]
    if alpha > 18.0:
        return Evaluation("failed", "mesh", "MeshQualityError: minimum angle 3.1° < 15°", seconds={"mesh": 0.1})
    if alpha < 2.0:
        return Evaluation("diverged", "solve", "residuals exceeded 1e10 at iteration 57", cells=5000,
                          iterations=57, seconds={"mesh": 0.1, "solve": 0.2})
    fy, c_max = -1000.0 * alpha, 20.0 + alpha ** 1.5 / 10
    cls = Classification("converged", {"fy:blade": fy, "c_max": c_max, "fx:blade": 10.0},
                         {"fy:blade": 0.0, "c_max": 0.0, "fx:blade": 0.0}, {}, {}, 200, "converged",
                         {"fy:blade": "stationary", "c_max": "stationary", "fx:blade": "stationary"})
    return Evaluation("converged", None, "converged", converged=True, classification=cls, fx=10.0, fy=fy,
                      c_max=c_max, span=0.004, chord=0.1, cells=5000, iterations=900,
                      seconds={"mesh": 0.1, "solve": 0.3})


@pytest.fixture
def failing_pipeline(monkeypatch):
    monkeypatch.setattr(record, "_pipeline", lambda: fake_pipeline)


def blade_campaign(tmp_path, *overrides):
    path = tmp_path / "blade.yaml"
    path.write_text("blade: {mode: design, continuity: G1}\nmesh: {level: coarse}\n"
                    "algorithm: {population: 8, generations: 3, seed: 5}\n"
                    "execution: {backend: inline}\noutput: {sync: normal}\n")
    return load_campaign(path, overrides)


def test_failed_evaluations_are_recorded_and_the_campaign_finishes(tmp_path, failing_pipeline):
    runner = CountingRunner()
    outcome = run_campaign(blade_campaign(tmp_path), tmp_path / "run", runner=runner)
    assert outcome.state == "finished"
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        rows = list(store.evaluations())
        generations = store.generations()
    by_status = {s: [r for r in rows if r.status == s] for s in {r.status for r in rows}}
    assert {"ok", "mesh_failed", "diverged"} <= set(by_status), set(by_status)
    for r in by_status["mesh_failed"]:
        assert "MeshQualityError" in r.reason and r.objectives is None
        assert r.constraints["evaluation"] == FAILED_VIOLATION
    for r in by_status["diverged"]:
        assert r.iterations == 57 and r.cells == 5000
    # infeasible geometries are stored with their reason and never reach the runner
    infeasible = by_status.get("infeasible", [])
    assert not {r.key for r in infeasible} & set(runner.keys)
    assert all("eq21" in r.reason or "sides" in r.reason for r in infeasible)
    # the feasible share of each generation's offspring is recorded
    for g in generations:
        offspring = [r for r in rows if r.key in set(g.offspring)]
        assert g.feasible_offspring == sum(1 for r in offspring if r.status != "infeasible")
    # no failure reaches the front
    assert outcome.front and all(r.status == "ok" for r in outcome.front)
    assert all(2.0 <= r.parameters["alpha"] <= 18.0 for r in outcome.front)


def test_a_stored_design_is_not_evaluated_again(tmp_path, failing_pipeline):
    """A design asked for again (here: the whole campaign resumed from its last generation's state after
    deleting that generation's row) comes from the store."""
    config = blade_campaign(tmp_path, "algorithm.generations=2")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME) as store:
        store._db.execute("DELETE FROM generations WHERE generation = 1")
        store._db.commit()
        stored = {r.key for r in store.evaluations()}
    runner = CountingRunner()
    resume_campaign(tmp_path / "run", runner=runner)
    assert runner.keys == []
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        assert {r.key for r in store.evaluations()} == stored
        assert store.last_generation().cache_hits == 0        # the same generation again: not a cache hit


@pytest.mark.slow
def test_resume_with_infeasible_and_failed_members_equals_an_uninterrupted_run(tmp_path, failing_pipeline):
    """Infeasible and failed designs in the population (no rank, no crowding) survive the rebuild too."""
    config = blade_campaign(tmp_path)
    run_campaign(config, tmp_path / "whole")

    def interrupt(p):
        if p.generation == 2 and p.done + p.failed == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(config, tmp_path / "cut", progress=interrupt)
    resume_campaign(tmp_path / "cut")
    with Store(tmp_path / "whole" / STORE_NAME, readonly=True) as a, \
            Store(tmp_path / "cut" / STORE_NAME, readonly=True) as b:
        assert final_population(a) == final_population(b)
        assert [g.members for g in a.generations()] == [g.members for g in b.generations()]
        assert any(r.status != "ok" for r in a.evaluations())


def test_worker_failures_become_statuses(tmp_path, failing_pipeline):
    class LosingRunner(CountingRunner):
        def run(self, fn, tasks):
            for i, task in enumerate(tasks):
                status = ("timeout", "worker_lost", "error", "done")[i % 4]
                rec = fn(task.payload) if status == "done" else None
                yield TaskResult(task.key, task.generation, rec, status, f"{status} on purpose", "w", 1.0)

    run_campaign(blade_campaign(tmp_path, "algorithm.generations=1"), tmp_path / "run", runner=LosingRunner())
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        statuses = {r.status for r in store.evaluations()}
        reasons = {r.reason for r in store.evaluations()}
    assert {"timeout", "worker_lost", "error"} <= statuses
    assert "worker_lost on purpose" in reasons


def test_deadline_stops_the_solve_as_timeout(monkeypatch):
    """The runner's deadline: the record says timeout when the pipeline's progress callback passes it."""
    def slow_pipeline(config, *, log=None, every=0, warm_start=None):
        try:
            log("solve: iteration 1")
        except Exception as exc:     # the pipeline records an exception in a stage as a failed stage
            return Evaluation("failed", "solve", f"unexpected {type(exc).__name__}: {exc}")
        return fake_pipeline(config)

    monkeypatch.setattr(record, "_pipeline", lambda: slow_pipeline)
    from optimizer.campaign.config import CampaignConfig
    from optimizer.campaign.problem import BladeProblem, initial_population

    p = BladeProblem(CampaignConfig.model_validate({"blade": {"mode": "design", "continuity": "G1"}}))
    X, _ = initial_population(p, 1, 1, 100)
    out = record.evaluate_payload({**p.payload(X[0]), "deadline_s": 0.0})
    assert out.status == "timeout" and "deadline" in out.reason
    ok = record.evaluate_payload({**p.payload(X[0]), "deadline_s": 1e12})
    assert ok.solved and ok.status == "solved"


def test_record_of_a_real_evaluation_shape():
    ev = fake_pipeline(type("C", (), {"blade": type("B", (), {"parameters": {"alpha": 10.0}})()})())
    cfg = load_campaign(None)
    rec = record.record_of(ev, cfg)
    assert rec.status == "solved" and rec.convergence == "converged"
    assert rec.figures["fy"] == -10000.0 and rec.window_figures["fy"] == -10000.0
    assert rec.window_figures["c_l"] == pytest.approx(-10000.0 / (0.5 * 998.2 * 100 * 0.1))
    assert np.isfinite(rec.monitors["c_max"]["mean"])
    # the record crosses to the driver by pickle and reads back from its dict unchanged
    assert pickle.loads(pickle.dumps(rec)) == rec
    d = rec.to_dict()
    assert record.EvaluationRecord.from_dict(json.loads(json.dumps(d))) == rec and d["class"] == "converged"
