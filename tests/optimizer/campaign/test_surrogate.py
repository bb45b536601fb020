"""The surrogate-assisted search: hypervolume improvement, the models, the batch choice, feasible offspring
in plain mode, and a surrogate campaign through the driver and store."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from optimizer.campaign.config import ConfigError, SurrogateSettings, load_campaign
from optimizer.campaign.driver import run_campaign
from optimizer.campaign.infill import boundary_midpoints, choose, hypervolume_improvement, search_coordinates
from optimizer.campaign.offspring import FeasibleOffspring, portfolio
from optimizer.campaign.progress import format_status, search_text, status_of
from optimizer.campaign.store import STORE_NAME, Store, non_dominated
from optimizer.campaign.surrogate import BatchConditioning, Models, Prediction, TrainingData


def campaign(tmp_path, text: str, *overrides):
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return load_campaign(path, overrides)


ZDT1 = ("analytic: {problem: zdt1, variables: 8}\n"
        "objectives: [{figure: f1, reference: 1.1}, {figure: f2, reference: 10}]\n"
        "algorithm: {population: 20, generations: 6, seed: 5}\n"
        "execution: {backend: inline}\noutput: {sync: normal}\n")


# ------------------------------------------------------------------------------------- hypervolume
@pytest.mark.parametrize("m", [2, 3])
def test_hypervolume_improvement_is_the_hypervolume_difference(m):
    from pymoo.indicators.hv import HV

    rng = np.random.default_rng(m)
    front = rng.random((12, m))
    front = front[non_dominated(front)]
    points = rng.random((30, m)) * 1.2
    reference = np.full(m, 1.1)
    hv = HV(ref_point=reference)
    expected = [hv(np.vstack([front, p])) - hv(front) if np.all(p < reference) else 0.0 for p in points]
    assert hypervolume_improvement(front, points, reference) == pytest.approx(expected, abs=1e-12)


def test_improvement_against_an_empty_front_is_the_dominated_box():
    gain = hypervolume_improvement(np.zeros((0, 2)), np.array([[0.1, 0.6], [2.0, 0.0]]), np.array([1.0, 1.0]))
    assert gain == pytest.approx([0.9 * 0.4, 0.0])


# ------------------------------------------------------------------------------------------ models
def test_the_models_predict_out_of_sample_and_learn_where_designs_fail():
    rng = np.random.default_rng(0)
    X = rng.random((80, 3))
    failed = X[:, 0] > 0.8
    F = np.column_stack([np.sin(3 * X[:, 0]) + X[:, 1], (X[:, 2] - 0.5) ** 2])
    data = TrainingData(X, failed, np.where(failed[:, None], np.nan, F), np.zeros((80, 0)), np.zeros(80),
                        np.arange(80.0))
    models = Models(np.zeros(3), np.ones(3), ["a", "b"], []).fit(data, cap=80)
    Y = rng.random((40, 3)) * [0.8, 1, 1]
    truth = np.column_stack([np.sin(3 * Y[:, 0]) + Y[:, 1], (Y[:, 2] - 0.5) ** 2])
    p = models.predict(Y)
    assert np.all(np.sqrt(np.mean((p.mean - truth) ** 2, axis=0)) < 0.05 * truth.std(axis=0) + 1e-3)
    assert p.std.shape == (40, 2) and p.g_mean.shape == (40, 0)
    fail_side = models.predict(np.array([[0.95, 0.5, 0.5]])).p_fail[0]
    safe_side = models.predict(np.array([[0.2, 0.5, 0.5]])).p_fail[0]
    assert fail_side > 0.5 > safe_side
    assert set(models.theta()) == {"a", "b", "failure"}


def test_a_warm_start_from_stored_hyperparameters_gives_the_same_models():
    rng = np.random.default_rng(1)
    X = rng.random((40, 2))
    data = TrainingData(X, np.zeros(40, bool), X.sum(axis=1, keepdims=True), np.zeros((40, 0)), np.zeros(40),
                        np.arange(40.0))
    first = Models(np.zeros(2), np.ones(2), ["s"], []).fit(data, cap=40)
    again = Models(np.zeros(2), np.ones(2), ["s"], []).fit(data, cap=40)
    assert first.theta() == again.theta()
    warm = Models(np.zeros(2), np.ones(2), ["s"], []).fit(data, cap=40, theta=first.theta())
    assert np.allclose(warm.predict(X[:5]).mean, first.predict(X[:5]).mean, atol=1e-6)


def test_the_newest_designs_are_learnt_from_whatever_their_rank():
    """Forty designs near the front (rank 0) and, newest, five far from it that turned out badly (rank 9):
    with a cap of forty the campaign's rule never learns the five; keeping the newest, it does."""
    rng = np.random.default_rng(2)
    X = np.vstack([rng.random((40, 2)) * 0.5, 0.8 + 0.2 * rng.random((5, 2))])
    F = (X ** 2).sum(axis=1, keepdims=True)
    rank = np.r_[np.zeros(40), np.full(5, 9.0)]
    data = TrainingData(X, np.zeros(45, bool), F, np.zeros((45, 0)), rank, np.arange(45.0))
    by_rank = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40)
    with_newest = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40, recent=5)
    assert by_rank.training_size == with_newest.training_size == 40
    far = slice(40, 45)
    assert np.abs(with_newest.predict(X[far]).mean - F[far]).max() < 0.02
    assert np.abs(by_rank.predict(X[far]).mean - F[far]).max() > 0.1


def test_the_first_designs_keep_the_box_in_view():
    """Twenty designs spread over the box first (rank 9: far from the front), then forty crowded near the
    front (rank 0): with a cap of forty the campaign's rule forgets the box and predicts its corners from
    the front's values; keeping the first twenty, it knows them."""
    rng = np.random.default_rng(3)
    X = np.vstack([rng.random((20, 2)), 0.45 + 0.1 * rng.random((40, 2))])
    F = ((X - 0.5) ** 2).sum(axis=1, keepdims=True)
    rank = np.r_[np.full(20, 9.0), np.zeros(40)]
    data = TrainingData(X, np.zeros(60, bool), F, np.zeros((60, 0)), rank, np.arange(60.0))
    by_rank = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40)
    with_first = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40, initial=20, recent=5)
    assert by_rank.training_size == with_first.training_size == 40
    corners = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]])
    truth = ((corners - 0.5) ** 2).sum(axis=1)
    assert np.abs(with_first.predict(corners).mean[:, 0] - truth).max() < 0.1
    assert np.abs(by_rank.predict(corners).mean[:, 0] - truth).max() > 0.2



def test_hyperparameters_from_the_first_designs_keep_their_units_when_conditioned_on_the_front():
    """``hyperparameter_initial``: with every design in both sets the models are those fitted the usual way;
    with the first twenty for the hyperparameters and the forty near the front to predict from, the models
    predict the front as those fitted on it do."""
    rng = np.random.default_rng(3)
    X = np.vstack([rng.random((20, 2)), 0.45 + 0.1 * rng.random((40, 2))])
    F = 3.0 + 10.0 * ((X - 0.5) ** 2).sum(axis=1, keepdims=True)
    rank = np.r_[np.full(20, 9.0), np.zeros(40)]
    data = TrainingData(X, np.zeros(60, bool), F, np.zeros((60, 0)), rank, np.arange(60.0))
    usual = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=60)
    both = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=60, hyperparameter_initial=20)
    Y = rng.random((10, 2))
    assert both.theta() == usual.theta()
    np.testing.assert_array_equal(both.predict(Y).mean, usual.predict(Y).mean)
    by_rank = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40)
    split = Models(np.zeros(2), np.ones(2), ["f"], []).fit(data, cap=40, hyperparameter_initial=20)
    assert split.training_size == 40
    near = 0.47 + 0.06 * rng.random((10, 2))
    truth = 3.0 + 10.0 * ((near - 0.5) ** 2).sum(axis=1)
    assert np.abs(split.predict(near).mean[:, 0] - truth).max() < 0.01
    assert np.abs(by_rank.predict(near).mean[:, 0] - truth).max() < 0.01


@pytest.mark.slow
def test_models_fitted_side_by_side_are_those_fitted_one_after_another(monkeypatch):
    import optimizer.campaign.surrogate as surrogate

    rng = np.random.default_rng(2)
    X = rng.random((60, 4))
    failed = X[:, 3] > 0.85
    F = np.column_stack([np.sin(3 * X[:, 0]) + X[:, 1], X[:, 2] ** 2, X[:, :2].sum(axis=1)])
    data = TrainingData(X, failed, np.where(failed[:, None], np.nan, F[:, :2]), F[:, 2:], np.zeros(60),
                        np.arange(60.0))
    fit = lambda: Models(np.zeros(4), np.ones(4), ["a", "b"], ["g"], kernel="warped").fit(data, cap=60)  # noqa: E731
    monkeypatch.setattr(surrogate, "_cores", lambda: 4)
    side_by_side = fit()
    monkeypatch.setattr(surrogate, "_cores", lambda: 1)
    one_by_one = fit()
    assert side_by_side.theta() == one_by_one.theta()
    assert list(side_by_side.theta()) == ["a", "b", "g", "failure"]


@pytest.mark.parametrize("kernel", ["product", "warped"])
def test_conditioning_on_chosen_designs_is_the_gaussian_posterior_given_them(kernel):
    """Each chosen design taken as observed (with the fitted noise) at its predicted value: the pool's
    variances are the Schur complement of the joint posterior covariance, for one design and for two."""
    rng = np.random.default_rng(5)
    X = rng.random((40, 3))
    F = np.column_stack([np.sin(4 * X[:, 0]) + X[:, 1], (X ** 2).sum(axis=1)])
    G = X[:, 2:] - 0.5
    data = TrainingData(X, np.zeros(40, bool), F, G, np.zeros(40), np.arange(40.0))
    models = Models(np.zeros(3), np.ones(3), ["a", "b"], ["g"], kernel=kernel).fit(data, cap=40)
    pool = rng.random((30, 3))
    conditioning = BatchConditioning(models, pool)
    for chosen in ([7], [7, 19]):
        shrink, g_shrink = conditioning.condition(chosen[-1])
        for label, factor in (("a", shrink[:, 0]), ("b", shrink[:, 1]), ("g", g_shrink[:, 0])):
            gp = models.gaussian_process(label)
            _, cov = gp.predict(pool, return_cov=True)          # the noise on its diagonal
            rest = np.setdiff1d(np.arange(30), chosen)
            C, c = cov[np.ix_(rest, rest)], cov[np.ix_(rest, chosen)]
            conditioned = np.diag(C) - np.einsum("ij,ij->i", c @ np.linalg.inv(cov[np.ix_(chosen, chosen)]), c)
            # the fitted variances dwarf the posterior ones: both sides lose digits to cancellation
            np.testing.assert_allclose(factor[rest], np.sqrt(conditioned / np.diag(C)), rtol=1e-3)
    assert np.all(shrink <= 1.0) and shrink[7].max() < 0.5


# ------------------------------------------------------------------------------------------ choice
def _prediction(mean, std=None, p_fail=None):
    mean = np.asarray(mean, float)
    n = len(mean)
    return Prediction(mean, np.zeros_like(mean) if std is None else np.asarray(std, float), np.zeros((n, 0)),
                      np.zeros((n, 0)), np.zeros(n) if p_fail is None else np.asarray(p_fail, float))


def test_the_batch_improves_the_front_and_skips_evaluated_and_failing_designs():
    X = np.linspace(0, 1, 6)[:, None]
    mean = [[0.5, 0.5], [0.2, 0.9], [0.9, 0.2], [0.95, 0.95], [0.1, 0.1], [0.3, 0.3]]
    index, roles = choose(_prediction(mean, p_fail=[0, 0, 0, 0, 0.9, 0]), front=np.array([[0.6, 0.6]]),
                          reference=np.array([1.1, 1.1]), batch=3, exploration=0.0, failure_limit=0.5, X=X,
                          evaluated=X[5:6])
    assert 4 not in index and 5 not in index                   # likely to fail; already evaluated
    assert index[0] == 0 and set(roles) == {"exploit"}          # the largest predicted improvement first
    assert len(index) == 3


def test_exploration_takes_the_uncertain_designs():
    X = np.linspace(0, 1, 4)[:, None]
    mean = [[0.7, 0.7], [0.8, 0.8], [0.8, 0.8], [0.5, 0.5]]
    std = [[0, 0], [0.3, 0.3], [0, 0], [0, 0]]
    index, roles = choose(_prediction(mean, std), front=np.array([[0.6, 0.6]]), reference=np.array([1.1, 1.1]),
                          batch=2, exploration=0.5, failure_limit=0.5, X=X, evaluated=np.zeros((0, 1)))
    assert list(index) == [3, 1] and roles == ["exploit", "explore"]


def test_a_batch_conditioned_on_its_choices_explores_distinct_designs():
    """A cluster of five near-identical designs whose f2 the models know little of, and one design apart,
    a little less uncertain. Without conditioning both exploration designs come from the cluster (the
    believed mean of the first takes nothing from its neighbour's optimistic point); conditioned on the
    first, the cluster's uncertainty is gone and the second is the design apart."""
    X = np.r_[0.5 + 1e-3 * np.arange(5), 0.2][:, None]
    mean = [[0.5, 0.8]] * 5 + [[0.2, 0.8]]
    std = [[0.0, 0.5]] * 5 + [[0.0, 0.2]]
    front = np.array([[0.1, 0.95], [0.9, 0.15]])

    def condition(i):                     # as BatchConditioning does: no uncertainty left near design i
        shrink = np.where(np.abs(X - X[i]) < 0.01, 0.0, 1.0)
        return np.column_stack([shrink, shrink]), np.ones((6, 0))

    def explored(condition):
        index, roles = choose(_prediction(mean, std), front=front, reference=np.array([1.1, 1.1]), batch=2,
                              exploration=1.0, failure_limit=0.5, X=X, evaluated=np.zeros((0, 1)), condition=condition)
        assert roles == ["explore", "explore"]
        return set(index)

    assert explored(None) <= {0, 1, 2, 3, 4}
    assert 5 in explored(condition)


def test_a_front_beyond_the_reference_point_can_still_be_improved():
    X = np.linspace(0, 1, 3)[:, None]
    mean = [[2.5, 2.5], [3.5, 3.5], [2.9, 2.9]]       # all outside the reference box (1.1, 1.1)
    index, roles = choose(_prediction(mean), front=np.array([[3.0, 3.0]]), reference=np.array([1.1, 1.1]),
                          batch=1, exploration=0.0, failure_limit=0.5, X=X, evaluated=np.zeros((0, 1)))
    assert list(index) == [0] and roles == ["exploit"]


def test_slots_nothing_improves_follow_the_predicted_order():
    X = np.linspace(0, 1, 4)[:, None]
    mean = [[0.9, 0.9], [0.7, 0.8], [0.8, 0.7], [0.95, 0.95]]   # none improves the front at (0.1, 0.1)
    g = np.array([[0.0], [0.0], [0.0], [-1.0]])
    prediction = Prediction(np.array(mean), np.zeros((4, 2)), g, np.zeros((4, 1)), np.zeros(4))
    index, roles = choose(prediction, front=np.array([[0.1, 0.1]]), reference=np.array([1.1, 1.1]), batch=2,
                          exploration=0.0, failure_limit=0.5, X=X, evaluated=np.zeros((0, 1)))
    assert sorted(index) == [1, 2] and roles == ["fill", "fill"]


class _TwoBasins:
    """Models of a two-objective problem (f1 = x1, f2 = g − x1, as MW2) whose distance g is a sum of
    one-variable double wells: a shallow basin at 0.05 (where every variable starts) and the deep one at 0.8,
    behind a barrier."""

    def predict(self, X):
        well = 1.0 - np.exp(-50 * (X - 0.8) ** 2) - 0.3 * np.exp(-50 * (X - 0.05) ** 2)
        mean = np.column_stack([X[:, 0], 1.0 + well[:, 1:].sum(axis=1) - X[:, 0]])
        n = len(X)
        return Prediction(mean, np.zeros_like(mean), np.zeros((n, 0)), np.zeros((n, 0)), np.zeros(n))


def test_the_coordinate_search_crosses_the_barrier_between_a_variables_basins():
    starts = np.array([[0.2, 0.05, 0.05, 0.05], [0.7, 0.05, 0.05, 0.05]])
    moved = search_coordinates(_TwoBasins(), starts, np.zeros(4), np.ones(4), 0.5, lambda X: np.ones(len(X), bool),
                               front=np.zeros((0, 2)), reference=np.array([1.1, 4.0]), rng=np.random.default_rng(1))
    assert np.allclose(moved[:, 1:], 0.8, atol=0.01)           # every distance variable in its deep basin
    assert moved[1, 0] - moved[0, 0] > 0.3                     # the starts keep their places along the front


def test_the_coordinate_search_makes_no_move_that_breaks_the_cheap_conditions():
    starts = np.array([[0.2, 0.05, 0.05, 0.05]])
    allowed = lambda X: X[:, 2] < 0.5                          # noqa: E731 - the third variable may not move up
    moved = search_coordinates(_TwoBasins(), starts, np.zeros(4), np.ones(4), 0.5, allowed,
                               front=np.zeros((0, 2)), reference=np.array([1.1, 4.0]), rng=np.random.default_rng(1))
    assert moved[0, 2] < 0.5 and np.allclose(moved[0, [1, 3]], 0.8, atol=0.01)


class _UnsureConstraint:
    """Models of one constraint that the designs all violate: raising x2 makes it worse on the mean and less
    certain, in the objectives too, so that the optimistic point favours it while the probability of meeting
    the constraint falls; x1 near 1 meets it, as the models are fairly sure. Objectives: flat."""

    def predict(self, X):
        n = len(X)
        g_mean = 0.3 + 3.0 * X[:, 1] - 0.5 * (X[:, 0] > 0.9)
        g_std = 0.2 + 1.6 * X[:, 1]
        std = np.repeat((0.1 + X[:, 1])[:, None], 2, axis=1)
        return Prediction(np.zeros((n, 2)), std, g_mean[:, None], g_std[:, None], np.zeros(n))


class _ConstraintBeyondTheEnd:
    """Models of MW3's trouble: f1 = x1, f2 = 1 − x1, and a constraint the mean predicts violated for x1 above
    0.7 (by 0.1, 1.5 standard deviations): the front's end at 0.6 can only grow on the optimistic view."""

    def predict(self, X):
        n = len(X)
        mean = np.column_stack([X[:, 0], 1.0 - X[:, 0]])
        g_mean = np.where(X[:, 0] > 0.7, 0.1, -0.1)
        return Prediction(mean, np.full((n, 2), 0.01), g_mean[:, None], np.full((n, 1), 0.067), np.zeros(n))


def test_the_front_ends_are_moved_outwards_on_the_mean_and_the_optimistic_view():
    starts = np.array([[0.3, 0.5], [0.4, 0.5], [0.5, 0.5], [0.6, 0.5]])
    search = lambda **kw: search_coordinates(_ConstraintBeyondTheEnd(), starts, np.zeros(2), np.ones(2), 0.5,  # noqa: E731
                                             lambda X: np.ones(len(X), bool), front=np.array([[0.3, 0.7], [0.6, 0.4]]),
                                             reference=np.array([1.1, 1.1]), rng=np.random.default_rng(1), **kw)
    plain, ends = search(), search(front_ends=True)
    assert len(plain) == 4 and np.array_equal(ends[:4], plain)
    # f1's end (the start at 0.3) goes to 0 on either view; f2's end (0.6) to the largest x1 each view allows
    assert ends[4:, 0] == pytest.approx([0.0, 0.0, 0.7, 1.0], abs=0.02)


@pytest.mark.parametrize("until_feasible, x1, x2", [("optimistic", 0.05, 1.0), ("probability", 1.0, 0.05)])
def test_before_the_first_feasible_design_exploration_aims_as_asked(until_feasible, x1, x2):
    starts = np.array([[0.05, 0.05], [0.05, 0.05]])          # the second start is the optimistic one
    moved = search_coordinates(_UnsureConstraint(), starts, np.zeros(2), np.ones(2), 0.5,
                               lambda X: np.ones(len(X), bool), front=np.zeros((0, 2)),
                               reference=np.array([1.1, 1.1]), rng=np.random.default_rng(1),
                               until_feasible=until_feasible)
    assert moved[1] == pytest.approx([x1, x2], abs=0.07)
    assert moved[0][0] > 0.9 and moved[0][1] == 0.05         # the mean's start meets the constraint either way


def test_before_the_first_feasible_design_exploration_can_take_the_likeliest_to_be_feasible():
    X = np.array([[0.05, 1.0], [1.0, 0.05], [0.05, 0.05]])
    prediction = _UnsureConstraint().predict(X)
    taken = {aim: choose(prediction, front=np.zeros((0, 2)), reference=np.array([1.1, 1.1]), batch=1,
                         exploration=1.0, failure_limit=0.5, X=X, evaluated=np.zeros((0, 2)), until_feasible=aim)
             for aim in ("optimistic", "probability")}
    assert list(taken["optimistic"][0]) == [0] and list(taken["probability"][0]) == [1]
    assert taken["probability"][1] == ["explore"]


def test_with_a_feasible_design_exploration_aims_at_the_optimistic_point_whatever_was_asked():
    starts = np.array([[0.05, 0.05], [0.05, 0.05]])
    moved = [search_coordinates(_UnsureConstraint(), starts, np.zeros(2), np.ones(2), 0.5,
                                lambda X: np.ones(len(X), bool), front=np.array([[0.5, 0.5]]),
                                reference=np.array([1.1, 1.1]), rng=np.random.default_rng(1), until_feasible=aim)
             for aim in ("optimistic", "probability")]
    assert np.array_equal(*moved)


def _boundary_data(G):
    """A front design at (0.8, 0.5); violating designs: one improving the front near it, one improving it
    farther away, one nearest of all that improves nothing."""
    X = np.array([[0.8, 0.5], [0.4, 0.5], [0.0, 0.5], [0.75, 0.5]])
    F = np.array([[0.5, 0.5], [0.3, 0.3], [0.2, 0.2], [0.6, 0.6]])
    return TrainingData(X, np.zeros(4, bool), F, np.asarray(G, float).reshape(4, -1),
                        np.array([0.0, 1e5, 1e5, 1e5]), np.arange(4.0))


def test_boundary_candidates_bisect_towards_the_nearest_violating_design_that_improves_the_front():
    data = _boundary_data([[-1.0], [0.2], [0.5], [0.1]])
    mid = boundary_midpoints(data, np.array([1.1, 1.1]), np.zeros(2), np.ones(2))
    assert mid == pytest.approx(np.array([[0.6, 0.5]]))


def test_no_boundary_candidates_without_modelled_constraints_or_violations():
    assert boundary_midpoints(_boundary_data(np.zeros((4, 0))), None, np.zeros(2), np.ones(2)).shape == (0, 2)
    assert boundary_midpoints(_boundary_data([[-1.0]] * 4), None, np.zeros(2), np.ones(2)).shape == (0, 2)


def test_the_boundary_share_is_chosen_without_the_constraint_models():
    X = np.linspace(0, 1, 5)[:, None]
    mean = [[0.2, 0.5], [0.35, 0.35], [0.5, 0.2], [0.55, 0.55], [0.1, 0.55]]
    g = np.array([[-1.0], [-1.0], [-1.0], [1.0], [1.0]])          # the last two predicted to violate
    prediction = Prediction(np.array(mean), np.zeros((5, 2)), g, np.zeros((5, 1)), np.zeros(5))
    boundary = np.array([False, False, False, True, True])
    index, roles = choose(prediction, front=np.array([[0.6, 0.6]]), reference=np.array([1.1, 1.1]), batch=4,
                          exploration=0.0, failure_limit=0.5, X=X, evaluated=np.zeros((0, 1)), boundary=boundary)
    assert roles == ["boundary", "exploit", "exploit", "exploit"]    # a quarter of the batch
    assert index[0] == 4 and sorted(index[1:]) == [0, 1, 2]


# ------------------------------------------------------------------------------------- plain mode
class _HalfBox:
    """A stand-in problem whose designs with x1 > 0.3 are geometrically infeasible."""

    def prescreen(self, X):
        return np.ones(len(X), bool)

    def check(self, x):
        from optimizer.campaign.problem import Feasibility

        return Feasibility((float(x[0] - 0.3),), "x1 above 0.3")


def test_plain_offspring_are_redrawn_until_feasible():
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem

    class Sum(Problem):
        def __init__(self):
            super().__init__(n_var=4, n_obj=2, xl=0.0, xu=1.0)

        def _evaluate(self, X, out, *args, **kwargs):
            out["F"] = np.column_stack([X[:, 0], X[:, 1:].sum(axis=1)])

    filter_ = FeasibleOffspring(_HalfBox())
    start = np.random.default_rng(0).random((20, 4)) * [0.3, 1, 1, 1]
    algorithm = NSGA2(pop_size=20, sampling=start, eliminate_duplicates=filter_)
    algorithm.setup(Sum(), seed=3)
    problem = algorithm.problem
    initial = algorithm.ask()             # the initial population (feasible)
    Evaluator().eval(problem, initial)
    algorithm.tell(infills=initial)
    filter_.drawn = filter_.screened = 0
    for _ in range(5):
        off = algorithm.ask()
        assert len(off) == 20 and np.all(off.get("X")[:, 0] <= 0.3)
        Evaluator().eval(problem, off)
        algorithm.tell(infills=off)
    assert 100 <= filter_.screened < filter_.drawn          # some were drawn again


# -------------------------------------------------------------------------------------- campaigns
@pytest.mark.slow
def test_a_surrogate_campaign_beats_plain_nsga2_at_equal_evaluations(tmp_path):
    from pymoo.indicators.hv import HV

    def archive_hv(directory):
        with Store(directory / STORE_NAME, readonly=True) as s:
            F = np.array([r.minimised for r in s.evaluations() if r.feasible])
            return len(F), HV(ref_point=np.array([1.1, 10.0]))(F[non_dominated(F)])

    surrogate = campaign(tmp_path, ZDT1, "algorithm.method=surrogate", "algorithm.offspring=10",
                         "algorithm.surrogate={pool: 20, training: 60}")
    run_campaign(surrogate, tmp_path / "surrogate")
    plain = campaign(tmp_path, ZDT1, "algorithm.offspring=10")
    run_campaign(plain, tmp_path / "plain")
    n_s, hv_s = archive_hv(tmp_path / "surrogate")
    n_p, hv_p = archive_hv(tmp_path / "plain")
    assert n_s == n_p == 70
    assert hv_s > hv_p + 0.5            # plain NSGA-II has barely started at 70 evaluations on 8 variables

    with Store(tmp_path / "surrogate" / STORE_NAME, readonly=True) as s:
        searched = [g.search for g in s.generations()]
    assert searched[0]["method"] == "initial"                # the initial population is drawn, not searched
    for search in searched[1:]:
        assert search["method"] == "surrogate" and search["batch"] == 10
        # screened counts distinct candidates (ZDT1 has no cheap conditions): a coordinate move that keeps
        # its start repeats a design the pool already has
        assert search["drawn"] >= 20 * 10 and 0.9 * search["drawn"] <= search["screened"] <= search["drawn"]
        assert set(search["error"]) == {"f1", "f2"} and len(search["predicted"]) == 10
        assert search["seconds"]["fit"] > 0
    status = status_of(tmp_path / "surrogate")
    assert status["method"] == "surrogate" and "model error f1" in format_status(status)


@pytest.mark.parametrize("kernel, per_variable", [("additive", 2), ("warped", 4)])
def test_the_additive_kernels_are_fitted_and_stored_with_their_terms(tmp_path, kernel, per_variable):
    """``kernel: additive`` adds a variance and a length scale per design variable to each regression's stored
    hyperparameters (product: constant, 8 length scales, noise); ``warped`` also the two warping exponents."""
    config = campaign(tmp_path, ZDT1, "algorithm.method=surrogate", "algorithm.generations=3",
                      f"algorithm.surrogate={{pool: 5, training: 40, kernel: {kernel}}}")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        theta = s.generations()[-1].search["theta"]
    assert len(theta["f1"]) == len(theta["f2"]) == 1 + 8 + per_variable * 8 + 1


def test_the_coordinate_search_adds_its_designs_to_the_pool(tmp_path):
    """With ``coordinate_search`` each generation's pool holds the batch's worth of moved designs too, and the
    run still sends full batches."""
    drawn = {}
    for name, keys in (("plain", "coordinate_search: false"), ("search", "coordinate_search: true, front_ends: false"),
                       ("ends", "coordinate_search: true, front_ends: true")):
        config = campaign(tmp_path, ZDT1, "algorithm.method=surrogate", "algorithm.generations=3",
                          f"algorithm.surrogate={{pool: 5, training: 40, {keys}}}")
        run_campaign(config, tmp_path / name)
        with Store(tmp_path / name / STORE_NAME, readonly=True) as s:
            searches = [g.search for g in s.generations()[1:]]
        assert all(x["batch"] == 4 for x in searches)
        drawn[name] = np.array([x["drawn"] for x in searches])
    assert list(drawn["search"] - drawn["plain"]) == [4, 4]
    assert list(drawn["ends"] - drawn["plain"]) == [8, 8]           # two objectives, each end on two views


@pytest.mark.parametrize("batch, recent, share, expected", [
    (20, 0, 1.0, [(0, 20)]), (20, 20, 1.0, [(20, 20)]), (20, 20, 0.5, [(0, 10), (20, 10)]),
    (20, 20, 0.0, [(0, 20)]), (4, 5, 0.1, [(0, 3), (5, 1)]), (4, 5, 0.9, [(0, 1), (5, 3)]), (1, 5, 0.5, [(5, 1)]),
])
def test_the_portfolio_splits_the_batch_between_the_best_ranked_and_the_newest(batch, recent, share, expected):
    assert portfolio(batch, SurrogateSettings(recent=recent, recent_share=share)) == expected


def test_a_split_batch_is_chosen_by_both_sets_of_models_without_repeats(tmp_path):
    """``recent_share: 0.5``: half of each batch comes from the models fitted on the best-ranked designs, half
    from those that also learn from the newest; both sets' hyperparameters are stored for the next warm start."""
    config = campaign(tmp_path, ZDT1, "algorithm.method=surrogate", "algorithm.generations=3",
                      "algorithm.surrogate={pool: 5, training: 40, recent: 8, recent_share: 0.5}")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        searches = [g.search for g in s.generations()[1:]]
        keys = [r.key for r in s.evaluations()]
    assert len(keys) == len(set(keys)) == 20 + 2 * 4
    for search in searches:
        members = sorted(p["models"] for p in search["predicted"].values())
        assert search["batch"] == 4 and members == ["ranked", "ranked", "recent", "recent"]
        assert set(search["theta"]) == set(search["theta_recent"]) >= {"f1", "f2"}


def test_plain_generations_record_their_draws(tmp_path):
    run_campaign(campaign(tmp_path, ZDT1, "algorithm.generations=2"), tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        last = s.generations()[-1].search
    assert last == {"method": "nsga2", "drawn": 20, "screened": 20, "batch": 20}
    assert search_text(last) == "drew 20, 20 feasible, 20 to CFD"


@pytest.mark.parametrize("override, message", [
    ("algorithm.method=kriging", r"algorithm.method.*nsga2.*surrogate"),
    ("algorithm.surrogate.pool=0", r"algorithm.surrogate.pool"),
    ("algorithm.surrogate.exploration=1.5", r"algorithm.surrogate.exploration"),
    ("algorithm.surrogate.kernel=rbf", r"algorithm.surrogate.kernel.*product.*additive.*warped"),
    ("algorithm.surrogate.coordinate_search=maybe", r"algorithm.surrogate.coordinate_search"),
    ("algorithm.surrogate.recent=-1", r"algorithm.surrogate.recent"),
    ("algorithm.surrogate.recent=300", r"algorithm.surrogate.recent' = 300 is more than "
                                       r"algorithm.surrogate.training \(200\)"),
    ("algorithm.surrogate.initial=-1", r"algorithm.surrogate.initial"),
    ("algorithm.surrogate.initial=201", r"algorithm.surrogate.initial' = 201 is more than "),
    ("algorithm.surrogate.initial=150 algorithm.surrogate.recent=60",
     r"'algorithm.surrogate.recent' \+ 'algorithm.surrogate.initial' = 210 is more than "
     r"algorithm.surrogate.training \(200\)"),
    ("algorithm.surrogate.recent_share=1.5", r"algorithm.surrogate.recent_share"),
    ("algorithm.surrogate.recent_share=0.5", r"'algorithm.surrogate.recent_share' = 0.5 splits the batch .* "
                                             r"algorithm.surrogate.recent is 0"),
    ("algorithm.surrogate.warp_prior_variance=0", r"algorithm.surrogate.warp_prior_variance"),
    ("algorithm.surrogate.kernel=product algorithm.surrogate.warp_prior_variance=1.25",
     r"'algorithm.surrogate.warp_prior_variance' = 1.25 sets the prior .* algorithm.surrogate.kernel is 'product'"),
    ("algorithm.surrogate.hyperparameter_initial=201", r"algorithm.surrogate.hyperparameter_initial' = 201 is "
                                                        r"more than algorithm.surrogate.training \(200\)"),
    ("algorithm.surrogate.until_feasible=maybe", r"algorithm.surrogate.until_feasible' = 'maybe' is not allowed; "
                                                 r"allowed: 'optimistic' or 'probability'"),
    ("algorithm.surrogate.front_ends=often", r"algorithm.surrogate.front_ends"),
    ("algorithm.surrogate.condition_on_batch=often", r"algorithm.surrogate.condition_on_batch"),
    ("algorithm.surrogate.kappa=2", r"unknown key 'algorithm.surrogate.kappa'; allowed: pool, exploration"),
])
def test_bad_surrogate_settings_name_the_key(tmp_path, override, message):
    with pytest.raises(ConfigError, match=message):
        campaign(tmp_path, ZDT1, *override.split())


def test_front_ends_without_the_coordinate_search_changes_nothing(tmp_path):
    """``front_ends`` moves designs of the coordinate search, so with it off the key is inert, not an error
    (it is on by default, and a user who turns the search off need not turn it off too)."""
    s = campaign(tmp_path, ZDT1, "algorithm.surrogate.coordinate_search=false").algorithm.surrogate
    assert s.front_ends and not s.coordinate_search


def test_a_stored_configuration_without_the_newer_keys_resumes_with_the_rule_it_ran():
    """A store written before the surrogate's rule keys existed ran the product kernel without the options:
    resumed, it goes on with that rule, not with today's defaults; a key the store has is kept."""
    import yaml

    from optimizer.campaign.driver import EARLIER_DEFAULTS, saved_config

    old = yaml.safe_load(ZDT1) | {"algorithm": {"method": "surrogate", "population": 20,
                                                "surrogate": {"pool": 50, "training": 200}}}
    s = saved_config(yaml.safe_dump(old)).algorithm.surrogate
    assert (s.kernel, s.coordinate_search, s.warp_prior_variance, s.until_feasible, s.front_ends,
            s.condition_on_batch) == ("product", False, 2.0, "optimistic", False, False)
    assert {key[-1] for key in EARLIER_DEFAULTS} <= set(SurrogateSettings.model_fields)
    old["algorithm"]["surrogate"]["kernel"] = "additive"
    assert saved_config(yaml.safe_dump(old)).algorithm.surrogate.kernel == "additive"
    assert SurrogateSettings().kernel == "warped"


def test_the_batch_defaults_to_a_fifth_of_the_population_with_the_surrogate(tmp_path):
    assert campaign(tmp_path, ZDT1).algorithm.batch == 20
    assert campaign(tmp_path, ZDT1, "algorithm.method=surrogate").algorithm.batch == 4
    assert campaign(tmp_path, ZDT1, "algorithm.method=surrogate", "algorithm.offspring=6").algorithm.batch == 6


def test_a_store_of_the_first_schema_gains_the_search_column(tmp_path):
    run_campaign(campaign(tmp_path, ZDT1, "algorithm.generations=2"), tmp_path / "run")
    path = tmp_path / "run" / STORE_NAME
    db = sqlite3.connect(path)
    db.execute("ALTER TABLE generations DROP COLUMN search")
    db.execute("PRAGMA user_version=1")
    db.commit()
    db.close()
    with Store(path, readonly=True) as old:
        assert [g.search for g in old.generations()] == [None, None]
    with Store(path) as migrated:
        assert [g.search for g in migrated.generations()] == [None, None]
    assert sqlite3.connect(path).execute("PRAGMA user_version").fetchone()[0] == 2


def test_without_designs_with_values_a_generation_takes_nsga2_offspring(tmp_path):
    # nine designs in ten fail: the initial population leaves the models too few designs with values
    config = campaign(tmp_path, ZDT1.replace("variables: 8}", "variables: 8, failures: {random: 0.9, seed: 1}}"),
                      "algorithm.method=surrogate", "algorithm.offspring=10", "algorithm.generations=3")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        searched = [g.search for g in s.generations()]
    assert searched[1]["method"] == "nsga2" and "the models need 4 designs with values" in searched[1]["fallback"]
    assert "NSGA-II's own offspring" in search_text(searched[1])


@pytest.mark.slow
def test_a_constrained_campaign_bisects_its_constraint_boundaries(tmp_path):
    config = campaign(tmp_path, ZDT1.replace("zdt1, variables: 8", "mw3, variables: 6").replace("reference: 10",
                                                                                              "reference: 1.1"),
                      "algorithm.method=surrogate", "algorithm.offspring=8", "algorithm.seed=3")
    run_campaign(config, tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        searched = [g.search for g in s.generations()][1:]
    roles = [[p["role"] for p in search["predicted"].values()] for search in searched]
    assert any(r.count("boundary") == 2 for r in roles)                 # a quarter of the batch of 8
    assert all(search["screened"] <= search["drawn"] for search in searched)
    shown = [search_text(search) for search in searched if "boundary" in [p["role"] for p in
                                                                         search["predicted"].values()]]
    assert shown and all("8 to CFD, 2 bisecting constraint boundaries" in text for text in shown)


def test_check_says_how_the_batch_fills_the_workers(tmp_path, capsys):
    from optimizer.cli import main

    path = tmp_path / "c.yaml"
    path.write_text(ZDT1.replace("backend: inline", "backend: local, workers: 4"))
    assert main(["check", str(path), "--set", "algorithm.method=surrogate", "--set", "algorithm.offspring=6"]) == 0
    out = capsys.readouterr().out
    assert "surrogate-assisted NSGA-II (warped kernel, coordinate search," in out and "at most 50 evaluations" in out
    assert "6 offspring on 4 worker(s): 2 round(s) per generation, 2 worker(s) idle in the last" in out
