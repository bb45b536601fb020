"""The evaluation records (optimizer.evaluation): strict JSON, artifacts kept by the pipeline."""

import json

import numpy as np
import pytest

from optimizer.evaluation import FAILED, SOLVED, STAGES, Artifacts, Evaluation, finite


def test_finite_replaces_every_non_finite_float_by_none():
    raw = {"a": float("nan"), "b": [1.0, float("inf"), np.float64(-np.inf)], "c": (np.int64(3), "x"),
           "d": {"e": np.float32(2.5)}}
    assert finite(raw) == {"a": None, "b": [1.0, None, None], "c": [3, "x"], "d": {"e": 2.5}}
    assert type(finite(np.int64(3))) is int


def test_a_failed_evaluation_is_strict_json_without_figures():
    ev = Evaluation("failed", "mesh", "MeshingError: no", seconds={"geometry": 0.1, "mesh": 2.0})
    assert not ev.ok and ev.status in FAILED and ev.stage in STAGES
    d = json.loads(ev.to_json())
    assert d["F_Y"] is None and d["wall"] is None and d["classification"] is None
    assert d["seconds"] == {"geometry": 0.1, "mesh": 2.0} and d["status"] == "failed"
    assert set(SOLVED).isdisjoint(FAILED)


def test_artifacts_merge_keeps_what_was_built():
    built = Artifacts(profile="p").merged(Artifacts(mesh="m"))
    assert (built.profile, built.mesh, built.flow) == ("p", "m", None)
    assert built.merged(Artifacts()) == built and built.merged(Artifacts(mesh="n")).mesh == "n"
    assert "artifacts" not in Evaluation("failed", "mesh", "x", artifacts=built).summary()


def test_lift_and_pressure_coefficients_follow_their_definitions():
    from optimizer.figures import lift_coefficient, pressure_coefficient_min

    # Eq. 23 with F_Y over a 4 mm span of a 0.1 m chord in water at 10 m/s: F_Y / (½ rho C0² L span)
    assert lift_coefficient(-40.0, 998.2, 10.0, 0.1, 0.004) == pytest.approx(-40.0 / (0.5 * 998.2 * 100 * 0.1 * 0.004))
    assert pressure_coefficient_min(10.0, 10.0) == 0.0 and pressure_coefficient_min(20.0, 10.0) == -3.0
