"""The additive Matérn kernel: its values are the sum of one-column Matérn 5/2 kernels, its gradient is the
derivative in the log-hyperparameters, and in the surrogate it lets a model of one-variable effects find
the minimum of a response that no training design comes near. The warped kernel: the same terms after the
Kumaraswamy warping of each variable, an exact gradient in all its log-hyperparameters, and a fit that finds
a steep corner of a variable's range. The sum of a surrogate's terms, its gradient computed in place, is
scikit-learn's sum."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

from optimizer.campaign.additive import AdditiveMatern, InPlaceSum, WarpedAdditiveMatern
from optimizer.campaign.surrogate import Models, TrainingData

VARIANCES = np.array([0.5, 1.0, 2.0])
LENGTHS = np.array([0.2, 0.5, 1.0])


def test_the_kernel_is_the_sum_of_one_column_matern_kernels():
    rng = np.random.default_rng(0)
    X, Y = rng.random((7, 3)), rng.random((4, 3))
    kernel = AdditiveMatern(VARIANCES, LENGTHS)
    expected = sum(s * Matern(length, nu=2.5)(X[:, [j]], Y[:, [j]])
                   for j, (s, length) in enumerate(zip(VARIANCES, LENGTHS, strict=True)))
    assert kernel(X, Y) == pytest.approx(expected, abs=1e-14)
    assert kernel.diag(X) == pytest.approx(np.diag(kernel(X)))


def test_a_pool_larger_than_a_block_gets_every_row():
    """k(X, Y) is computed a block of rows of X at a time: a pool of many blocks, the last one short, has
    the same values as one row at a time."""
    rng = np.random.default_rng(2)
    X, Y = rng.random((1001, 3)), rng.random((400, 3))
    kernel = AdditiveMatern(VARIANCES, LENGTHS)
    K = kernel(X, Y)
    assert K.shape == (1001, 400)
    assert np.array_equal(K, np.vstack([kernel(x[None, :], Y) for x in X]))


def test_the_gradient_is_the_derivative_in_the_log_hyperparameters():
    X = np.random.default_rng(1).random((6, 3))
    kernel = AdditiveMatern(VARIANCES, LENGTHS)
    K, gradient = kernel(X, eval_gradient=True)
    step = 1e-6
    for i, theta in enumerate(np.eye(len(kernel.theta)) * step + kernel.theta):
        assert (kernel.clone_with_theta(theta)(X) - K) / step == pytest.approx(gradient[:, :, i], abs=1e-5)
    assert len(kernel.theta) == 6 and kernel.bounds.shape == (6, 2)


@pytest.mark.slow
def test_a_model_of_one_variable_effects_finds_a_minimum_no_design_came_near():
    """Ten narrow wells, one per variable, summed: 120 random designs all lie above 4.5 (every design misses
    most wells at once). The product kernel alone predicts 4.4 at the minimum (the level of the data
    around it); with the additive term the model puts it near its true value, 0."""
    d = 10
    centre = np.linspace(0.2, 0.8, d)

    def wells(X):
        return (1.0 - np.exp(-(((X - centre) / 0.15) ** 2))).sum(axis=1)

    X = np.random.default_rng(3).random((120, d))
    data = TrainingData(X, np.zeros(len(X), bool), wells(X)[:, None], np.zeros((len(X), 0)), np.zeros(len(X)),
                        np.arange(len(X), dtype=float))
    product = Models(np.zeros(d), np.ones(d), ["w"], []).fit(data, cap=len(X))
    additive = Models(np.zeros(d), np.ones(d), ["w"], [], kernel="additive").fit(data, cap=len(X))
    assert wells(X).min() > 4.0
    assert product.predict(centre[None]).mean[0, 0] > 3.0
    assert additive.predict(centre[None]).mean[0, 0] < 1.0


WARP_A = np.array([2.0, 0.7, 5.0])
WARP_B = np.array([1.5, 0.8, 3.0])


def test_the_warped_kernel_is_the_additive_kernel_of_the_warped_inputs():
    rng = np.random.default_rng(2)
    X, Y = rng.random((7, 3)), rng.random((4, 3))
    kernel = WarpedAdditiveMatern(VARIANCES, LENGTHS, WARP_A, WARP_B)
    warp = lambda Z: 1.0 - (1.0 - Z**WARP_A) ** WARP_B  # noqa: E731
    assert kernel(X, Y) == pytest.approx(AdditiveMatern(VARIANCES, LENGTHS)(warp(X), warp(Y)), abs=1e-14)
    unwarped = WarpedAdditiveMatern(VARIANCES, LENGTHS, np.ones(3), np.ones(3))
    assert unwarped(X, Y) == pytest.approx(AdditiveMatern(VARIANCES, LENGTHS)(X, Y), abs=1e-12)
    assert kernel.diag(X) == pytest.approx(np.diag(kernel(X)))


def test_the_warped_gradient_is_the_derivative_in_every_log_hyperparameter():
    X = np.random.default_rng(1).random((6, 3))
    kernel = WarpedAdditiveMatern(VARIANCES, LENGTHS, WARP_A, WARP_B)
    K, gradient = kernel(X, eval_gradient=True)
    assert [h.name for h in kernel.hyperparameters] == ["length_scales", "variances", "warping_a", "warping_b"]
    assert gradient.shape == (6, 6, 12)
    step = 1e-6
    for i, theta in enumerate(np.eye(len(kernel.theta)) * step + kernel.theta):
        assert (kernel.clone_with_theta(theta)(X) - K) / step == pytest.approx(gradient[:, :, i], abs=1e-5)


@pytest.mark.parametrize("additive", [None, AdditiveMatern(VARIANCES, LENGTHS),
                                      WarpedAdditiveMatern(VARIANCES, LENGTHS, WARP_A, WARP_B)])
def test_the_in_place_sum_is_scikit_learn_s_sum(additive):
    X = np.random.default_rng(4).random((9, 3))
    terms = ConstantKernel(2.0) * Matern(LENGTHS, nu=2.5)
    terms = terms if additive is None else terms + additive
    plain, in_place = terms + WhiteKernel(1e-3), InPlaceSum(terms, WhiteKernel(1e-3))
    (K, gradient), (K_in_place, gradient_in_place) = plain(X, eval_gradient=True), in_place(X, eval_gradient=True)
    assert K_in_place == pytest.approx(K, abs=1e-14)
    assert gradient_in_place == pytest.approx(gradient, abs=1e-14)
    assert in_place(X[:4], X) == pytest.approx(plain(X[:4], X), abs=1e-14)
    assert np.array_equal(in_place.theta, plain.theta)


def test_the_warping_exponents_have_a_log_normal_prior_of_median_one():
    """The fit maximises the marginal likelihood plus, on the warping exponents only, a normal log-prior of
    variance v about log 1 = 0: on a quadratic stand-in for the likelihood, the mode moves from the
    likelihood's optimum c to c / (1 + 1 / v) for those, and stays at c for the others."""
    from optimizer.campaign.surrogate import _optimizer, _regressor

    c = np.array([1.0, -2.0, 0.5, 3.0])
    prior = np.array([False, True, False, True])

    def objective(theta):                        # − log likelihood, its optimum at c
        return 0.5 * float(np.sum((theta - c) ** 2)), theta - c

    for variance in (0.75, 2.0):
        mode, _ = _optimizer(200, prior, variance)(objective, np.zeros(4), np.tile([-10.0, 10.0], (4, 1)))
        # L-BFGS-B stops at a projected gradient of 1e-5; the curvature here is at least 1, so the mode is
        # that near.
        assert mode == pytest.approx(np.where(prior, c / (1 + 1 / variance), c), abs=1e-5)
    counts = {k: sum(h.n_elements for h in _regressor(3, None, k).kernel.hyperparameters if "warping_" in h.name)
              for k in ("product", "additive", "warped")}
    assert counts == {"product": 0, "additive": 0, "warped": 6}


@pytest.mark.slow
def test_a_warped_model_learns_wells_in_the_corner_of_each_range():
    """Ten wells of x¹³, one per variable, each a few hundredths wide in x near the top of its range (a
    sum like MW1's distance function): 150 designs, random except that each variable lies in the top tenth
    of its range a third of the time, all lie above 4.5. The warped model puts the minimum near its true
    value, 0, and predicts 200 new designs of the same kind within a few hundredths; the plain additive one
    (1.3 at the minimum, 0.3 out of sample here) does not. Its fit stretches the top of every range (a > 1)."""
    d = 10
    centre = np.linspace(0.55, 0.95, d)

    def wells(X):
        return (1.0 - np.exp(-10.0 * (X**13 - centre) ** 2)).sum(axis=1)

    def draw(rng, n):
        X = rng.random((n, d))
        top = rng.random((n, d)) < 1 / 3
        X[top] = 0.9 + 0.1 * rng.random(top.sum())
        return X

    rng = np.random.default_rng(5)
    X, test = draw(rng, 150), draw(rng, 200)
    data = TrainingData(X, np.zeros(len(X), bool), wells(X)[:, None], np.zeros((len(X), 0)), np.zeros(len(X)),
                        np.arange(len(X), dtype=float))
    assert wells(X).min() > 4.5
    minimum, error = {}, {}
    for kernel in ("additive", "warped"):
        models = Models(np.zeros(d), np.ones(d), ["w"], [], kernel=kernel).fit(data, cap=len(X))
        minimum[kernel] = models.predict(centre[None] ** (1 / 13)).mean[0, 0]
        error[kernel] = np.sqrt(np.mean((models.predict(test).mean[:, 0] - wells(test)) ** 2))
    assert abs(minimum["warped"]) < 0.3 and minimum["additive"] > 1.0
    assert error["warped"] < 0.05 and error["additive"] > 0.2
    assert np.all(np.asarray(models.gaussian_process("w").kernel_.k1.k2.warping_a) > 1.0)


def test_a_smaller_warping_prior_variance_keeps_the_warping_nearer_the_identity():
    """``algorithm.surrogate.warp_prior_variance``: two wells of x¹³ near the top of their ranges, 80
    designs. Under the default prior (variance 2) the fit stretches the top of each range (log a above 2:
    a near the function's 13); under a tight one (0.01) the exponents stay within a factor e of 1."""
    d = 2
    centre = np.array([0.6, 0.9])

    def wells(X):
        return (1.0 - np.exp(-10.0 * (X**13 - centre) ** 2)).sum(axis=1)

    rng = np.random.default_rng(5)
    X = rng.random((80, d))
    top = rng.random((80, d)) < 1 / 3
    X[top] = 0.9 + 0.1 * rng.random(top.sum())
    data = TrainingData(X, np.zeros(len(X), bool), wells(X)[:, None], np.zeros((len(X), 0)), np.zeros(len(X)),
                        np.arange(len(X), dtype=float))
    log_a = {}
    for variance in (0.01, 2.0):
        models = Models(np.zeros(d), np.ones(d), ["w"], [], kernel="warped", warp_prior_variance=variance)
        warping = models.fit(data, cap=len(X)).gaussian_process("w").kernel_.k1.k2
        log_a[variance] = np.log(warping.warping_a)
    assert np.all(np.abs(log_a[0.01]) < 1.0)
    assert np.all(log_a[2.0] > 2.0)
