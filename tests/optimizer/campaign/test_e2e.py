"""End to end: a real CFD campaign (coarse mesh, k-omega SST, population 4, 2 generations) on a dask
LocalCluster with 2 worker processes, through ``millfoil run`` without a CONFIG — the embedded quickstart
campaign cut to two generations. Several minutes: marked slow."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from optimizer.campaign.status import EvaluationStatus
from optimizer.campaign.store import STORE_NAME, Store

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[3]


def test_tiny_cfd_campaign_on_a_local_cluster(tmp_path):
    run = tmp_path / "run"
    cmd = [sys.executable, "-m", "optimizer.cli", "run", "--out", str(run),       # no CONFIG: the quickstart
           "--set", "algorithm.generations=2", "--set", "execution.backend=local", "--set", "execution.workers=2"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "non-dominated designs" in done.stdout
    with Store(run / STORE_NAME, readonly=True) as store:
        rows = list(store.evaluations())
        generations = store.generations()
        assert store.campaign().state == "finished"
    assert len(generations) == 2 and all(len(g.members) == 4 for g in generations)
    assert 4 <= len(rows) <= 8
    assert all(r.status in list(EvaluationStatus) and r.reason for r in rows)
    solved = [r for r in rows if r.status != "infeasible"]
    assert len({r.worker for r in solved}) == 2                       # both worker processes took work
    assert all(r.worker.startswith("tcp://") for r in solved)
    meshed = [r for r in solved if r.cells]
    assert meshed and all(3000 < r.cells < 8000 for r in meshed)        # coarse, 1-chord channel: ~5 000
    ok = [r for r in rows if r.status == "ok"]
    assert len(ok) >= 2                                                 # the solves behind the front ran
    for r in ok:
        assert r.convergence in ("converged", "stationary", "oscillating")
        assert all(math.isfinite(v) for v in r.objectives.values())
        assert r.objectives["|fy|"] > 0 and r.objectives["c_max"] > 10.0     # faster than C0 = 10 m/s
        assert set(r.seconds) >= {"geometry", "mesh", "solve", "post"}
