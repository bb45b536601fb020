"""Execution of a campaign's evaluations: in process, on a dask ``LocalCluster``, a scheduler or SLURM/PBS.

The campaign driver hands a batch of :class:`Task` (one per blade still to evaluate) and a picklable
module-level function ``fn(payload: dict) -> dict`` to a runner and receives one :class:`TaskResult` per
task **as each one completes**, never in submission order and never aborting the batch on one failure
(pymoo's own dask runner waits in order and re-raises the first exception)::

    runner = make_runner(execution_config)      # backend chosen from a registry keyed by name
    with runner:                                # starts / stops the cluster
        for result in runner.run(fn, tasks):    # TaskResult as completed
            store.save(result)

Statuses of a :class:`TaskResult`:

* ``done``: ``fn`` returned; :attr:`TaskResult.record` is what it returned (for a campaign an
  :class:`~optimizer.campaign.record.EvaluationRecord`: the evaluation's own status, e.g. a mesh failure or a
  diverged solve, lives inside the record).
* ``timeout``: the evaluation ran longer than ``execution.timeout`` seconds (counted from the moment it
  started on a worker, not from submission: queued tasks do not time out). Its future is cancelled.
* ``worker_lost``: the worker running it died (process killed, node lost, job cancelled) more than
  ``execution.retries`` times; each loss before that resubmits the task.
* ``error``: ``fn`` raised (a bug: the pipeline records bad blades instead of raising); the reason names
  the exception and where it was raised.

**Deadline.** A running Python function cannot be interrupted by cancelling its future, so the runner
adds one key to the payload it passes to ``fn``: ``payload["deadline_s"]``, the Unix time (s, as
``time.time()`` on the worker) at which the runner gives up on the evaluation. ``fn`` should drop this key
before hashing or validating the payload and should stop the solve between iterations once
``time.time() > deadline_s`` (the evaluation then ends as the runner's ``timeout``). If the worker is still
busy with the cancelled evaluation ``execution.timeout_grace`` seconds after the deadline, the runner
restarts that worker process (the tasks that were queued behind it are resubmitted without counting a
retry). The ``inline`` backend passes the deadline too but cannot enforce it.

Backends (:data:`RUNNERS`):

* ``inline``: ``fn`` called in this process, one task after the other (tests, debugging).
* ``local``: a ``distributed.LocalCluster`` with one single-threaded worker process per core (or
  ``execution.workers``), BLAS/OpenMP pinned to one thread, no dashboard.
* ``scheduler``: an existing dask scheduler at ``execution.address``.
* ``slurm``, ``pbs``: ``dask-jobqueue`` clusters of ``execution.workers`` jobs whose workers retire before
  the wall time (``--lifetime``, ``--lifetime-stagger``) and are replaced by new jobs.

Where the runner owns the scheduler (local, slurm, pbs) it sets ``allowed-failures`` to 0 and
``worker-saturation`` to 1.0, so a worker death surfaces at once as ``KilledWorker`` (the runner counts
retries itself) and a single-threaded worker holds only the task it is running. An external scheduler keeps
its own settings: its ``allowed-failures`` retries come on top of ``execution.retries``.

Its configuration, the campaign's ``execution:`` section (:class:`ExecutionConfig`, on the base of every
configuration section, :class:`optimizer.config.Section`), is defined here, after the registry of backends
whose names it takes; see ``docs/how-to/run-on-a-cluster.md``.
"""

from __future__ import annotations

import logging
import math
import os
import re
import signal
import threading
import time
import traceback
import uuid
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from optimizer.campaign.status import TaskStatus
from optimizer.config import Section

log = logging.getLogger(__name__)

#: Environment of every worker process: the evaluations are parallel across processes, so BLAS and
#: OpenMP inside each must not spawn threads that fight for the same cores.
PINNED_THREADS_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: Event topic on which a worker announces that it started a task (its timeout clock starts then).
START_TOPIC = "millfoil-task-start"
#: How long the result loop waits for a completion before checking timeouts and stuck workers, s.
POLL_S = 0.2
#: While no worker is connected, a line saying what the runner waits for every this many seconds.
WAIT_REPORT_S = 30.0


class ClusterRefused(RuntimeError):
    """The batch scheduler refused a worker job (bad queue, account, resources): its own message."""


class NoWorkers(RuntimeError):
    """No worker connected within ``execution.cluster.wait``."""


# --------------------------------------------------------------------------------------------------
# Tasks and results
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Task:
    """One evaluation to run: ``fn(payload)`` on some worker.

    key: content hash of everything that determines the result (the store's key). payload: JSON-able,
    passed to ``fn`` with ``deadline_s`` added (see the module docstring). generation: the campaign
    generation that asked for it.
    """

    key: str
    payload: dict
    generation: int


@dataclass(frozen=True)
class TaskResult:
    """The outcome of one :class:`Task`.

    record: what ``fn`` returned, or None if it did not return. status: a :class:`TaskStatus`. reason: why, for all
    but ``done`` (``""`` then). worker: address of the worker that ran the last attempt (``""`` inline or when
    unknown). seconds: wall time seen by the runner from the start of the last attempt on a worker (its submission
    if it never started) to its end, s. attempts: how many times it was submitted, not counting resubmissions after
    a worker restart that the runner itself caused (a task queued behind a timed-out one).
    """

    key: str
    generation: int
    record: Any
    status: TaskStatus
    reason: str
    worker: str
    seconds: float
    attempts: int = 1


#: Statuses of :class:`TaskResult`.
STATUSES = tuple(TaskStatus)


def _with_deadline(payload: Mapping, timeout: float) -> dict:
    """The payload ``fn`` receives: a copy with ``deadline_s`` (Unix time, s) ``timeout`` seconds from now."""
    return {**payload, "deadline_s": time.time() + timeout}


def _describe(exc: BaseException) -> str:
    """``Type: message (at file:line in function)`` of an exception, for :attr:`TaskResult.reason`."""
    text = f"{type(exc).__name__}: {exc}"
    frames = traceback.extract_tb(exc.__traceback__)
    if frames:
        last = frames[-1]
        text += f" (at {os.path.basename(last.filename)}:{last.lineno} in {last.name})"
    return text


# --------------------------------------------------------------------------------------------------
# Runners
# --------------------------------------------------------------------------------------------------


class Runner(ABC):
    """Runs batches of tasks; a context manager that starts and stops its workers."""

    def __init__(self, config: ExecutionConfig, clock: Callable[[], float] = time.monotonic):
        self.config = config
        #: Called with one line when the runner has something to say (waiting for workers); set by the driver.
        self.log: Callable[[str], None] = lambda _line: None
        #: Seconds of a monotonic clock: what durations and timeouts are measured with (tests inject one).
        self.clock = clock

    def __enter__(self) -> Runner:
        try:
            self.start()
        except BaseException:
            # what did start (a cluster, its client) is stopped; the start's failure or interrupt is what
            # the caller must see, not a second error from stopping a half-started runner
            try:
                self.close()
            except Exception:
                pass
            raise
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    @abstractmethod
    def start(self) -> None:
        """Start the workers (or connect to them)."""

    @abstractmethod
    def close(self) -> None:
        """Stop the workers this runner started."""

    @property
    @abstractmethod
    def workers(self) -> int:
        """Workers connected now (for progress displays)."""

    @abstractmethod
    def run(self, fn: Callable[[dict], dict], tasks: Iterable[Task]) -> Iterator[TaskResult]:
        """Run ``fn`` on every task; yield one :class:`TaskResult` per task as each completes."""


class InlineRunner(Runner):
    """``fn`` in this process, one task after the other; the timeout is passed as a deadline, not enforced."""

    def start(self) -> None:
        """Nothing to start: tasks run in this process."""

    def close(self) -> None:
        """Nothing to stop."""

    @property
    def workers(self) -> int:
        return 1

    def run(self, fn: Callable[[dict], dict], tasks: Iterable[Task]) -> Iterator[TaskResult]:
        for task in tasks:
            t0 = self.clock()
            try:
                record = fn(_with_deadline(task.payload, self.config.timeout))
            except Exception as exc:  # a raise from fn is a bug to report, not a reason to stop the batch
                yield TaskResult(task.key, task.generation, None, TaskStatus.ERROR, _describe(exc), "",
                                 self.clock() - t0)
                continue
            yield TaskResult(task.key, task.generation, record, TaskStatus.DONE, "", "", self.clock() - t0)


def _execute(fn_pickle: bytes, payload: dict, key: str, timeout: float) -> dict:
    """Worker side of one attempt: announce the start, call ``fn``, report its record or its exception.

    ``fn`` comes cloudpickled by the runner: dask pickles a task's arguments with plain pickle first, which
    ignores ``cloudpickle.register_pickle_by_value`` (functions of modules the workers cannot import).
    """
    import cloudpickle
    from distributed import get_worker

    fn = cloudpickle.loads(fn_pickle)
    worker = get_worker()
    worker.log_event(START_TOPIC, {"key": key, "worker": worker.address})
    try:
        record = fn(_with_deadline(payload, timeout))
    except Exception as exc:
        return {"worker": worker.address, "record": None, "error": _describe(exc)}
    return {"worker": worker.address, "record": record, "error": None}


def _is_executing(key: str, dask_worker=None) -> bool:
    """Whether ``dask_worker`` is still running task ``key`` (run on the worker through ``Client.run``)."""
    return any(ts.key == key for ts in dask_worker.state.executing)


async def _kill_worker_process(dask_worker=None) -> None:
    """SIGKILL the worker process (run on it through ``Client.run``): its nanny starts a fresh one.

    A stuck Python thread cannot be stopped from outside; ``Client.restart_workers`` asks the nanny for a
    graceful restart that can block the caller for minutes on a loaded machine, while a killed process is
    replaced at once, as after any worker crash. A coroutine: ``Client.run(..., wait=False)`` takes only
    those.
    """
    os.kill(os.getpid(), signal.SIGKILL)


@dataclass
class _Attempt:
    """One submission of a task: its dask key, how many losses came before, when it was submitted."""

    task: Task
    key: str
    losses: int
    submitted: float


class DaskRunner(Runner):
    """Runs tasks on a dask cluster: submit to free threads, gather as completed, time out, resubmit lost ones."""

    #: Scheduler settings where this runner creates the scheduler (see the module docstring).
    SCHEDULER_CONFIG: ClassVar[dict] = {"distributed.scheduler.allowed-failures": 0,
                                        "distributed.scheduler.worker-saturation": 1.0}

    def __init__(self, config: ExecutionConfig, clock: Callable[[], float] = time.monotonic):
        super().__init__(config, clock)
        self.cluster = None
        self.client = None
        self._no_workers_since: float | None = None   # monotonic time the runner found no worker connected
        self._reported_at = -math.inf
        self._started: dict[str, tuple[float, str]] = {}  # dask key -> (monotonic start, worker)
        self._stuck: dict[str, tuple[str, float]] = {}  # cancelled key -> (worker, when to check it)
        self._restarted: set[str] = set()  # workers this runner restarted (their losses are not retries)
        self._threads_n, self._threads_at = 0, -math.inf  # cached worker-thread count and when it was asked

    # ---- cluster lifecycle ------------------------------------------------------------------------

    @abstractmethod
    def _make_cluster(self):
        """The cluster to connect to, or None where :meth:`_address` is used."""

    def _address(self) -> str | None:
        return None

    def start(self) -> None:
        import dask
        from distributed import Client

        with dask.config.set(self.SCHEDULER_CONFIG), _signals_held():
            self.cluster = self._make_cluster()
        self.client = Client(self.cluster if self.cluster is not None else self._address())
        self.client.subscribe_topic(START_TOPIC, self._on_start)

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        self.client = self.cluster = None

    @property
    def workers(self) -> int:
        return len(self.client.nthreads()) if self.client is not None else 0

    def _on_start(self, event: tuple[float, dict]) -> None:
        """Start-event handler (client event loop): the attempt's timeout clock starts now."""
        msg = event[1]
        self._started[msg["key"]] = (self.clock(), msg["worker"])

    # ---- the batch --------------------------------------------------------------------------------

    def run(self, fn: Callable[[dict], dict], tasks: Iterable[Task]) -> Iterator[TaskResult]:
        import cloudpickle
        from distributed import as_completed

        if self.client is None:
            raise RuntimeError("runner not started: use it as a context manager ('with runner: ...')")
        fn_pickle = cloudpickle.dumps(fn)
        ac = as_completed(with_results=True, raise_errors=False)  # results fetched in the client's event loop
        waiting: deque[tuple[Task, int]] = deque((task, 0) for task in tasks)  # (task, losses so far)
        pending: dict = {}  # future -> _Attempt
        try:
            while waiting or pending:
                if not pending:
                    self._check_workers()
                self._submit_to_free_threads(fn_pickle, waiting, pending, ac)
                self._wait_for_completion(ac)
                for future, value in ac.next_batch(block=False):
                    attempt = pending.pop(future, None)
                    if attempt is not None:  # None: a future this runner cancelled on timeout
                        result = self._settle(future, value, attempt, waiting)
                        if result is not None:
                            yield result
                yield from self._expire(pending)
                self._restart_stuck_workers()
        finally:
            if pending:  # the consumer stopped early: do not leave the batch running
                self.client.cancel(list(pending))

    def _check_workers(self) -> None:
        """With nothing running: while no worker is connected, say what the runner waits for (every
        :data:`WAIT_REPORT_S`) and give up after ``execution.cluster.wait``; where the cluster's jobs were
        refused by the scheduler, raise :class:`ClusterRefused` with its message at once."""
        self._raise_refusal()
        if self._threads() > 0:
            self._no_workers_since = None
            return
        now = self.clock()
        if self._no_workers_since is None:
            self._no_workers_since, self._reported_at = now, now
        waited = now - self._no_workers_since
        limit = self._wait_limit()
        if limit is not None and waited > limit:
            raise NoWorkers(f"no worker connected within {_duration(limit)}: {self._waiting_for()}")
        if now - self._reported_at >= WAIT_REPORT_S:
            self._reported_at = now
            self.log(f"waiting for workers ({_duration(waited)} so far"
                     + (f", limit {_duration(limit)}" if limit is not None else "") + f"): {self._waiting_for()}")

    def _raise_refusal(self) -> None:
        """Raise :class:`ClusterRefused` if the scheduler refused a job (backends that submit jobs)."""

    def _wait_limit(self) -> float | None:
        """Seconds to wait for a first worker (None: no limit)."""
        return None

    def _waiting_for(self) -> str:
        return f"the scheduler at {self.client.scheduler.address}" if self.client is not None else "the scheduler"

    def _submit_to_free_threads(self, fn_pickle: bytes, waiting: deque, pending: dict, ac) -> None:
        """Submit waiting tasks while worker threads are free.

        Submitting only what can start at once (rather than the whole batch) keeps an evaluation from
        queueing on a worker behind a long one while another worker idles: dask's own queueing applies
        only to batches much larger than the cluster. Workers still busy with a timed-out evaluation do
        not count as free.
        """
        if not waiting:
            return
        free = self._threads() - len(self._stuck) - len(pending)
        for _ in range(min(free, len(waiting))):
            task, losses = waiting.popleft()
            key = f"millfoil-{task.key}-{losses}-{uuid.uuid4().hex[:8]}"
            future = self.client.submit(_execute, fn_pickle, task.payload, key, self.config.timeout, key=key,
                                        pure=False)
            pending[future] = _Attempt(task, key, losses, self.clock())
            ac.add(future)

    def _threads(self) -> int:
        """Worker threads connected, asked of the scheduler at most every :data:`POLL_S` seconds.

        A stale count (a worker lost in the last fraction of a second) costs at most one task queued on the
        scheduler; asking on every completion would cost a round trip per task.
        """
        now = self.clock()
        if now - self._threads_at > POLL_S:
            self._threads_n = sum(self.client.nthreads().values())
            self._threads_at = now
        return self._threads_n

    @staticmethod
    def _wait_for_completion(ac) -> None:
        """Block until a future completes or :data:`POLL_S` passes."""
        condition = getattr(ac, "thread_condition", None)
        if condition is None:
            time.sleep(POLL_S)
            return
        with condition:
            if not ac.has_ready():
                condition.wait(POLL_S)

    def _elapsed(self, attempt: _Attempt) -> tuple[float, str]:
        """(seconds since the attempt started on a worker, or since submission; that worker or "")."""
        start, worker = self._started.get(attempt.key, (attempt.submitted, ""))
        return self.clock() - start, worker

    def _settle(self, future, value, attempt: _Attempt, waiting: deque) -> TaskResult | None:
        """The result of a completed future, or None if the task was resubmitted after a worker loss.

        ``value``: what ``as_completed(with_results=True)`` fetched: ``_execute``'s dict if the future
        finished, the exception otherwise.
        """
        seconds, worker = self._elapsed(attempt)
        self._started.pop(attempt.key, None)
        task = attempt.task
        lost = self._loss(future)
        if lost is not None:
            reason, lost_worker, counts = lost
            losses = attempt.losses + counts
            if losses <= self.config.retries:
                log.warning("task %s lost with worker %s (%s); resubmitting", task.key, lost_worker, reason)
                waiting.appendleft((task, losses))
                return None
            return TaskResult(task.key, task.generation, None, TaskStatus.WORKER_LOST,
                              f"lost with its worker {losses} times; last: {reason}", lost_worker or worker,
                              seconds, attempt.losses + 1)
        if future.status == "error":
            return TaskResult(task.key, task.generation, None, TaskStatus.ERROR, _describe(future.exception()), worker,
                              seconds, attempt.losses + 1)
        status, reason = (TaskStatus.ERROR, value["error"]) if value["error"] else (TaskStatus.DONE, "")
        return TaskResult(task.key, task.generation, value["record"], status, reason, value["worker"], seconds,
                          attempt.losses + 1)

    def _loss(self, future) -> tuple[str, str, int] | None:
        """(reason, worker, 1 or 0 retries it costs) if the future ended by losing its worker, else None.

        A loss on a worker this runner restarted itself (to free it from a timed-out evaluation) costs no
        retry: the task only queued behind the stuck one.
        """
        from distributed import KilledWorker

        if future.status == "cancelled":
            return "future cancelled by the scheduler (worker or connection lost)", "", 1
        if future.status != "error":
            return None
        exc = future.exception()
        if not isinstance(exc, KilledWorker):
            return None
        worker = getattr(getattr(exc, "last_worker", None), "address", "") or ""
        return f"worker {worker} died while running it", worker, 0 if worker in self._restarted else 1

    def _expire(self, pending: dict) -> Iterator[TaskResult]:
        """Cancel and yield every attempt that has run on a worker for longer than the timeout."""
        for future, attempt in list(pending.items()):
            if attempt.key not in self._started:
                continue  # still queued: the clock starts when a worker starts it
            seconds, worker = self._elapsed(attempt)
            if seconds <= self.config.timeout:
                continue
            del pending[future]
            future.cancel()
            self._started.pop(attempt.key, None)
            self._stuck[attempt.key] = (worker, self.clock() + self.config.timeout_grace)
            task = attempt.task
            yield TaskResult(task.key, task.generation, None, TaskStatus.TIMEOUT,
                             f"ran longer than the timeout of {self.config.timeout:g} s", worker, seconds,
                             attempt.losses + 1)

    def _restart_stuck_workers(self) -> None:
        """Restart each worker still running a timed-out evaluation ``timeout_grace`` s after its cancel."""
        now = self.clock()
        for key, (worker, check_at) in list(self._stuck.items()):
            if now < check_at:
                continue
            del self._stuck[key]
            try:
                busy = self.client.run(_is_executing, key, workers=[worker], on_error="return").get(worker)
            except Exception:  # the worker left already: nothing to free
                continue
            if busy is True:
                log.warning("worker %s still runs timed-out task %s; restarting it", worker, key)
                self._restarted.add(worker)
                self.client.run(_kill_worker_process, workers=[worker], wait=False)


class LocalRunner(DaskRunner):
    """A ``LocalCluster``: one single-threaded worker process per core, BLAS/OpenMP pinned, no dashboard."""

    def _make_cluster(self):
        from distributed import LocalCluster

        n = self.config.workers or len(os.sched_getaffinity(0))
        # the in-process scheduler's INFO lines (a comm closed as a worker stops) are noise to a user
        logging.getLogger("distributed").setLevel(logging.WARNING)
        # dashboard_address=None would still serve the dashboard on port 8787: no dashboard, no fixed port
        # (the workers start with SIGINT blocked, see _signals_held, and their plugin ignores it)
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                            scheduler_kwargs={"dashboard": False}, silence_logs=logging.CRITICAL,
                            env=dict(PINNED_THREADS_ENV))

    def start(self) -> None:
        from distributed import WorkerPlugin

        class IgnoreSigint(WorkerPlugin):
            """The worker process ignores SIGINT: Ctrl-C reaches the whole process group, and only the
            driver answers it (a worker started with the cluster also has it blocked, see _signals_held)."""

            def setup(self, worker=None) -> None:
                import signal
                import threading

                if threading.current_thread() is threading.main_thread():
                    signal.signal(signal.SIGINT, signal.SIG_IGN)

        super().start()
        self.client.register_plugin(IgnoreSigint(), name="millfoil-ignore-sigint")


@contextmanager
def _signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held while the block runs and acted on when it ends, as if they arrived then.

    A cluster cut short in its start (Ctrl-C, a batch system's SIGTERM in the first seconds of a campaign)
    can be neither used nor closed, and dask's exit hook then fails on it: the start is let finish, then
    the runner stops the cluster. SIGINT is also blocked, so that the threads dask starts meanwhile, and
    the worker processes they start, inherit it blocked: Ctrl-C in a terminal reaches the whole process
    group, and only the driver answers it (it stores, marks the run interrupted and closes the cluster).
    A blocked signal stays pending, where one ignored (SIG_IGN) would be lost. Off the main thread,
    signals are left alone.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    # an ignored signal stays ignored; one whose handler was not set from Python (None) is left as it is
    previous = {signum: signal.signal(signum, lambda signum, frame: noted.append(signum))
                for signum in (signal.SIGINT, signal.SIGTERM) if signal.getsignal(signum) not in (signal.SIG_IGN, None)}
    # multiprocessing's resource tracker starts with the first spawned process and unblocks SIGINT in the
    # thread that starts it: started here, not from a dask thread whose later workers would answer Ctrl-C
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})   # a pending Ctrl-C is delivered here
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)


class SchedulerRunner(DaskRunner):
    """An existing scheduler at ``execution.address`` (its workers are started by whoever runs it)."""

    def _make_cluster(self):
        return None

    def _address(self) -> str | None:
        return self.config.address


class JobQueueRunner(DaskRunner):
    """A ``dask-jobqueue`` cluster of ``execution.workers`` jobs, replaced as they end (wall time, scancel)."""

    #: Name of the cluster class in ``dask_jobqueue``.
    CLUSTER_CLASS: ClassVar[str]

    def _make_cluster(self):
        import dask_jobqueue

        options = self.config.cluster
        lifetime, stagger = options.lifetimes_s()
        cluster_class = getattr(dask_jobqueue, self.CLUSTER_CLASS)
        cluster = cluster_class(
            queue=options.queue, account=options.account, walltime=options.walltime, cores=options.cores,
            processes=options.worker_processes, memory=options.memory,
            job_extra_directives=list(options.job_extra_directives),
            job_script_prologue=[f"export {k}={v}" for k, v in PINNED_THREADS_ENV.items()]
            + list(options.job_script_prologue),
            worker_extra_args=["--lifetime", f"{math.floor(lifetime)}s",
                               "--lifetime-stagger", f"{math.floor(stagger)}s"],
            local_directory=options.local_directory, log_directory=options.log_directory,
            interface=options.interface, python=options.python, job_name=options.job_name,
            silence_logs="critical",
            scheduler_options={"dashboard": False, "dashboard_address": ":0"},  # no dashboard, no fixed port
        )
        jobs = self.config.workers or 1
        # the scheduler's refusal of a job (sbatch/qsub exiting non-zero) is raised inside dask-jobqueue's
        # event loop, where it is only logged: collect it there, to stop the campaign with its message
        self._refusals = _Refusals()
        self._refusals.attach()
        # adapt, not scale: a job that ends (lifetime, wall time, scancel) is replaced by a new one
        cluster.adapt(minimum_jobs=jobs, maximum_jobs=jobs)
        return cluster

    def close(self) -> None:
        refusals, self._refusals = getattr(self, "_refusals", None), None
        try:
            super().close()
        except AssertionError:
            # dask's SpecCluster cannot close a job the scheduler refused (it never left "created"): there
            # is nothing of it to stop, and the refusal is what the user must see
            if not (refusals and refusals.messages):
                raise
            self.client = self.cluster = None
        finally:
            if refusals is not None:
                refusals.detach()

    def _raise_refusal(self) -> None:
        refusals = getattr(self, "_refusals", None)
        if refusals is not None and refusals.messages:
            command = self.CLUSTER_CLASS.removesuffix("Cluster").lower()
            raise ClusterRefused(f"the {command} scheduler refused the worker job: {refusals.messages[-1]}")

    def _wait_limit(self) -> float | None:
        wait = self.config.cluster.wait
        return None if wait is None else _timedelta_seconds(wait)

    def _waiting_for(self) -> str:
        jobs = list(self.cluster.workers.values()) if self.cluster is not None else []
        ids = [str(j.job_id) for j in jobs if getattr(j, "job_id", None)]
        wanted = self.config.workers or 1
        return (f"{wanted} worker job(s) named {self.config.cluster.job_name!r}; "
                + (f"job IDs {', '.join(ids)} in the queue" if ids else "none submitted yet"))


class _Refusals(logging.Handler):
    """Collects the messages of failed job submissions (dask-jobqueue's ``Command exited with non-zero exit
    code``) logged from the event loop, and keeps those log records off the terminal."""

    LOGGERS = ("tornado.application", "distributed.deploy.adaptive", "distributed.deploy.spec")

    def __init__(self):
        super().__init__(logging.ERROR)
        self.messages: list[str] = []
        self._propagate: dict[str, bool] = {}

    def emit(self, record: logging.LogRecord) -> None:
        exc = record.exc_info[1] if record.exc_info else None
        text = str(exc) if exc is not None else record.getMessage()
        if "non-zero exit code" in text:
            self.messages.append(_scheduler_message(text))

    def attach(self) -> None:
        for name in self.LOGGERS:
            logger = logging.getLogger(name)
            self._propagate[name] = logger.propagate
            logger.addHandler(self)
            logger.propagate = False

    def detach(self) -> None:
        for name, propagate in self._propagate.items():
            logger = logging.getLogger(name)
            logger.removeHandler(self)
            logger.propagate = propagate


def _scheduler_message(text: str) -> str:
    """The scheduler's own words from dask-jobqueue's error (its ``stderr:`` lines), on one line."""
    _, found, stderr = text.partition("stderr:")
    lines = [line.strip() for line in (stderr if found else text).splitlines() if line.strip()]
    return "; ".join(lines)[:500] or text.strip()[:500]


def _duration(seconds: float) -> str:
    """``95`` → ``1m35s``; ``7200`` → ``2h0m``."""
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


class SlurmRunner(JobQueueRunner):
    CLUSTER_CLASS = "SLURMCluster"

    def _waiting_for(self) -> str:
        """What the jobs wait for, as ``squeue`` says (``55 PENDING (Priority)``), after the job IDs."""
        import subprocess

        text = super()._waiting_for()
        ids = [str(j.job_id) for j in self.cluster.workers.values() if getattr(j, "job_id", None)]
        if not ids:
            return text
        try:
            out = subprocess.run(["squeue", "-h", "-j", ",".join(ids), "-o", "%i %T (%r)"], capture_output=True,
                                 text=True, timeout=10).stdout
        except (OSError, subprocess.SubprocessError):
            return text
        states = "; ".join(line.strip() for line in out.splitlines() if line.strip())
        return f"{text}: {states}" if states else text


class PbsRunner(JobQueueRunner):
    CLUSTER_CLASS = "PBSCluster"


#: Runners by ``execution.backend``.
RUNNERS: dict[str, type[Runner]] = {
    "inline": InlineRunner,
    "local": LocalRunner,
    "scheduler": SchedulerRunner,
    "slurm": SlurmRunner,
    "pbs": PbsRunner,
}


# --------------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------------


_WALLTIME = re.compile(r"^(?:(\d+)-)?(\d+):(\d{2})(?::(\d{2}))?$")


def walltime_seconds(walltime: str) -> float:
    """Seconds of a SLURM/PBS wall time ``[D-]HH:MM[:SS]`` (``"01:30:00"`` → 5400.0)."""
    m = _WALLTIME.match(walltime.strip())
    if not m:
        raise ValueError(f"walltime {walltime!r} is not [D-]HH:MM[:SS]")
    days, hours, minutes, seconds = (int(g) if g else 0 for g in m.groups())
    return float(((days * 24 + hours) * 60 + minutes) * 60 + seconds)


def _timedelta_seconds(value: str) -> float:
    """Seconds of a dask time string (``"55m"``, ``"1h"``, ``"90s"``)."""
    from dask.utils import parse_timedelta

    try:
        return float(parse_timedelta(value))
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{value!r} is not a duration such as '50m', '1h' or '90s'") from exc


class ClusterOptions(Section):
    """Options of a ``dask-jobqueue`` cluster (``execution.cluster``; used by backends ``slurm``, ``pbs``).

    One job (named ``job_name`` in ``squeue``) runs ``processes`` single-threaded workers on ``cores`` cores
    (``processes`` defaults to ``cores``). ``log_directory`` receives the jobs' output (default: the
    directory the campaign was started from); ``job_script_prologue`` lines run before the worker starts
    (``module load ...``, ``source venv/bin/activate``); ``job_extra_directives`` are added as
    ``#SBATCH``/``#PBS`` lines (``--constraint=...``, ``-l select=...``).

    Workers retire after ``lifetime`` ± ``lifetime_stagger`` (dask durations such as ``"50m"``), before the
    scheduler's wall time kills the job, and the runner starts a new job in their place; an evaluation cut
    by a retirement is resubmitted (it costs a retry: keep ``lifetime`` well above ``execution.timeout``).
    Defaults: with ``m = min(5 min, walltime / 10)``, ``lifetime = walltime - 2 m`` and
    ``lifetime_stagger = m``, so workers leave between ``walltime - 3 m`` and ``walltime - m``.
    """

    queue: str | None = Field(None, description="queue (SLURM partition) of the jobs; null: the scheduler's "
                              "default")
    account: str | None = Field(None, description="account the jobs are charged to; null: the user's default")
    walltime: str = Field("01:00:00", description="wall time of each job, [D-]HH:MM[:SS]")
    cores: int = Field(1, ge=1, description="cores per job")
    processes: int | None = Field(None, ge=1, description="single-threaded worker processes per job (cores must "
                                  "be a multiple of it); null: cores")
    memory: str = Field("4GiB", description="memory per job, e.g. 4GiB")
    job_extra_directives: tuple[str, ...] = Field((), description="extra #SBATCH/#PBS lines, e.g. "
                                                  "--constraint=...")
    job_script_prologue: tuple[str, ...] = Field((), description="shell lines run before the worker starts (module "
                                                 "load ..., source venv/bin/activate)")
    local_directory: str | None = Field(None, description="the workers' scratch directory on the nodes; null: "
                                        "dask's default")
    log_directory: str | None = Field(None, description="directory of the jobs' output; null: the directory the "
                                      "campaign was started from")
    interface: str | None = Field(None, description="network interface of the workers, e.g. ib0; null: dask's "
                                  "default")
    python: str | None = Field(None, description="Python interpreter of the workers; null: this one")
    lifetime: str | None = Field(None, description="a worker retires after this dask duration (50m, 1h); null: "
                                 "walltime - 2 min(5 min, walltime / 10)")
    lifetime_stagger: str | None = Field(None, description="spread of the workers' retirements (a dask "
                                         "duration); null: min(5 min, walltime / 10)")
    job_name: str = Field("millfoil-worker", description="name of the jobs (as squeue shows it)")
    wait: str | None = Field("24h", description="how long the campaign waits with no worker connected (jobs "
                             "pending in the queue) before it stops, a dask duration (30m, 24h); null: no "
                             "limit. A line says every 30 s what it waits for")

    @field_validator("walltime")
    @classmethod
    def _walltime_format(cls, value: str) -> str:
        walltime_seconds(value)
        return value

    @field_validator("lifetime", "lifetime_stagger", "wait")
    @classmethod
    def _duration_format(cls, value: str | None) -> str | None:
        if value is not None:
            _timedelta_seconds(value)
        return value

    @model_validator(mode="after")
    def _consistent(self) -> ClusterOptions:
        if self.cores % self.worker_processes:
            raise ValueError(f"cores ({self.cores}) must be a multiple of processes ({self.processes})")
        lifetime, stagger = self.lifetimes_s()
        if lifetime + stagger >= walltime_seconds(self.walltime):
            raise ValueError(f"lifetime + lifetime_stagger ({lifetime:g} s + {stagger:g} s) must be shorter than "
                             f"walltime {self.walltime!r}, or workers are killed by the wall time")
        return self

    @property
    def worker_processes(self) -> int:
        """Worker processes per job (single-threaded workers: ``cores`` unless set)."""
        return self.processes or self.cores

    def lifetimes_s(self) -> tuple[float, float]:
        """(lifetime, stagger) of a worker in seconds, the defaults derived from the wall time."""
        margin = min(300.0, walltime_seconds(self.walltime) / 10)
        stagger = _timedelta_seconds(self.lifetime_stagger) if self.lifetime_stagger else margin
        lifetime = (_timedelta_seconds(self.lifetime) if self.lifetime
                    else walltime_seconds(self.walltime) - 2 * margin)
        return lifetime, stagger


class ExecutionConfig(Section):
    """``execution:`` — where and how a campaign's evaluations run (:mod:`optimizer.campaign.runner`)."""

    backend: Literal[tuple(RUNNERS)] = Field("local", description="where evaluations run, "
                                             "optimizer.campaign.runner.RUNNERS: inline (this process, one after "
                                             "the other), local (one worker process per core), scheduler (an "
                                             "existing dask scheduler), slurm or pbs (dask-jobqueue jobs)")
    workers: int | None = Field(None, ge=1, description="worker processes (local; null: one per core) or jobs "
                                "(slurm, pbs; null: 1)")
    timeout: float = Field(1800.0, gt=0, description="seconds an evaluation may run on a worker, s",
                           json_schema_extra={"unit": "s"})
    retries: int = Field(2, ge=0, description="times an evaluation lost with its worker is resubmitted before it "
                         "is recorded worker_lost")
    timeout_grace: float = Field(60.0, ge=0, description="seconds a worker may keep running a timed-out "
                                 "evaluation before it is restarted, s", json_schema_extra={"unit": "s"})
    address: str | None = Field(None, description="the dask scheduler's address (backend scheduler only), e.g. "
                                "tcp://10.0.0.1:8786")
    cluster: ClusterOptions = Field(ClusterOptions(), description="the dask-jobqueue cluster (backends slurm, "
                                    "pbs)")

    @model_validator(mode="after")
    def _address_for_scheduler_only(self) -> ExecutionConfig:
        if self.backend == "scheduler" and not self.address:
            raise ValueError("backend 'scheduler' needs address (e.g. 'tcp://host:8786')")
        if self.backend != "scheduler" and self.address:
            raise ValueError(f"address is used by backend 'scheduler' only, not {self.backend!r}")
        return self


def make_runner(config: ExecutionConfig | Mapping | None = None) -> Runner:
    """The runner of ``config.backend`` (an :class:`ExecutionConfig` or its mapping; None: defaults)."""
    if not isinstance(config, ExecutionConfig):
        config = ExecutionConfig.model_validate(config or {})
    return RUNNERS[config.backend](config)
