"""The early stop of an established oscillation with windows scaled to its period
(:func:`solver.monitors.established`, :func:`solver.monitors.early_window`; ``SimpleSettings.early_periods``,
``early_skip``)."""

import dataclasses

import numpy as np

from solver import SimpleSettings
from solver.convergence import classify
from solver.monitors import early_window, established

CFG = SimpleSettings()                  # classify_window 200, classify_tol 1e-3, early_periods 8
FIXED = dataclasses.replace(CFG, early_periods=None)


def _hist(values):
    return {"c_max": np.asarray(values, dtype=float), "fy:blade": -2.0 * np.asarray(values, dtype=float)}


def _lists(h):
    return {k: list(v) for k, v in h.items()}


def _first_stop(h, cfg, n):
    return next((it for it in range(25, n + 1, 25) if established(_lists({k: v[:it] for k, v in h.items()}),
                                                                  it, cfg) is not None), None)


def test_the_window_spans_early_periods_of_the_longest_period_within_half_and_one_classify_window():
    it = np.arange(400)

    def longest(h):
        return max(p for p in classify(h, window=200, tol=1e-3).period.values() if p is not None)

    twenty = _hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 20.0))
    assert abs(longest(twenty) - 20.0) < 0.2 and early_window(twenty, CFG) == int(8 * longest(twenty))   # ~160
    assert early_window(_hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 11.0)), CFG) == 100        # 88: floor
    assert early_window(_hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 37.0)), CFG) == 200        # 296: cap
    assert early_window(_hist(25.0 + 2e-3 * it), CFG) == 200                                  # no period
    assert early_window(twenty, FIXED) == 200
    mixed = {"c_max": 25.0 + 0.5 * np.sin(2 * np.pi * it / 11.0), "fy:blade": -50.0 + np.sin(2 * np.pi * it / 16.0)}
    assert abs(longest(mixed) - 16.0) < 0.2 and early_window(mixed, CFG) == int(8 * longest(mixed))      # ~128


def test_a_short_period_oscillation_stops_at_three_short_windows_with_that_windows_figures():
    it = np.arange(2000)
    h = _hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 12.0))           # 8 periods = 96: window 100
    assert _first_stop(h, CFG, 2000) == 300
    status, message, cls = established(_lists({k: v[:300] for k, v in h.items()}), 300, CFG)
    assert status == "oscillating" and "two windows of 100" in message
    ref = classify({k: v[:300] for k, v in h.items()}, window=100, tol=1e-3)
    assert cls.mean == ref.mean and cls.amplitude == ref.amplitude and cls.period == ref.period
    cap = classify(h, window=200, tol=1e-3)                         # the figures at the cap: the same mean
    assert abs(cls.mean["c_max"] - cap.mean["c_max"]) <= 1e-3 * 25.0
    assert _first_stop(h, FIXED, 2000) == 500                       # the fixed windows: 2 x 200 + 100
    assert established(_lists({k: v[:310] for k, v in h.items()}), 310, CFG) is None   # checked every 25


def test_a_long_period_keeps_the_classify_window_and_noise_waits_two_windows_after_the_start_up():
    it = np.arange(2000)
    h = _hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 37.0))
    assert _first_stop(h, CFG, 2000) == 500                          # 2 x 200 + early_skip 100
    rng = np.random.default_rng(1)
    noisy = _hist(25.0 + 0.05 * rng.standard_normal(2000))         # no period: classify_window
    assert _first_stop(noisy, CFG, 2000) == 500
    whole = dataclasses.replace(CFG, early_skip=None)               # early_skip None: a whole window skipped
    assert _first_stop(h, whole, 2000) == 600 and _first_stop(noisy, whole, 2000) == 600


def test_the_start_up_allowance_is_at_most_one_window():
    it = np.arange(2000)
    short = _hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 12.0))       # windows of 100
    assert _first_stop(short, dataclasses.replace(CFG, early_skip=400), 2000) == 300
    assert _first_stop(short, dataclasses.replace(CFG, early_skip=0), 2000) == 200
    ringing = _hist(25.0 + 0.5 * np.exp(-it / 60.0) * np.sin(2 * np.pi * it / 12.0) - 0.4 * np.exp(-it / 90.0))
    assert _first_stop(ringing, CFG, 1000) is None                   # a decaying start-up is still not stopped


def test_a_short_window_does_not_stop_a_decaying_transient_or_a_mean_that_still_moves():
    it = np.arange(2000)
    # a converging start-up ringing at a short period: stationary to 1e-3 before the cap, never stopped
    ringing = _hist(25.0 + 0.5 * np.exp(-it / 60.0) * np.sin(2 * np.pi * it / 12.0) - 0.4 * np.exp(-it / 90.0))
    assert _first_stop(ringing, CFG, 1000) is None
    # a limit cycle whose mean still moves by a third of its amplitude per 100 iterations: held until it settles
    drifting = _hist(25.0 + 0.3 * np.sin(2 * np.pi * it / 12.0) + 2.0 * np.exp(-it / 250.0))
    stop = _first_stop(drifting, CFG, 2000)
    assert stop is not None and stop > 300
    cls = established(_lists({k: v[:stop] for k, v in drifting.items()}), stop, CFG)[2]
    cap = classify(drifting, window=200, tol=1e-3)
    assert abs(cls.mean["c_max"] - cap.mean["c_max"]) <= max(1e-3 * 25.0, 0.5 * cap.amplitude["c_max"])


def test_early_classify_false_still_turns_the_early_stop_off():
    it = np.arange(600)
    h = _hist(25.0 + 0.5 * np.sin(2 * np.pi * it / 12.0))
    off = dataclasses.replace(CFG, early_classify=False)
    assert all(established(_lists({k: v[:n] for k, v in h.items()}), n, off) is None for n in range(300, 601, 25))
