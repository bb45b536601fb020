"""Campaign runner on a real SLURM cluster (one node on 127.0.0.1, ``scripts/slurm/``), not a mock (slow).

The workers' job is cancelled with ``scancel`` in the middle of a batch — as a wall-time kill, an
administrator or a preemption would — and the runner must recover: the job is replaced by a new one, the
evaluation that was running is resubmitted, and every task of the batch finishes.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import cloudpickle
import pytest

from optimizer.campaign.runner import SlurmRunner, Task, make_runner

pytestmark = pytest.mark.slow

# SLURM workers are fresh processes that cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def sleep_and_mark(payload: dict) -> dict:
    """Touch ``payload['marker']`` (the test sees the task has started), sleep ``payload['s']`` seconds."""
    Path(payload["marker"]).touch()
    time.sleep(payload["s"])
    return {"slept": payload["s"]}


def test_scancel_mid_batch_the_runner_gets_a_new_job_and_loses_nothing(slurm, tmp_path):
    execution = slurm.execution(tmp_path / "jobs", workers=1, retries=2, timeout=120)
    started = tmp_path / "started"
    tasks = [Task(f"t{i}", {"s": 5.0, "marker": str(started)}, 0) for i in range(2)]
    cancelled: list[str] = []

    def cancel_once_running():
        while not started.exists():
            time.sleep(0.2)
        cancelled.extend(slurm.jobs(execution))
        slurm.cancel(execution)

    with make_runner(execution) as runner:
        assert isinstance(runner, SlurmRunner)
        killer = threading.Thread(target=cancel_once_running, daemon=True)
        killer.start()
        results = {r.key: r for r in runner.run(sleep_and_mark, tasks)}
        killer.join(timeout=5)
        jobs_after = slurm.jobs(execution)

    assert len(cancelled) == 1, "the batch must have been running on exactly one job when it was cancelled"
    assert set(results) == {"t0", "t1"}
    assert all(r.status == "done" and r.record == {"slept": 5.0} for r in results.values())
    assert sorted(r.attempts for r in results.values()) == [1, 2]  # the running one was resubmitted once
    assert jobs_after and not set(jobs_after) & set(cancelled), "a new job replaced the cancelled one"


def test_job_script_carries_lifetimes_pinned_threads_and_options(slurm, tmp_path):
    execution = slurm.execution(tmp_path, workers=1)
    execution["cluster"] |= {"walltime": "01:00:00", "job_extra_directives": ["--comment=millfoil"],
                             "job_script_prologue": ["echo prologue"]}
    runner = make_runner(execution)
    with runner:
        script = runner.cluster.job_script()
    assert "#SBATCH -t 01:00:00" in script and "#SBATCH --comment=millfoil" in script
    assert f"#SBATCH -J {execution['cluster']['job_name']}" in script
    assert "export OMP_NUM_THREADS=1" in script and "echo prologue" in script
    assert "--lifetime 3000s --lifetime-stagger 300s" in script and "--nthreads 1" in script


def test_workers_retire_before_their_wall_time_and_new_jobs_take_over(slurm, tmp_path):
    # lifetime 12 s ± 1 s against 8 tasks of 3 s on one single-worker job: the worker retires mid-batch
    execution = slurm.execution(tmp_path / "jobs", workers=1, retries=3, timeout=120)
    execution["cluster"] |= {"lifetime": "12s", "lifetime_stagger": "1s"}
    tasks = [Task(f"t{i}", {"s": 3.0, "marker": str(tmp_path / "started")}, 0) for i in range(8)]
    jobs_seen: set[str] = set()
    with make_runner(execution) as runner:
        results = []
        for result in runner.run(sleep_and_mark, tasks):
            results.append(result)
            jobs_seen |= set(slurm.jobs(execution))
    assert sorted(r.key for r in results) == sorted(t.key for t in tasks)
    assert all(r.status == "done" for r in results)
    assert len(jobs_seen) >= 2, "the retired worker's job was replaced by a new one"
    assert len({r.worker for r in results}) >= 2
