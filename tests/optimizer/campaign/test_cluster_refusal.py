"""A batch scheduler that refuses the worker jobs, or never starts them: a clear error with the scheduler's
own words, a line while the campaign legitimately waits, a stated limit — never a silent hang."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from optimizer.campaign.runner import (
    ClusterRefused,
    DaskRunner,
    ExecutionConfig,
    NoWorkers,
    SlurmRunner,
    _Refusals,
    _scheduler_message,
)

ROOT = Path(__file__).resolve().parents[3]
SBATCH_ERROR = ("Command exited with non-zero exit code.\nExit code: 1\nCommand:\nsbatch /tmp/x.sh\nstdout:\n\n"
                "stderr:\nsbatch: error: invalid partition specified: nope\n"
                "sbatch: error: Batch job submission failed: Invalid partition name specified\n")


def test_the_scheduler_message_is_its_stderr_on_one_line():
    assert _scheduler_message(SBATCH_ERROR) == ("sbatch: error: invalid partition specified: nope; sbatch: error: "
                                                "Batch job submission failed: Invalid partition name specified")


def test_a_refused_submission_logged_in_the_event_loop_is_collected_and_kept_off_the_terminal(capsys):
    refusals = _Refusals()
    refusals.attach()
    try:
        try:
            raise RuntimeError(SBATCH_ERROR)
        except RuntimeError:
            logging.getLogger("tornado.application").exception("Exception in callback")
    finally:
        refusals.detach()
    assert refusals.messages == [_scheduler_message(SBATCH_ERROR)]
    assert "Traceback" not in capsys.readouterr().err
    assert logging.getLogger("tornado.application").propagate


class _NoWorkerRunner(SlurmRunner):
    """A SLURM runner without a cluster: no worker ever connects; the test drives the clock."""

    def __init__(self, wait):
        self.now = 0.0
        super().__init__(ExecutionConfig.model_validate({"backend": "slurm", "cluster": {"wait": wait}}),
                         clock=lambda: self.now)
        self.lines: list[str] = []
        self.log = self.lines.append

    def _threads(self) -> int:
        return 0

    def _waiting_for(self) -> str:
        return "1 worker job(s); job IDs 55 in the queue"


def test_waiting_for_workers_says_so_every_half_minute_and_stops_at_the_limit():
    runner = _NoWorkerRunner("2m")
    for runner.now in range(0, 121, 5):
        runner._check_workers()
    assert runner.lines == [f"waiting for workers ({t} so far, limit 2m00s): 1 worker job(s); job IDs 55 in the queue"
                            for t in ("30s", "1m00s", "1m30s", "2m00s")]
    runner.now = 121
    with pytest.raises(NoWorkers, match=r"no worker connected within 2m00s: 1 worker job\(s\); job IDs 55"):
        runner._check_workers()


def test_without_a_limit_it_waits_and_keeps_saying_so():
    runner = _NoWorkerRunner(None)
    for runner.now in range(0, 86400 * 3, 600):
        runner._check_workers()
    assert len(runner.lines) == 86400 * 3 // 600 - 1


def test_a_refusal_stops_the_wait_at_once():
    runner = _NoWorkerRunner("24h")
    runner._refusals = _Refusals()
    runner._refusals.messages.append("sbatch: error: invalid partition specified: nope")
    with pytest.raises(ClusterRefused, match="the slurm scheduler refused the worker job: sbatch: error: invalid "
                                             "partition specified: nope"):
        runner._check_workers()


def test_the_wait_limit_is_a_duration():
    with pytest.raises(ValueError, match="is not a duration"):
        ExecutionConfig.model_validate({"backend": "slurm", "cluster": {"wait": "soon"}})
    assert issubclass(SlurmRunner, DaskRunner)


# ------------------------------------------------------------------------------------ real SLURM
def _run(tmp_path: Path, execution: dict, timeout: float) -> subprocess.CompletedProcess:
    config = {"analytic": {"problem": "zdt1", "variables": 4}, "algorithm": {"population": 4, "generations": 2},
              "execution": execution}
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(config))
    return subprocess.run([sys.executable, "-m", "optimizer.cli", "run", str(tmp_path / "c.yaml"), "--out",
                           str(tmp_path / "run")], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


@pytest.mark.slow
def test_a_job_the_scheduler_refuses_is_exit_2_with_its_message(slurm, tmp_path):
    execution = slurm.execution(tmp_path / "jobs")
    execution["cluster"]["queue"] = "nope"
    done = _run(tmp_path, execution, timeout=120)
    assert done.returncode == 2, done.stderr
    error = [line for line in done.stderr.splitlines() if line.startswith("millfoil: error:")]
    assert error == ["millfoil: error: the slurm scheduler refused the worker job: sbatch: error: invalid partition "
                     "specified: nope; sbatch: error: Batch job submission failed: Invalid partition name specified"]
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "run").exists()          # nothing was evaluated: nothing blocks a corrected run


@pytest.mark.slow
def test_jobs_that_never_start_are_reported_then_given_up_on(slurm, tmp_path):
    execution = slurm.execution(tmp_path / "jobs")
    execution["cluster"].update({"job_extra_directives": ["--begin=now+1hour"], "wait": "40s"})
    done = _run(tmp_path, execution, timeout=180)
    assert done.returncode == 4, done.stderr
    assert "millfoil: waiting for workers (30s so far, limit 40s): 1 worker job(s) named" in done.stderr
    assert "PENDING (BeginTime)" in done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("millfoil: error: the campaign failed: NoWorkers: no "
                                                           "worker connected within 40s")
    assert slurm.jobs(execution) == {}             # the pending job was cancelled on the way out
