"""Convergence classification (solver.convergence) on synthetic monitor histories with known answers."""

import math

import numpy as np
import pytest

from solver.convergence import Classification, ConvergenceClass, classify

IT = np.arange(1200)


def _finite(c: Classification) -> bool:
    """No figure is NaN or infinite (None is allowed)."""
    for d in (c.mean, c.amplitude, c.period, c.drift):
        for v in d.values():
            if v is not None and not math.isfinite(v):
                return False
    return True


@pytest.mark.parametrize("period", [6.5, 25.0, 61.0, 97.0])
def test_noisy_sine_is_oscillating_with_its_period_amplitude_and_mean(period):
    rng = np.random.default_rng(1)
    x = 40.0 + 0.8 * np.sin(2 * np.pi * IT / period + 0.3) + 0.05 * rng.standard_normal(IT.size)
    c = classify({"fy:blade": x}, window=400, tol=1e-3)
    assert c.status == "oscillating" and c.monitor_status == {"fy:blade": "oscillating"}
    assert c.window == 400
    assert c.period["fy:blade"] == pytest.approx(period, rel=0.02)
    # amplitude: sqrt(2) x std about the trend = sqrt(A² + 2 sigma²) = 0.8031 for A = 0.8, sigma = 0.05
    assert c.amplitude["fy:blade"] == pytest.approx(0.8, rel=0.03)
    assert c.mean["fy:blade"] == pytest.approx(40.0, abs=0.02)   # whole periods: no partial-cycle bias
    assert c.dominant_period == pytest.approx(period, rel=0.02)
    assert _finite(c)


def test_mean_over_whole_periods_removes_the_partial_cycle_bias():
    # 100 samples of a period-40 sine: 2.5 cycles; the plain window mean is off by A/(2.5 pi) ~ 0.13 A
    x = 3.0 + np.sin(2 * np.pi * np.arange(100) / 40.0)
    c = classify({"m": x}, window=100, tol=1e-3)
    assert abs(x.mean() - 3.0) > 0.1
    assert c.mean["m"] == pytest.approx(3.0, abs=0.03)


def test_linear_drift_is_not_converged_and_its_drift_is_measured():
    rng = np.random.default_rng(2)
    x = 10.0 + 2e-3 * IT + 1e-3 * rng.standard_normal(IT.size)
    c = classify({"c_max": x, "fx:blade": np.full(IT.size, 4.0)}, window=300, tol=1e-3)
    assert c.status == "not_converged"
    assert c.monitor_status == {"c_max": "not_converged", "fx:blade": "stationary"}
    assert c.drift["c_max"] == pytest.approx(2e-3 * 300, rel=0.02)
    assert c.period["c_max"] is None
    assert "c_max" in c.reason and "drifting" in c.reason


def test_oscillation_around_a_small_trend_is_oscillating_and_a_trend_with_ripple_is_not():
    slow = 5.0 + 0.01 * np.sin(2 * np.pi * IT / 20) + 1e-6 * IT          # drift 2e-4 << amplitude 0.01
    fast = 5.0 + 0.01 * np.sin(2 * np.pi * IT / 20) + 2e-4 * IT          # drift 0.04 = 4 x amplitude
    assert classify({"m": slow}, window=200, tol=1e-4).status == "oscillating"
    assert classify({"m": fast}, window=200, tol=1e-4).status == "not_converged"


@pytest.mark.parametrize("value", [0.0, 2.5, -1e6])
def test_constant_is_stationary(value):
    c = classify({"m": np.full(300, value)}, window=100, tol=1e-6)
    assert c.status == "stationary"
    assert c.mean["m"] == value and c.amplitude["m"] == 0.0 and c.drift["m"] == 0.0
    assert c.period["m"] is None


def test_tiny_fluctuation_below_tol_is_stationary_above_it_oscillating():
    x = 1.0 + 1e-7 * np.sin(2 * np.pi * IT / 17)
    assert classify({"m": x}, window=200, tol=1e-6).status == "stationary"
    assert classify({"m": x}, window=200, tol=1e-8).status == "oscillating"


def test_white_noise_is_oscillating_without_a_period():
    x = 7.0 + 0.1 * np.random.default_rng(3).standard_normal(IT.size)
    c = classify({"m": x}, window=400, tol=1e-3)
    assert c.status == "oscillating" and c.period["m"] is None and c.dominant_period is None
    assert c.amplitude["m"] == pytest.approx(0.1 * np.sqrt(2), rel=0.1)
    assert "noisy" in c.reason


def test_solver_verdicts_take_precedence_and_figures_are_still_given():
    x = 1.0 + 0.1 * np.sin(2 * np.pi * IT / 30)
    assert classify({"m": x}, window=200, converged=True).status == "converged"
    c = classify({"m": x}, window=200, diverged=True, converged=True)
    assert c.status == "diverged" and c.period["m"] == pytest.approx(30, rel=0.02)


def test_non_finite_values_never_produce_nan():
    x = np.r_[np.linspace(1, 2, 50), np.nan, np.inf, -np.inf]
    c = classify({"bad": x, "empty": np.array([]), "one": np.array([np.nan, 3.0])}, window=100)
    assert _finite(c)
    assert c.mean["empty"] is None and c.mean["one"] is None and c.mean["bad"] is not None
    assert c.status == "not_converged" and "finite" in c.reason
    d = c.to_dict()
    assert type(d["status"]) is str and ConvergenceClass(d["status"]) == c.status


def test_short_histories_are_not_classified_and_bad_arguments_rejected():
    c = classify({"m": np.ones(5)}, window=50)
    assert c.status == "not_converged" and "only 5" in c.reason
    assert classify({}, window=50).status == "not_converged"
    with pytest.raises(ValueError, match="window"):
        classify({"m": np.ones(50)}, window=1)
    with pytest.raises(ValueError, match="tol"):
        classify({"m": np.ones(50)}, window=10, tol=-1)


def test_worst_monitor_decides():
    osc = 2.0 + 0.1 * np.sin(2 * np.pi * IT / 25)
    c = classify({"a": np.full(IT.size, 1.0), "b": osc}, window=200, tol=1e-3)
    assert c.status == "oscillating" and c.monitor_status["a"] == "stationary"
    assert c.reason.startswith("b:")


def test_classes_are_ordered_best_first_and_equal_their_strings():
    C = ConvergenceClass
    assert list(C) == ["converged", "stationary", "oscillating", "not_converged", "diverged"]
    assert C.worst(["converged", C.OSCILLATING, "stationary"]) is C.OSCILLATING
    assert C.worst([C.DIVERGED, "not_converged"]) is C.DIVERGED
    assert [c.rank for c in C] == list(range(5)) and not C.DIVERGED.solved and C.NOT_CONVERGED.solved
    with pytest.raises(ValueError):
        C.worst([])
    with pytest.raises(ValueError):
        C.worst(["settled"])
