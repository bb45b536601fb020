"""Fields files of a campaign (no CFD): the writer on an Evaluation-shaped object with a real blade outline
and invented values, the worker's failure note, and pruning to the front's designs."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from geometry import BladeSpec, build_profile
from optimizer.campaign.fields import (
    FIELDS_DIR,
    GRID,
    fields_path,
    outline,
    prune_fields,
    read_fields,
    with_fields,
    write_fields,
)
from optimizer.campaign.record import SOLVED, EvaluationRecord, keep_fields
from optimizer.campaign.store import STORE_NAME, EvaluationRow, Store, non_dominated
from optimizer.report.synthetic import TABLE5_G1_TOOLPATH, synthetic_evaluation


@pytest.fixture(scope="module")
def blade():
    return build_profile(BladeSpec.from_values("toolpath", "G1", TABLE5_G1_TOOLPATH)).points


def test_written_file_round_trips(tmp_path, blade):
    ev = synthetic_evaluation(blade, c0=10.0)
    path = write_fields(ev, tmp_path / FIELDS_DIR / "abc.npz", c0=10.0)
    data = read_fields(path)
    assert sorted(p.name for p in path.parent.iterdir()) == ["abc.npz"]       # no temporary file left
    assert path.stat().st_size < 400_000
    np.testing.assert_array_equal(data["side"], ev.wall.side)
    for name in ("s", "x", "y", "cp", "cf", "y_plus"):
        np.testing.assert_allclose(data[name], getattr(ev.wall, name), rtol=1e-6)
    assert data["speed"].shape == (GRID[1], GRID[0]) and data["c0"] == 10.0
    gx, gy = data["grid_x"], data["grid_y"]
    assert gx[-1] - gx[0] == pytest.approx(1.5 * np.ptp(blade[:, 0]), rel=1e-3)
    assert np.diff(gx)[0] == pytest.approx(np.diff(gy)[0], rel=1e-9)             # square cells
    X, Y = np.meshgrid(gx, gy)
    inside = shapely.contains_xy(shapely.Polygon(blade), X, Y)
    assert inside.sum() > 100
    # NaN inside the blade (up to the face-centre outline's chord error), the sampled field outside
    assert np.isnan(data["speed"][inside]).mean() > 0.97
    outside = ~shapely.contains_xy(shapely.Polygon(outline(ev.wall)), X, Y)
    expected = np.linalg.norm(ev.artifacts.flow.sample(np.column_stack([X[outside], Y[outside]])), axis=1)
    np.testing.assert_allclose(data["speed"][outside], expected, rtol=1e-6)


def test_a_write_failure_is_a_note_not_a_failed_evaluation(tmp_path, blade):
    blocker = tmp_path / "not_a_directory"
    blocker.write_text("")
    solved = EvaluationRecord(SOLVED, "converged")
    config = SimpleNamespace(flow=SimpleNamespace(speed=10.0))
    record = keep_fields(synthetic_evaluation(blade), config, str(blocker / "k.npz"), solved)
    assert record.solved and record.fields is None
    assert record.reason.startswith("converged; fields not kept (")
    record = keep_fields(SimpleNamespace(wall=None, artifacts=SimpleNamespace(flow=None)), config,
                         str(tmp_path / "k.npz"), solved.replace(reason="ok"))
    assert record.fields is None and "no wall distribution" in record.reason
    record = keep_fields(synthetic_evaluation(blade), config, str(tmp_path / "f" / "k.npz"),
                         solved.replace(reason="ok"))
    assert record.fields == str(tmp_path / "f" / "k.npz") and record.reason == "ok"


def test_payload_names_the_file_for_blades_only(tmp_path):
    blade_payload = with_fields({"kind": "blade", "parameters": {}}, tmp_path, "k1")
    assert blade_payload["fields"] == str(fields_path(tmp_path.absolute(), "k1"))
    assert with_fields({"kind": "zdt1", "x": [0.1]}, tmp_path, "k1") == {"kind": "zdt1", "x": [0.1]}


def _row(key: str, f: list[float], status: str = "ok", violated: bool = False) -> EvaluationRow:
    return EvaluationRow(key=key, generation=0, x=[0.0], parameters={}, status=status, reason="", minimised=f,
                         constraints={"evaluation": 1.0 if violated else 0.0})


def test_pruning_keeps_exactly_the_fronts_files(tmp_path):
    rows = [_row("a", [0, 3]), _row("b", [1, 1]), _row("c", [3, 0]), _row("d", [2, 2]),     # d dominated by b
            _row("e", [-1, -1], violated=True), _row("f", [-2, -2], status="oscillating"),   # not feasible/accepted
            _row("g", [1, 1])]                                                               # equal to b: kept
    with Store(tmp_path / STORE_NAME) as store:
        for r in rows:
            store.add(r)
        for key in "abcdefg" + "z":                # z: not stored yet (still running): never judged
            (tmp_path / FIELDS_DIR).mkdir(exist_ok=True)
            fields_path(tmp_path, key).write_bytes(b"")
        assert [r.key for r in store.front()] == ["a", "b", "g", "c"]
        removed = prune_fields(store)
    assert sorted(p.stem for p in removed) == ["d", "e", "f"]
    assert sorted(p.stem for p in (tmp_path / FIELDS_DIR).iterdir()) == ["a", "b", "c", "g", "z"]


def test_pruning_without_fields_does_nothing(tmp_path):
    with Store(tmp_path / STORE_NAME) as store:
        store.add(_row("a", [0, 0]))
        assert prune_fields(store) == []


def test_non_dominated_matches_a_direct_check():
    F = np.random.default_rng(3).integers(0, 6, size=(700, 3)).astype(float)       # many ties, > one chunk
    direct = [not any(np.all(G <= f) and np.any(G < f) for G in F) for f in F]
    np.testing.assert_array_equal(non_dominated(F), direct)


@pytest.mark.parametrize("n", [0, 1, 2, 700])
def test_non_dominated_of_two_objectives_matches_a_direct_check(n):
    """The sorted sweep for two columns, with ties in each column and whole rows repeated."""
    F = np.random.default_rng(n).integers(0, 6, size=(n, 2)).astype(float)
    direct = np.array([not any(np.all(G <= f) and np.any(G < f) for G in F) for f in F], bool)
    np.testing.assert_array_equal(non_dominated(F), direct)


def test_non_dominated_of_two_objectives_with_a_nan_row_compares_it_as_before():
    F = np.array([[1.0, 2.0], [np.nan, 0.0], [2.0, 1.0], [2.0, 3.0]])
    np.testing.assert_array_equal(non_dominated(F), [True, True, True, False])


@pytest.mark.slow
def test_a_campaign_keeps_the_fields_of_its_front_only(tmp_path, blade, monkeypatch):
    """The driver names each blade's fields file in its payload, the worker writes it, and after the last
    generation the files are exactly those of the stored front (stand-in pipeline: no CFD)."""
    from dataclasses import replace

    from optimizer.campaign import record
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.driver import run_campaign
    from optimizer.evaluation import Artifacts, Evaluation
    from solver.convergence import Classification

    shape = synthetic_evaluation(blade)

    def pipeline(config, *, log=None, every=0, warm_start=None):
        alpha = config.blade.parameters["alpha"]
        beta = config.blade.parameters.get("beta1bar", 60.0)
        fy, c_max = -1000.0 * alpha, 20.0 + alpha ** 1.5 / 10 + 0.01 * (beta - 60.0) ** 2   # a front, not a point
        means = {"fy:blade": fy, "c_max": c_max, "fx:blade": 10.0}
        cls = Classification("converged", means, dict.fromkeys(means, 0.0), {}, {}, 200, "converged",
                             dict.fromkeys(means, "stationary"))
        ev = Evaluation("converged", None, "converged", converged=True, classification=cls, fx=10.0, fy=fy,
                        c_max=c_max, span=0.004, cells=5000, iterations=900, seconds={"solve": 0.1})
        return replace(ev, wall=shape.wall, artifacts=Artifacts(flow=shape.artifacts.flow))

    monkeypatch.setattr(record, "_pipeline", lambda: pipeline)
    path = tmp_path / "blade.yaml"
    path.write_text("blade: {mode: design, continuity: G1}\nmesh: {level: coarse}\n"
                    "algorithm: {population: 8, generations: 3, seed: 5}\n"
                    "execution: {backend: inline}\noutput: {sync: normal}\n")
    run_campaign(load_campaign(path, ()), tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as store:
        front = {r.key for r in store.front()}
        solved = {r.key for r in store.evaluations() if r.ok}
    kept = {p.stem for p in (tmp_path / "run" / FIELDS_DIR).glob("*.npz")}
    assert front and len(solved) > len(front)
    assert kept == front
    assert not list((tmp_path / "run" / FIELDS_DIR).glob(".*"))                   # no temporary file left
