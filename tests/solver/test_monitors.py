"""Stopping tests on the monitor histories: the short-window stop (:func:`solver.monitors.settled`) and the
early recognition of an established oscillation or drift (:func:`solver.monitors.established`)."""

import dataclasses

import numpy as np
import pytest

from solver import SimpleSettings
from solver.convergence import classify
from solver.monitors import established, near_fixed_point, settled, stop_monitor_names

CFG = SimpleSettings()          # classify_window 200, classify_tol 1e-3, stop_window 50, stop_tol 1e-3
RES = {"u": 1e-6, "v": 1e-6, "continuity": 1e-6}


def _hist(values):
    return {"c_max": list(values), "fy:blade": list(-2.0 * np.asarray(values))}


def test_settled_needs_the_short_window_stationary_and_the_residuals_below_stall_tol():
    it = np.arange(300)
    decaying = 10.0 + np.exp(-it / 20.0)             # settles to 1e-6 relative long before 300
    assert settled(RES, _hist(decaying), 300, CFG)
    assert not settled({**RES, "k": 2e-4}, _hist(decaying), 300, CFG)           # a residual above stall_tol
    assert not settled(RES, _hist(decaying), 301, CFG)                          # checked every 10 iterations
    drifting = 10.0 + 3e-4 * it                      # 1.5e-3 relative over 50 iterations > stop_tol
    assert not settled(RES, _hist(drifting), 300, CFG)


def test_settled_waits_only_for_the_stop_monitors_and_rejects_unknown_names():
    it = np.arange(300)
    hist = {**_hist(10.0 + np.exp(-it / 20.0)), "fx:blade": list(1.0 + 3e-4 * it)}   # F_X still drifting
    assert not settled(RES, hist, 300, CFG)
    objectives = dataclasses.replace(CFG, stop_monitors=("fy:blade", "c_max"))
    assert settled(RES, hist, 300, objectives)
    assert stop_monitor_names(hist, CFG) == ("c_max", "fy:blade", "fx:blade")
    with pytest.raises(ValueError, match=r"\['lift'\] are not monitored; the monitors are \['c_max', 'fx:blade'"):
        stop_monitor_names(hist, dataclasses.replace(CFG, stop_monitors=("lift", "c_max")))


def test_a_slow_geometric_decay_whose_tail_exceeds_the_tolerance_is_not_near_its_fixed_point():
    it = np.arange(300)
    rho = 0.9 ** (1 / 50)                            # the change shrinks by 0.9 per 50-iteration window
    x = 1.0 + 0.0085 * rho**it
    last_change = x[-51] - x[-1]                     # 4.9e-4: a spread within 1e-3 over the last window...
    tail = x[-1] - 1.0                               # ...but 4.4e-3 still to come
    assert last_change < 1e-3 < tail
    assert not near_fixed_point(x, 50, 1e-3)
    assert near_fixed_point(x, 50, 1e-2)


def test_the_extrapolated_tail_of_a_fast_decay_decides_and_noise_without_trend_passes():
    it = np.arange(400)
    x = 1.0 + 0.05 * np.exp(-it / 40.0)              # ratio 0.29 per window
    stops = [n for n in range(100, 401, 10) if near_fixed_point(x[:n], 50, 1e-3)]
    first = stops[0]
    assert x[first - 1] - 1.0 <= 1e-3                # within the tolerance of the limit where it stops
    assert not near_fixed_point(x[: first - 10], 50, 1e-3)
    rng = np.random.default_rng(0)
    noisy = 1.0 + 2e-4 * rng.standard_normal(200)    # settled, with chatter below the tolerance
    assert near_fixed_point(noisy, 50, 1e-3)
    assert not near_fixed_point(noisy, 50, 1e-4)
    growing = 1.0 + 1e-5 * np.exp(it[:200] / 40.0)   # moves away from its value: never near a fixed point
    assert not near_fixed_point(growing[:150], 50, 1e-3)


def test_established_oscillation_stops_with_the_classification_of_the_last_window():
    it = np.arange(600)
    x = 25.0 + 0.2 * np.sin(2 * np.pi * it / 37.0)
    status, message, cls = established(_hist(x), 600, CFG)
    assert status == "oscillating" and "established" in message
    ref = classify({k: np.asarray(v) for k, v in _hist(x).items()}, window=200, tol=1e-3)
    assert cls.mean == ref.mean and cls.amplitude == ref.amplitude and cls.period == ref.period
    assert established(_hist(x[:599]), 599, CFG) is None                        # checked every 50 iterations
    assert established(_hist(x[:475]), 475, CFG) is None                        # before 2 windows + 100
    assert established(_hist(x[:500]), 500, CFG)[0] == "oscillating"


def test_an_oscillation_with_a_settled_mean_stops_even_if_it_would_decay_before_max_iter():
    it = np.arange(600)
    slow = 25.0 + 0.2 * np.exp(-it / 400.0) * np.sin(2 * np.pi * it / 37.0)   # -40 % per window
    status, message, cls = established(_hist(slow), 600, CFG)
    assert status == "oscillating" and abs(cls.mean["c_max"] - 25.0) <= 1e-3 * 25.0   # the mean is final
    moving = slow + 0.3 * np.exp(-it / 300.0)                 # the mean still moves by 2e-3 per window
    assert established(_hist(moving), 600, CFG) is None


def test_a_ripple_that_decays_below_the_tolerance_within_two_windows_runs_on():
    it = np.arange(600)
    decaying = 25.0 + 0.3 * np.exp(-it / 150.0) * np.sin(2 * np.pi * it / 37.0)     # 3.8x smaller per window
    assert established(_hist(decaying), 600, CFG) is None     # settled mean, but soon converged (2e-4 a/m)
    lasting = 25.0 + 0.02 * np.sin(2 * np.pi * it / 37.0)     # 8e-4 of the mean, not decaying: oscillating
    assert established(_hist(lasting), 600, CFG)[0] == "oscillating"


def test_an_oscillation_or_drift_that_would_settle_before_max_iter_goes_on_a_steady_drift_stops():
    it = np.arange(600)
    creeping = 25.0 - 0.5 * np.exp(-it / 100.0)                                       # converging slowly
    assert established(_hist(creeping), 600, CFG) is None
    # a drift that slows down but not geometrically (it levels off at iteration 1 000): the extrapolation of
    # its last two windows would still have called it drifting at the cap (0.4 x 0.71^7 > 0.025); it runs on
    slowing = 25.0 + 4e-3 * it - 2e-6 * it**2
    assert established(_hist(slowing), 600, CFG) is None
    drift = 25.0 + 2e-3 * it
    status, _, cls = established(_hist(drift), 600, CFG)
    assert status == "not_converged" and cls.status == "not_converged"
    assert established(_hist(drift), 600, SimpleSettings(early_classify=False)) is None


def test_the_start_up_limiter_switches_off_after_its_iterations_and_holds_the_stop_tests_until_then():
    from solver.simple import active_limiter, limiter_settled

    start_up = dataclasses.replace(CFG, limiter_iterations=500)
    assert active_limiter(start_up, {"iteration": 500}) == "venkatakrishnan"
    assert active_limiter(start_up, {"iteration": 501}) == "none"
    assert active_limiter(CFG, {"iteration": 10_000}) == "venkatakrishnan"      # None: limited throughout
    assert not limiter_settled(start_up, 500) and limiter_settled(start_up, 501)
    assert limiter_settled(CFG, 1)
