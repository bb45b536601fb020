"""The solver's gentle start-up on a blade that needs it (coarse mesh, the campaigns' channel)."""

import pytest

pytest.importorskip("gmsh")

from optimizer.config import Config  # noqa: E402
from optimizer.pipeline import evaluate  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("startup_iterations,status", [(0, "diverged"), (50, "converged")])
def test_coarse_channel_blade_needs_the_gentle_start(startup_iterations, status):
    """Random blade 4 of ``bench/bench_robustness.py`` in the campaigns' channel at coarse: from the free
    stream at alpha_u 0.95 the leading-edge cells blow up at iteration 10; 50 iterations at 0.7 first and it
    converges (F_Y -7 193 N/m; -7 146 at medium)."""
    params = {"L": 0.1, "alpha": 24.72724458654757, "beta1": 8.179870404293172, "beta1bar": 29.954863950858122,
              "u_s2": 0.2665537845233394, "d_s1": 0.007931127313857598, "d_s2": 0.011754531756695236,
              "d_s3": 0.0474040272783459, "d_s4": 0.002, "d_p3": 0.033809094985744526, "d_p4": 0.002}
    ev = evaluate(Config.from_mapping({"blade": {"mode": "design", "continuity": "C2", "parameters": params},
                                       "mesh": {"level": "coarse", "half_height": 1.0},
                                       "solver": {"startup_iterations": startup_iterations}}))
    summary = ev.summary()
    assert summary["status"] == status
    if status == "converged":
        assert summary["F_Y"] == pytest.approx(-7146.3, rel=0.03)     # the same blade at medium (oscillating)
