"""The additive Matérn kernel: its values are the sum of one-column Matérn 5/2 kernels, its gradient is the
derivative in the log-hyperparameters, and in the surrogate it lets a model of one-variable effects find
the minimum of a response that no training design comes near."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process.kernels import Matern

from optimizer.campaign.additive import AdditiveMatern
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


def test_the_gradient_is_the_derivative_in_the_log_hyperparameters():
    X = np.random.default_rng(1).random((6, 3))
    kernel = AdditiveMatern(VARIANCES, LENGTHS)
    K, gradient = kernel(X, eval_gradient=True)
    step = 1e-6
    for i, theta in enumerate(np.eye(len(kernel.theta)) * step + kernel.theta):
        assert (kernel.clone_with_theta(theta)(X) - K) / step == pytest.approx(gradient[:, :, i], abs=1e-5)
    assert len(kernel.theta) == 6 and kernel.bounds.shape == (6, 2)


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
