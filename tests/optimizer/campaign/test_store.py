"""The campaign store: round trips, WAL and concurrent reading from another process."""

from __future__ import annotations

import math
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from optimizer.campaign.status import EvaluationStatus
from optimizer.campaign.store import STORE_NAME, EvaluationRow, GenerationRow, Store


def row(key: str, generation: int = 0, status: str = "ok", **changes) -> EvaluationRow:
    values = dict(
        key=key, generation=generation, x=[0.1, 1 / 3], parameters={"alpha": 9.013, "L": 0.1}, status=status,
        reason="converged", minimised=[-9924.335343228982, 27.00277318938347],
        constraints={"eq21_inlet": -0.25, "evaluation": 0.0}, convergence="converged",
        objectives={"|fy|": 9924.335343228982, "c_max": 27.00277318938347},
        figures={"fy": -9924.335343228982, "c_l": None}, monitors={"fy:blade": {"mean": -9924.3, "amplitude": 1.5,
                                                                              "status": "stationary"}},
        cells=4971, iterations=1310, seconds={"mesh": 1.5, "solve": 70.25}, wall_seconds=75.0, worker="tcp://w1",
        submitted="2026-01-01T00:00:00+00:00")
    values.update(changes)
    return EvaluationRow(**values)


def test_evaluation_round_trip_is_exact(tmp_path):
    original = row("a")
    with Store(tmp_path / "s.sqlite") as store:
        store.start_campaign("analytic: {}\n", 3, "0.1.0")
        store.add(original)
        back = store.get("a")
    assert back == original            # floats bit-for-bit (JSON repr), dicts, None


def test_non_finite_values_round_trip(tmp_path):
    with Store(tmp_path / "s.sqlite") as store:
        store.start_campaign("x: 1\n", 1, "0")
        store.add_generation(GenerationRow(0, ["a", "b"], [0, 0], [math.inf, 0.5], ["a", "b"], 2, 1.0, 0, None,
                                           {"bit_generator": "PCG64", "state": {"state": 2**127 + 5, "inc": 7}}))
        g = store.last_generation()
    assert g.crowding == [math.inf, 0.5]
    assert g.rng_state["state"]["state"] == 2**127 + 5       # big integers survive JSON


def test_a_key_is_stored_once(tmp_path):
    with Store(tmp_path / "s.sqlite") as store:
        store.add(row("a"))
        with pytest.raises(sqlite3.IntegrityError):
            store.add(row("a", generation=1))


def test_unknown_status_is_refused():
    with pytest.raises(ValueError, match="allowed: ok, infeasible"):
        row("a", status="fine")
    assert {"ok", "infeasible", "mesh_failed", "diverged", "not_converged", "oscillating", "timeout",
            "worker_lost", "error"} <= set(EvaluationStatus)


def test_campaign_row_and_states(tmp_path):
    with Store(tmp_path / "s.sqlite") as store:
        store.start_campaign("cfg\n", 5, "0.1.0")
        store.set_reference([1.1, -2.0])
        store.end_campaign("interrupted", "signal")
        c = store.campaign()
        assert (c.seed, c.version, c.state, c.message) == (5, "0.1.0", "interrupted", "signal")
        assert c.reference == [1.1, -2.0]
        store.start_campaign("ignored\n", 9, "9")         # resume: same row, running again
        c = store.campaign()
        assert (c.config, c.seed, c.state, c.ended) == ("cfg\n", 5, "running", None)


@pytest.mark.slow
def test_wal_and_read_from_another_process_while_writing(tmp_path):
    path = tmp_path / "s.sqlite"
    store = Store(path)
    store.start_campaign("cfg\n", 1, "0")
    store.add(row("a"))
    mode = store._db.execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"
    # the writer keeps its connection open (as the driver does); another process reads
    code = ("import sys; from optimizer.campaign.store import Store; s = Store(sys.argv[1], readonly=True); "
            "print(len(list(s.evaluations())), s.campaign().state)")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1", "running"]
    store.add(row("b", generation=1))
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["2", "running"]
    store.close()


def test_readonly_store_refuses_writes_and_missing_files(tmp_path):
    with Store(tmp_path / "s.sqlite") as store:
        store.start_campaign("cfg\n", 1, "0")
    with Store(tmp_path / "s.sqlite", readonly=True) as ro:
        with pytest.raises(sqlite3.OperationalError):
            ro.add(row("a"))
    with pytest.raises(FileNotFoundError):
        Store(tmp_path / "none.sqlite", readonly=True)


def test_queries_by_generation_and_status(tmp_path):
    with Store(tmp_path / "s.sqlite") as store:
        store.add(row("a", 0))
        store.add(row("b", 0, status="mesh_failed", objectives=None))
        store.add(row("c", 1, status="infeasible"))
        assert store.count_by_status() == {"ok": 1, "mesh_failed": 1, "infeasible": 1}
        assert store.count_by_status(0) == {"ok": 1, "mesh_failed": 1}
        assert [r.key for r in store.evaluations(1)] == ["c"]
        assert set(store.get_many(["a", "c", "zz"])) == {"a", "c"}


def test_a_new_store_appears_with_its_tables(tmp_path, monkeypatch):
    """The tables are made in a temporary file renamed onto the store's name: a reader the moment a run starts
    finds either no store or an empty one with every table, never a store without its tables."""
    import optimizer.campaign.store as store_module

    seen = []
    real_replace = store_module.os.replace

    def replace(src, dst):
        seen.append(Path(dst).exists())          # the store's name is free until the rename
        with sqlite3.connect(src) as db:
            seen.append({r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")})
        real_replace(src, dst)

    monkeypatch.setattr(store_module.os, "replace", replace)
    with Store(tmp_path / STORE_NAME) as s:
        assert s.campaign() is None
    assert seen == [False, {"campaign", "evaluations", "generations"}]
    assert sorted(p.name for p in tmp_path.iterdir() if "partial" in p.name) == []
