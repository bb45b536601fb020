"""A whole campaign on a real SLURM cluster (one node on 127.0.0.1, ``scripts/slurm/``), not a mock (slow).

A tiny campaign runs through dask-jobqueue's ``SLURMCluster``; the workers' job is cancelled with
``scancel`` in the middle of a generation (as a wall-time kill, an administrator or a preemption would),
and the campaign must recover with nothing lost: it finishes, every design of every generation is stored
exactly once, the evaluation the cancelled job was running is retried on a new job, and no evaluation is
solved twice. The problem is ZDT1 through the same driver, store and runner as a blade campaign (no CFD),
each evaluation sleeping long enough for the cancel to land inside one.
"""

from __future__ import annotations

import json
import sqlite3
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import cloudpickle
import pytest
import yaml

from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import run_campaign
from optimizer.campaign.runner import SlurmRunner, make_runner
from optimizer.campaign.store import STORE_NAME, Store

pytestmark = pytest.mark.slow

# SLURM workers are fresh processes that cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])

POPULATION, GENERATIONS = 6, 3
#: Seconds each evaluation sleeps on its worker: the cancel must find one running.
DELAY = 1.0


def logged_evaluation(log: str):
    """The campaign's worker function, appending ``start X`` and ``end X`` lines to the file ``log`` around
    each evaluation (X: the design vector as JSON), so the test sees what ran where and how often."""
    def evaluate(payload: dict) -> dict:
        from optimizer.campaign.record import evaluate_payload

        x = json.dumps(payload["x"])
        with open(log, "a") as fh:
            fh.write(f"start {x}\n")
        record = evaluate_payload(payload)
        with open(log, "a") as fh:
            fh.write(f"end {x}\n")
        return record
    return evaluate


class CountingRunner:
    """The SLURM runner, keeping every task result it hands the driver (key, attempts)."""

    def __init__(self, runner):
        self.runner, self.results = runner, []

    def __enter__(self):
        self.runner.__enter__()
        return self

    def __exit__(self, *exc):
        return self.runner.__exit__(*exc)

    def __getattr__(self, name):
        return getattr(self.runner, name)

    def run(self, fn, tasks):
        for result in self.runner.run(fn, tasks):
            self.results.append(result)
            yield result


def cancel_mid_generation(slurm, execution: dict, store_path: Path, cancelled: list, generation: int = 1):
    """Wait until ``generation`` generations are stored and two evaluations of the next one, then scancel
    the workers' job (the single worker is then inside the next evaluation) and record its id."""
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        if store_path.exists():
            try:
                with Store(store_path, readonly=True) as store:
                    ready = (len(store.generations()) == generation
                             and len(list(store.evaluations(generation))) >= 2)
            except Exception:              # the driver may be creating the tables right now
                ready = False
            if ready:
                cancelled.extend(slurm.jobs(execution))
                slurm.cancel(execution)
                return
        time.sleep(0.05)


def test_scancel_mid_generation_the_campaign_recovers_with_nothing_lost(slurm, tmp_path):
    execution = slurm.execution(tmp_path / "jobs", workers=1, retries=2, timeout=120)
    config_path = tmp_path / "zdt1.yaml"
    config_path.write_text(yaml.safe_dump({
        "analytic": {"problem": "zdt1", "variables": 4, "delay": DELAY},
        "algorithm": {"population": POPULATION, "generations": GENERATIONS, "seed": 3},
        "execution": execution}))
    config = load_campaign(config_path)
    run, log = tmp_path / "run", tmp_path / "evaluations.log"
    runner = CountingRunner(make_runner(config.execution))
    assert isinstance(runner.runner, SlurmRunner)
    cancelled: list[str] = []
    killer = threading.Thread(target=cancel_mid_generation, args=(slurm, execution, run / STORE_NAME, cancelled),
                              daemon=True)
    killer.start()
    try:
        outcome = run_campaign(config, run, runner=runner, fn=logged_evaluation(str(log)))
    finally:
        killer.join(timeout=5)
        slurm.cancel(execution)                              # whatever is left of this test's jobs

    assert len(cancelled) == 1, "the campaign must have been running on exactly one job when it was cancelled"
    assert outcome.state == "finished" and outcome.generations == GENERATIONS

    with Store(run / STORE_NAME, readonly=True) as store:
        rows = {r.key: r for r in store.evaluations()}
        generations = store.generations()
    with sqlite3.connect(run / STORE_NAME) as db:
        count, distinct = db.execute("SELECT COUNT(*), COUNT(DISTINCT key) FROM evaluations").fetchone()
    asked = [key for g in generations for key in g.offspring]
    # every design of every generation stored exactly once: none missing, none twice, none extra
    assert len(generations) == GENERATIONS and all(len(g.offspring) == POPULATION for g in generations)
    assert count == distinct == len(rows) == len(set(asked)) == len(asked) == POPULATION * GENERATIONS
    assert set(rows) == set(asked)
    assert {r.key: r.generation for r in rows.values()} == {k: g.generation for g in generations for k in g.offspring}
    assert all(r.status == "ok" for r in rows.values()), Counter(r.status for r in rows.values())
    assert all(set(g.members) <= set(rows) for g in generations)

    # the runner handed each design to the driver once; the one the cancelled job was running was retried
    handed = Counter(r.key for r in runner.results)
    assert set(handed) == set(rows) and set(handed.values()) == {1}
    assert max(r.attempts for r in runner.results) == 2, "the evaluation running at the cancel was resubmitted"
    assert len({r.worker for r in rows.values()}) >= 2, "a new job's worker took over"

    # on the workers: each stored design finished exactly once; only the lost one started twice
    lines = log.read_text().splitlines()
    starts = Counter(line.removeprefix("start ") for line in lines if line.startswith("start "))
    ends = Counter(line.removeprefix("end ") for line in lines if line.startswith("end "))
    assert sorted(ends) == sorted(json.dumps(r.x) for r in rows.values()) and set(ends.values()) == {1}
    assert sum(starts.values()) - sum(ends.values()) == 1
