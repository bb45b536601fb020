"""Campaign runner: configuration, the inline backend, and the dask result loop on an in-process cluster.

The in-process cluster (worker threads, no processes) exercises the same loop as the ``local`` backend —
as-completed order, timeouts, errors — in well under a second; the process-level behaviours (a worker
killed, a stuck worker restarted, BLAS pinned) are in ``test_runner_local.py`` (slow). No test here asserts a
wall time: evaluations wait on events the test sets, and timeouts are reached by advancing the runner's
injected clock, so a busy machine makes them slower, never wrong.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import threading
import time
from pathlib import Path

import pytest
from pydantic import ValidationError

from optimizer.campaign.runner import (
    RUNNERS,
    ClusterOptions,
    DaskRunner,
    ExecutionConfig,
    InlineRunner,
    Task,
    _signals_held,
    make_runner,
    walltime_seconds,
)

#: Events the in-process workers' evaluations wait on, by name (the worker threads share this module).
EVENTS: dict[str, threading.Event] = {}
#: Names of the evaluations that returned.
FINISHED: set[str] = set()


def sleep_then_echo(payload: dict) -> dict:
    """Sleep ``payload['s']`` seconds, return the payload (``deadline_s`` included)."""
    time.sleep(payload["s"])
    return payload


def wait_then_echo(payload: dict) -> dict:
    """Wait until ``EVENTS[payload['wait']]`` is set (no wait without one; 30 s at most), return the payload."""
    if "wait" in payload:
        EVENTS[payload["wait"]].wait(30)
        FINISHED.add(payload["wait"])
    return payload


def raise_value_error(payload: dict) -> dict:
    raise ValueError(f"bad payload {payload['n']}")


def tasks_sleeping(*seconds: float) -> list[Task]:
    return [Task(key=f"k{i}", payload={"s": s}, generation=3) for i, s in enumerate(seconds)]


# ---- configuration ---------------------------------------------------------------------------------


def test_defaults_are_a_local_cluster_with_retries():
    cfg = ExecutionConfig()
    assert (cfg.backend, cfg.workers, cfg.retries) == ("local", None, 2)
    assert cfg.timeout > 0


def test_registry_covers_every_backend():
    assert set(RUNNERS) == {"inline", "local", "scheduler", "slurm", "pbs"}
    for backend in ("inline", "local", "slurm", "pbs"):
        assert isinstance(make_runner({"backend": backend}), RUNNERS[backend])


def test_unknown_backend_names_the_key_and_allowed_values():
    with pytest.raises(ValidationError) as err:
        ExecutionConfig(backend="kubernetes")
    (e,) = err.value.errors()
    assert e["loc"] == ("backend",) and e["input"] == "kubernetes"
    for name in RUNNERS:
        assert name in e["msg"]


@pytest.mark.parametrize("bad", [{"workers": True}, {"retries": False}, {"timeout": True},
                                 {"cluster": {"cores": True}}])
def test_a_boolean_is_not_a_number(bad):
    with pytest.raises(ValidationError, match="a number is expected, not a boolean") as err:
        ExecutionConfig.model_validate(bad)
    assert err.value.errors()[0]["loc"][0] == next(iter(bad))


@pytest.mark.parametrize("key", ["timeout", "timeout_grace"])
@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_non_finite_numbers_are_refused_naming_the_key(key, value):
    with pytest.raises(ValidationError, match="finite number") as err:
        ExecutionConfig.model_validate({key: value})
    assert err.value.errors()[0]["loc"] == (key,)


def test_unknown_key_names_it_and_the_allowed_keys():
    with pytest.raises(ValidationError) as err:
        ExecutionConfig.model_validate({"backend": "local", "worker": 2})
    msg = str(err.value)
    assert "unknown key 'worker'; allowed: backend, workers, timeout, retries" in msg


def test_unknown_cluster_key_names_it_and_the_allowed_keys():
    with pytest.raises(ValidationError) as err:
        ExecutionConfig.model_validate({"backend": "slurm", "cluster": {"partition": "gpu"}})
    (e,) = err.value.errors()
    assert e["loc"][0] == "cluster"
    assert "'partition'" in e["msg"] and "queue" in e["msg"] and "job_extra_directives" in e["msg"]


@pytest.mark.parametrize("bad", [{"workers": 0}, {"timeout": 0}, {"retries": -1}, {"timeout_grace": -1}])
def test_out_of_range_numbers_are_rejected_naming_the_key(bad):
    with pytest.raises(ValidationError) as err:
        ExecutionConfig.model_validate(bad)
    assert err.value.errors()[0]["loc"] == (next(iter(bad)),)


def test_scheduler_backend_needs_an_address_and_only_it_takes_one():
    with pytest.raises(ValidationError, match="needs address"):
        ExecutionConfig(backend="scheduler")
    with pytest.raises(ValidationError, match="address is used by backend 'scheduler' only"):
        ExecutionConfig(backend="local", address="tcp://1.2.3.4:8786")
    assert ExecutionConfig(backend="scheduler", address="tcp://1.2.3.4:8786").address


def test_config_is_frozen():
    with pytest.raises(ValidationError):
        ExecutionConfig().timeout = 1.0


def test_walltime_parsing():
    assert walltime_seconds("01:30:00") == 5400
    assert walltime_seconds("2-00:00:00") == 172800
    assert walltime_seconds("10:00") == 36000  # HH:MM
    with pytest.raises(ValueError, match="walltime"):
        walltime_seconds("90 minutes")


def test_default_lifetimes_leave_the_job_before_its_wall_time():
    lifetime, stagger = ClusterOptions(walltime="01:00:00").lifetimes_s()
    assert (lifetime, stagger) == (3000, 300)  # 50 min ± 5 min: out between 45 and 55 min
    lifetime, stagger = ClusterOptions(walltime="00:10:00").lifetimes_s()
    assert (lifetime, stagger) == (480, 60)
    with pytest.raises(ValidationError, match="shorter than walltime"):
        ClusterOptions(walltime="01:00:00", lifetime="58m", lifetime_stagger="5m")
    with pytest.raises(ValidationError, match="duration"):
        ClusterOptions(lifetime="soon")
    with pytest.raises(ValidationError, match="multiple of processes"):
        ClusterOptions(cores=4, processes=3)


# ---- inline -----------------------------------------------------------------------------------------


def test_inline_runs_in_order_with_a_deadline_and_reports_errors():
    tasks = [*tasks_sleeping(0.0, 0.0), Task("bad", {"n": 7}, 0)]
    calls = iter([sleep_then_echo, sleep_then_echo, raise_value_error])
    with make_runner({"backend": "inline", "timeout": 60}) as runner:
        assert isinstance(runner, InlineRunner) and runner.workers == 1
        before = time.time()
        results = list(runner.run(lambda payload: next(calls)(payload), tasks))
        after = time.time()
    assert [r.key for r in results] == ["k0", "k1", "bad"]
    assert [r.status for r in results] == ["done", "done", "error"]
    assert results[0].generation == 3 and results[0].worker == ""
    assert results[0].record["s"] == 0.0
    assert before + 60 <= results[0].record["deadline_s"] <= after + 60
    assert "ValueError: bad payload 7" in results[2].reason and "raise_value_error" in results[2].reason
    assert results[2].record is None


def test_inline_does_not_change_the_callers_payload():
    task = tasks_sleeping(0.0)[0]
    list(make_runner({"backend": "inline"}).run(sleep_then_echo, [task]))
    assert task.payload == {"s": 0.0}


# ---- the dask loop on an in-process cluster ---------------------------------------------------------


class Clock:
    """The runner's clock, s: ``time.monotonic()`` plus ``offset``, which grows by ``step`` at every reading."""

    def __init__(self):
        self.offset, self.step = 0.0, 0.0
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            self.offset += self.step
            return time.monotonic() + self.offset


class ThreadRunner(DaskRunner):
    """The dask runner on two worker threads of this process: the result loop without process start-up."""

    def _make_cluster(self):
        from distributed import LocalCluster

        return LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                            silence_logs="critical")


@pytest.fixture(scope="module")
def thread_runner():
    with ThreadRunner(ExecutionConfig(backend="local", timeout=60.0, timeout_grace=3600), Clock()) as runner:
        yield runner
    for event in EVENTS.values():
        event.set()     # release any evaluation still waiting


def test_results_come_as_completed_not_in_submission_order(thread_runner):
    EVENTS["slow"] = threading.Event()
    tasks = [Task("k0", {"wait": "slow"}, 3), Task("k1", {}, 3), Task("k2", {}, 3)]
    results = []
    for result in thread_runner.run(wait_then_echo, tasks):
        results.append(result)
        if {r.key for r in results} == {"k1", "k2"}:
            EVENTS["slow"].set()     # k0 may finish only now
    assert [r.key for r in results] == ["k1", "k2", "k0"]
    assert all(r.status == "done" and r.worker.startswith("inproc://") for r in results)
    assert all(r.seconds >= 0 and r.attempts == 1 for r in results)
    assert thread_runner.workers == 2


def test_a_raise_is_an_error_and_the_batch_goes_on(thread_runner):
    tasks = [Task("bad", {"n": 1}, 0), Task("good", {"n": 2}, 0)]
    results = {r.key: r for r in thread_runner.run(raise_value_error, tasks[:1])}
    results |= {r.key: r for r in thread_runner.run(wait_then_echo, [Task("good", {}, 0)])}
    assert results["bad"].status == "error" and "ValueError: bad payload 1" in results["bad"].reason
    assert results["good"].status == "done"


def test_a_task_past_its_timeout_is_yielded_as_timeout_and_the_others_finish(thread_runner):
    """The 60 s timeout is reached on the runner's clock, which jumps 30 s at each reading once the other two
    tasks are done: k0, still waiting on its event, is yielded as a timeout while it runs."""
    EVENTS["stuck"] = threading.Event()
    tasks = [Task("k0", {"wait": "stuck"}, 0), Task("k1", {}, 0), Task("k2", {}, 0)]
    results = {}
    try:
        for result in thread_runner.run(wait_then_echo, tasks):
            results[result.key] = result
            if set(results) == {"k1", "k2"}:
                thread_runner.clock.step = 30.0
            if result.key == "k0":
                assert "stuck" not in FINISHED     # yielded at its timeout, not when it ended
    finally:
        thread_runner.clock.step = 0.0
        EVENTS["stuck"].set()
    assert results["k0"].status == "timeout" and results["k0"].record is None
    assert "timeout of 60 s" in results["k0"].reason and results["k0"].worker
    assert results["k0"].seconds > 60       # measured on the runner's clock from its start on the worker
    assert results["k1"].status == results["k2"].status == "done"


# ---- signals while a cluster starts ------------------------------------------------------------------

def _sigint_blocked(pid: int) -> bool:
    """Whether process ``pid`` has SIGINT blocked (Linux: the SigBlk mask of /proc/PID/status)."""
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("SigBlk:"):
            return bool(int(line.split()[1], 16) >> (signal.SIGINT - 1) & 1)
    raise AssertionError(f"no SigBlk line for {pid}")


@pytest.fixture
def interrupting_signals():
    """SIGINT and SIGTERM raise KeyboardInterrupt, as under the driver (SIGINT may have been ignored by
    whoever started the suite in the background); the previous handlers restored afterwards."""
    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = {signum: signal.signal(signum, handler) for signum in (signal.SIGINT, signal.SIGTERM)}
    yield
    for signum, handler in previous.items():
        signal.signal(signum, handler)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_while_the_cluster_starts_is_acted_on_once_it_has(interrupting_signals, signum):
    stages = []
    with pytest.raises(KeyboardInterrupt):
        with _signals_held():
            os.kill(os.getpid(), signum)
            time.sleep(0.05)            # a handler would have run by now
            stages.append("the start went on")
        stages.append("not reached")
    assert stages == ["the start went on"]
    assert not signal.sigpending() and signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads signal masks from /proc")
def test_processes_started_with_the_cluster_have_sigint_blocked_and_the_driver_not_after():
    """The workers are started from threads of dask's, by multiprocessing's spawn: they inherit SIGINT
    blocked (Ctrl-C reaches the whole process group; only the driver answers it)."""
    children = []

    def start_one():
        child = multiprocessing.get_context("spawn").Process(target=time.sleep, args=(30,))
        child.start()
        children.append(child)

    with _signals_held():
        for _ in range(2):              # the first start may start the resource tracker as well
            thread = threading.Thread(target=start_one)
            thread.start()
            thread.join()
    try:
        assert [_sigint_blocked(c.pid) for c in children] == [True, True]
        assert not _sigint_blocked(os.getpid())
    finally:
        for child in children:
            child.kill()
            child.join()
