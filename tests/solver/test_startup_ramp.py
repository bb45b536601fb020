"""The ramped end of the start-up: the last ``startup_ramp`` iterations of the start-up rise linearly from the
start-up relaxation towards ``alpha_u`` (``SimpleSettings.startup_ramp``; 0, the default, keeps the step)."""

import re

import pytest

from optimizer.config import ConfigError, load_config
from solver import SimpleSettings
from solver.simple import _startup_settings, iteration_alpha_u


def _schedule(settings: SimpleSettings, n: int) -> list[float]:
    return [iteration_alpha_u(settings, it) for it in range(1, n + 1)]


def test_no_ramp_is_the_step():
    s = SimpleSettings(alpha_u=0.95, startup_iterations=3, startup_alpha_u=0.7, startup_ramp=0)
    assert _schedule(s, 6) == [0.7] * 3 + [0.95] * 3


def test_the_start_ups_last_iterations_rise_linearly():
    s = SimpleSettings(alpha_u=0.95, startup_iterations=6, startup_alpha_u=0.7, startup_ramp=4)
    expected = [0.7, 0.7] + [0.7 + 0.25 * j / 5 for j in range(1, 5)] + [0.95, 0.95]
    assert _schedule(s, 8) == pytest.approx(expected, rel=0, abs=1e-15)
    assert all(a < b for a, b in zip(expected[1:6], expected[2:7], strict=True))


def test_a_ramp_over_the_whole_start_up_starts_at_the_first_iteration():
    s = SimpleSettings(alpha_u=0.9, startup_iterations=3, startup_alpha_u=0.5, startup_ramp=3)
    assert _schedule(s, 5) == pytest.approx([0.6, 0.7, 0.8, 0.9, 0.9], rel=0, abs=1e-15)
    longer = SimpleSettings(alpha_u=0.9, startup_iterations=3, startup_alpha_u=0.5, startup_ramp=50)
    assert _schedule(longer, 5) == _schedule(s, 5)          # at most the whole start-up


def test_no_start_up_no_ramp():
    s = SimpleSettings(alpha_u=0.9, startup_iterations=0, startup_alpha_u=0.5, startup_ramp=10)
    assert _schedule(s, 3) == [0.9] * 3


def test_the_ramp_never_raises_the_relaxation():
    s = SimpleSettings(alpha_u=0.5, startup_iterations=6, startup_alpha_u=0.7, startup_ramp=4)
    assert _schedule(s, 9) == [0.5] * 9


def test_settings_are_built_only_where_the_relaxation_changes():
    s = SimpleSettings(alpha_u=0.95, startup_iterations=4, startup_alpha_u=0.7, startup_ramp=2)
    current, seen = s, []
    for it in range(1, 7):
        current = _startup_settings(s, current, it)
        seen.append(current)
    assert seen[0] is seen[1] and seen[0] is not s and seen[0].alpha_u == 0.7
    assert len({id(x) for x in seen[:4]}) == 3                 # plateau, two ramp iterations
    assert seen[4] is s and seen[5] is s                      # the caller's own settings after the start-up
    assert seen[2] == SimpleSettings(alpha_u=0.7 + 0.25 / 3, alpha_p=1.0, startup_iterations=4, startup_alpha_u=0.7,
                                     startup_ramp=2)                 # and the start-up's alpha_p


def test_the_ramp_is_a_validated_solver_key():
    assert load_config(overrides=["solver.startup_ramp=40"]).solver.startup_ramp == 40
    assert load_config().solver.startup_ramp == SimpleSettings().startup_ramp
    with pytest.raises(ConfigError, match=re.escape("'solver.startup_ramp' = -1 is outside [0, 100000]")):
        load_config(overrides=["solver.startup_ramp=-1"])
