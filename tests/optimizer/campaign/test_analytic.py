"""The analytic problems a campaign can run in place of the blade: pymoo's values through the worker, their
own constraints in the optimiser's constraint vector, and injected failures that behave like failed solves."""

from __future__ import annotations

import numpy as np
import pytest

from optimizer.campaign.config import ANALYTIC, ConfigError, load_campaign
from optimizer.campaign.driver import run_campaign
from optimizer.campaign.problem import make_problem
from optimizer.campaign.record import evaluate_analytic_payload, hidden_region, injected_failure
from optimizer.campaign.store import STORE_NAME, Store


def campaign(tmp_path, analytic: str, *overrides):
    path = tmp_path / "analytic.yaml"
    path.write_text(f"analytic: {analytic}\nalgorithm: {{population: 10, generations: 3, seed: 3}}\n"
                    "execution: {backend: inline}\noutput: {sync: normal}\n")
    return load_campaign(path, overrides)


def _pymoo_class(name: str):
    """pymoo's class of each benchmark, named here rather than looked up by name as the worker does."""
    from pymoo.problems.many.dtlz import DTLZ2
    from pymoo.problems.multi.mw import MW1, MW2, MW3, MW7
    from pymoo.problems.multi.zdt import ZDT1, ZDT2, ZDT3

    return {"zdt1": ZDT1, "zdt2": ZDT2, "zdt3": ZDT3, "dtlz2": DTLZ2, "mw1": MW1, "mw2": MW2, "mw3": MW3,
            "mw7": MW7}[name]


@pytest.mark.parametrize("name", sorted(ANALYTIC))
def test_the_worker_reports_pymoo_values(name):
    x = np.random.default_rng(1).random(8)
    record = evaluate_analytic_payload({"kind": "analytic", "problem": name, "x": list(x)})
    cls = _pymoo_class(name)
    problem = cls(n_var=8, n_obj=2) if name == "dtlz2" else cls(n_var=8)
    expected = problem.evaluate(x[None], return_as_dictionary=True)
    assert [record.figures["f1"], record.figures["f2"]] == list(expected["F"][0])
    constraints = [v for k, v in sorted(record.figures.items()) if k.startswith("g")]
    assert constraints == (list(np.atleast_2d(expected["G"])[0]) if "G" in expected and expected["G"] is not None
                           and np.size(expected["G"]) else [])


def test_mw_constraints_enter_the_constraint_vector(tmp_path):
    problem = make_problem(campaign(tmp_path, "{problem: mw3, variables: 6}"))
    assert problem.constraint_names == ("g1", "g2", "evaluation")
    record = evaluate_analytic_payload(problem.payload(np.full(6, 0.5)))
    a = problem.assess(record)
    assert a.constraints["g1"] == record.figures["g1"] and a.constraints["g2"] == record.figures["g2"]
    assert a.constraints["evaluation"] == 0.0


def test_hidden_region_takes_its_share_of_the_box():
    (i, j), lower, upper = hidden_region(10, 0.07, seed=4)
    assert i != j and np.all(lower >= 0) and np.all(upper <= 1)
    assert np.prod(upper - lower) == pytest.approx(0.07)
    X = np.random.default_rng(0).random((20000, 10))
    failed = [injected_failure(list(x), {"region": 0.07, "seed": 4}) is not None for x in X]
    assert np.mean(failed) == pytest.approx(0.07, abs=0.01)


def test_random_failures_are_a_property_of_the_design():
    X = np.random.default_rng(1).random((5000, 4))
    first = [injected_failure(list(x), {"random": 0.02}) for x in X]
    assert [injected_failure(list(x), {"random": 0.02}) for x in X] == first
    share = np.mean([f is not None for f in first])
    assert share == pytest.approx(0.02, abs=0.006)
    assert {f[0] for f in first if f} == {"solve_failed"}


def test_injected_failures_are_stored_as_failed_evaluations(tmp_path):
    config = campaign(tmp_path, "{problem: zdt1, variables: 4, failures: {region: 0.1, random: 0.05, seed: 2}}")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        by_status = store.count_by_status()
    assert by_status.get("ok", 0) > 0 and by_status.get("diverged", 0) + by_status.get("solve_failed", 0) > 0


def test_no_failures_keep_the_design_keys(tmp_path):
    plain = make_problem(campaign(tmp_path, "{problem: zdt1, variables: 4}"))
    zero = make_problem(campaign(tmp_path, "{problem: zdt1, variables: 4, failures: {region: 0}}"))
    failing = make_problem(campaign(tmp_path, "{problem: zdt1, variables: 4, failures: {region: 0.1}}"))
    x = np.full(4, 0.3)
    assert plain.key(x) == zero.key(x) != failing.key(x)


def test_the_written_configuration_reads_back_without_a_warning(tmp_path):
    """A run directory's config.yaml is what `millfoil resume` reads: it must not warn of a blade the
    analytic campaign never had."""
    import warnings

    config = campaign(tmp_path, "{problem: zdt1, variables: 4}")
    path = tmp_path / "config.yaml"
    path.write_text(config.to_yaml())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = load_campaign(path)
    assert again.to_yaml() == config.to_yaml()
    assert again.analytic == config.analytic and again.algorithm == config.algorithm


def test_an_unknown_problem_names_the_allowed_ones(tmp_path):
    with pytest.raises(ConfigError, match=r"analytic.problem.*zdt1.*mw7"):
        campaign(tmp_path, "{problem: zdt9}")


def test_a_failed_design_ranks_behind_every_evaluated_one(tmp_path):
    """With injected failures on a constrained problem, plain NSGA-II must not drift into the failing region:
    a failed design ranks behind designs that violate the problem's own constraints by any amount."""
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.driver import run_campaign
    from optimizer.campaign.store import STORE_NAME, Store

    path = tmp_path / "mw2.yaml"
    path.write_text("analytic: {problem: mw2, variables: 15, failures: {region: 0.07, random: 0.02, seed: 0}}\n"
                    "algorithm: {population: 40, generations: 12, seed: 1}\nexecution: {backend: inline}\n"
                    "output: {sync: normal}\n")
    run_campaign(load_campaign(path, []), tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        last = [r for r in store.evaluations() if r.generation >= 9]
    failed = sum(not r.ok for r in last) / len(last)
    assert failed < 0.2, f"{failed:.0%} of the last generations' designs failed"
