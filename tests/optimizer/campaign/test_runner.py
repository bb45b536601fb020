"""Campaign runner: configuration, the inline backend, and the dask result loop on an in-process cluster.

The in-process cluster (worker threads, no processes) exercises the same loop as the ``local`` backend —
as-completed order, timeouts, errors — in well under a second; the process-level behaviours (a worker
killed, a stuck worker restarted, BLAS pinned) are in ``test_runner_local.py`` (slow).
"""

from __future__ import annotations

import time

import pytest
from pydantic import ValidationError

from optimizer.campaign.runner import (
    RUNNERS,
    ClusterOptions,
    DaskRunner,
    ExecutionConfig,
    InlineRunner,
    Task,
    make_runner,
    walltime_seconds,
)


def sleep_then_echo(payload: dict) -> dict:
    """Sleep ``payload['s']`` seconds, return the payload (``deadline_s`` included)."""
    time.sleep(payload["s"])
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
    assert e["loc"] == ("backend",)
    for name in ("'kubernetes'", "inline", "local", "scheduler", "slurm", "pbs"):
        assert name in e["msg"]


def test_unknown_key_names_it_and_the_allowed_keys():
    with pytest.raises(ValidationError) as err:
        ExecutionConfig.model_validate({"backend": "local", "worker": 2})
    msg = str(err.value)
    assert "'worker'" in msg and "workers" in msg and "timeout" in msg and "retries" in msg


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
        t0 = time.time()
        results = list(runner.run(lambda payload: next(calls)(payload), tasks))
    assert [r.key for r in results] == ["k0", "k1", "bad"]
    assert [r.status for r in results] == ["done", "done", "error"]
    assert results[0].generation == 3 and results[0].worker == ""
    assert results[0].record["s"] == 0.0
    assert t0 + 59 < results[0].record["deadline_s"] < time.time() + 61
    assert "ValueError: bad payload 7" in results[2].reason and "raise_value_error" in results[2].reason
    assert results[2].record is None


def test_inline_does_not_change_the_callers_payload():
    task = tasks_sleeping(0.0)[0]
    list(make_runner({"backend": "inline"}).run(sleep_then_echo, [task]))
    assert task.payload == {"s": 0.0}


# ---- the dask loop on an in-process cluster ---------------------------------------------------------


class ThreadRunner(DaskRunner):
    """The dask runner on two worker threads of this process: the result loop without process start-up."""

    def _make_cluster(self):
        from distributed import LocalCluster

        return LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                            silence_logs="critical")


@pytest.fixture(scope="module")
def thread_runner():
    with ThreadRunner(ExecutionConfig(backend="local", timeout=1.0, timeout_grace=3600)) as runner:
        yield runner


def test_results_come_as_completed_not_in_submission_order(thread_runner):
    results = list(thread_runner.run(sleep_then_echo, tasks_sleeping(0.6, 0.05, 0.05)))
    assert [r.key for r in results] == ["k1", "k2", "k0"]
    assert all(r.status == "done" and r.worker.startswith("inproc://") for r in results)
    assert results[2].seconds == pytest.approx(0.6, abs=0.3)
    assert thread_runner.workers == 2


def test_a_raise_is_an_error_and_the_batch_goes_on(thread_runner):
    tasks = [Task("bad", {"n": 1}, 0), Task("good", {"n": 2}, 0)]
    results = {r.key: r for r in thread_runner.run(raise_value_error, tasks[:1])}
    results |= {r.key: r for r in thread_runner.run(sleep_then_echo, [Task("good", {"s": 0.0}, 0)])}
    assert results["bad"].status == "error" and "ValueError: bad payload 1" in results["bad"].reason
    assert results["good"].status == "done"


def test_a_task_past_its_timeout_is_yielded_as_timeout_and_the_others_finish(thread_runner):
    t0 = time.monotonic()
    results = {r.key: r for r in thread_runner.run(sleep_then_echo, tasks_sleeping(2.5, 0.1, 0.1))}
    assert results["k0"].status == "timeout" and results["k0"].record is None
    assert "timeout of 1 s" in results["k0"].reason and results["k0"].worker
    assert 1.0 <= results["k0"].seconds < 1.8  # yielded at the timeout (+ a poll interval), not at the end
    assert results["k1"].status == results["k2"].status == "done"
    assert time.monotonic() - t0 < 2.3  # not waiting for the 2.5 s sleep
