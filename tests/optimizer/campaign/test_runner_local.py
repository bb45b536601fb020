"""Campaign runner, ``local`` backend: real worker processes on a ``LocalCluster`` with 2 workers (slow).

A worker process killed mid-task (SIGKILL from inside the task, as an out-of-memory kill or a segfault in a
native library would) must cost the task a retry, not the batch; a task that runs past its timeout must be
reported at the timeout and its worker, still busy, restarted.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from optimizer.campaign.runner import PINNED_THREADS_ENV, LocalRunner, Task, make_runner

pytestmark = pytest.mark.slow


def worker_environment(payload: dict) -> dict:
    """The thread settings and identity of the worker process that runs it."""
    from threadpoolctl import threadpool_info

    return {"env": {k: os.environ.get(k) for k in PINNED_THREADS_ENV}, "pid": os.getpid(),
            "blas_threads": [pool["num_threads"] for pool in threadpool_info()]}


def page_faults_of_reuse(payload: dict) -> dict:
    """Minor page faults of 20 arrays of 1 MB allocated, written and freed in turn, before and after the
    worker function's per-process preparation (an evaluation of an unknown kind does just that)."""
    import resource

    import numpy as np

    from optimizer.campaign.record import evaluate_payload

    def faults() -> int:
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(20):
            np.ones(2**17)
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

    unprepared = faults()
    evaluate_payload({"kind": "none"})
    return {"trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"), "before": unprepared, "after": faults()}


def sleep_for(payload: dict) -> dict:
    time.sleep(payload["s"])
    return {"slept": payload["s"], "pid": os.getpid()}


def die_once(payload: dict) -> dict:
    """SIGKILL the worker process on the first attempt (marker file absent), succeed on the next."""
    marker = Path(payload["marker"])
    if not marker.exists():
        marker.write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return {"pid": os.getpid()}


def die_always(payload: dict) -> dict:
    """SIGKILL the worker process on every attempt, counting attempts in a file."""
    with open(payload["count"], "a") as fh:
        fh.write("x")
    os.kill(os.getpid(), signal.SIGKILL)
    return {}


def raise_runtime_error(payload: dict) -> dict:
    raise RuntimeError("bug in fn")


@pytest.fixture(scope="module")
def runner():
    with make_runner({"backend": "local", "workers": 2, "timeout": 2.0, "timeout_grace": 1.0,
                      "retries": 1}) as runner:
        yield runner


def test_two_single_threaded_workers_with_pinned_blas(runner):
    assert isinstance(runner, LocalRunner) and runner.workers == 2
    assert set(runner.client.nthreads().values()) == {1}
    results = list(runner.run(worker_environment, [Task(f"e{i}", {}, 0) for i in range(2)]))
    for r in results:
        assert r.status == "done" and r.worker.startswith("tcp://")
        assert r.record["env"] == PINNED_THREADS_ENV
        assert set(r.record["blas_threads"]) <= {1}
        assert r.record["pid"] != os.getpid()


def test_the_worker_function_keeps_freed_memory_for_reuse(runner):
    """dask starts the workers with MALLOC_TRIM_THRESHOLD_=65536: every freed array goes back to the kernel
    and is faulted in again (256 pages per MB) until the worker function changes that."""
    (r,) = runner.run(page_faults_of_reuse, [Task("m", {}, 0)])
    assert r.status == "done", r.message
    assert r.record["trim"] == "65536" and r.record["before"] > 20 * 200     # every array faulted in
    assert r.record["after"] < 2 * 257                                        # the first one at most


def test_as_completed_and_every_worker_used(runner):
    tasks = [Task("long", {"s": 1.0}, 1), Task("short1", {"s": 0.05}, 1), Task("short2", {"s": 0.05}, 1)]
    results = list(runner.run(sleep_for, tasks))
    assert [r.key for r in results] == ["short1", "short2", "long"]
    assert len({r.record["pid"] for r in results}) == 2
    assert all(r.generation == 1 for r in results)


def test_a_raise_is_an_error_with_the_worker(runner):
    (r,) = runner.run(raise_runtime_error, [Task("bug", {}, 0)])
    assert r.status == "error" and "RuntimeError: bug in fn" in r.reason and r.worker.startswith("tcp://")


def test_a_worker_killed_mid_task_costs_a_retry_not_the_task(runner, tmp_path):
    tasks = [Task("victim", {"fn": "victim", "marker": str(tmp_path / "killed")}, 0),
             Task("bystander", {"fn": "bystander", "s": 0.2}, 0)]
    results = {r.key: r for r in runner.run(dispatch, tasks)}
    assert (tmp_path / "killed").exists()
    assert results["victim"].status == "done" and results["victim"].attempts == 2
    assert results["victim"].record["pid"] != int((tmp_path / "killed").read_text())
    assert results["bystander"].status == "done" and results["bystander"].attempts == 1
    _wait_for_workers(runner, 2)


def test_retries_exhausted_is_worker_lost(runner, tmp_path):
    count = tmp_path / "attempts"
    (r,) = runner.run(die_always, [Task("doomed", {"count": str(count)}, 0)])
    assert r.status == "worker_lost" and r.record is None
    assert count.read_text() == "xx"  # the first attempt and retries=1 more
    assert r.attempts == 2 and "lost with its worker 2 times" in r.reason
    _wait_for_workers(runner, 2)


def test_a_stuck_task_times_out_and_its_worker_is_restarted(runner):
    t0 = time.monotonic()
    results = list(runner.run(sleep_for, [Task("stuck", {"s": 60.0}, 0), Task("quick", {"s": 0.1}, 0)]))
    assert [r.key for r in results] == ["quick", "stuck"]
    stuck = results[1]
    assert stuck.status == "timeout" and 2.0 <= stuck.seconds < 4.0
    assert time.monotonic() - t0 < 10
    # the next batch runs while the grace period ends: the stuck worker is killed and replaced, and a task
    # that was sent to it meanwhile is resubmitted without costing a retry (retries=1 here)
    time.sleep(1.5)
    results = list(runner.run(sleep_for, [Task(f"after{i}", {"s": 0.5}, 0) for i in range(3)]))
    assert all(r.status == "done" and r.attempts == 1 for r in results)
    _wait_for_workers(runner, 2, timeout=120)
    assert stuck.worker not in runner.client.nthreads(), "the stuck worker was replaced by a fresh process"


def dispatch(payload: dict) -> dict:
    """Route a task to :func:`die_once` or :func:`sleep_for` by ``payload['fn']``."""
    return {"victim": die_once, "bystander": sleep_for}[payload["fn"]](payload)


def _wait_for_workers(runner, n: int, timeout: float = 30.0) -> None:
    """Wait until the nannies have replaced killed workers (so the next test starts with ``n``)."""
    deadline = time.monotonic() + timeout
    while runner.workers < n and time.monotonic() < deadline:
        time.sleep(0.2)
    assert runner.workers == n
