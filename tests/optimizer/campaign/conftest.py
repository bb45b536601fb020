"""Fixtures of the campaign tests: a one-node SLURM cluster on 127.0.0.1 (``slurm``), or a skip saying why.

``slurm`` makes sure ``scripts/slurm/start-local-slurm.sh`` has the node up (running the script as root
if it is not: it installs the Debian packages if needed) and hands the test a :class:`LocalSlurm`, which
builds ``execution:`` sections for the ``slurm`` backend and lists or cancels the jobs of one test::

    def test_campaign_on_slurm(slurm, tmp_path):
        execution = slurm.execution(tmp_path, workers=1)      # a dict for ExecutionConfig / the YAML
        ...
        slurm.cancel(execution)                             # scancel this test's worker jobs
"""

from __future__ import annotations

import os
import shutil
import subprocess
import uuid
from dataclasses import dataclass
from pathlib import Path

import pytest

START_SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "slurm" / "start-local-slurm.sh"


@dataclass(frozen=True)
class LocalSlurm:
    """The running one-node SLURM: execution configs for it and control of a test's worker jobs."""

    def execution(self, log_directory: str | Path, workers: int = 1, **overrides) -> dict:
        """An ``execution:`` mapping for the ``slurm`` backend with a job name unique to this call.

        Workers are single-core 1 GiB jobs with a 10-minute wall time; the job output goes to
        ``log_directory``. ``overrides`` replace top-level keys (``timeout``, ``retries``, ``cluster``...).
        """
        Path(log_directory).mkdir(parents=True, exist_ok=True)
        cluster = {"walltime": "00:10:00", "cores": 1, "memory": "1GiB", "log_directory": str(log_directory),
                   "job_name": f"millfoil-test-{uuid.uuid4().hex[:8]}"}
        return {"backend": "slurm", "workers": workers, "timeout": 300, "retries": 2, "cluster": cluster,
                **overrides}

    @staticmethod
    def jobs(execution: dict) -> dict[str, str]:
        """Job id -> state (``PENDING``, ``RUNNING``...) of the jobs of ``execution`` that are in the queue."""
        out = subprocess.run(["squeue", "-h", "-n", execution["cluster"]["job_name"], "-o", "%i %T"],
                             capture_output=True, text=True, check=True).stdout
        return dict(line.split() for line in out.splitlines() if line.strip())

    @staticmethod
    def cancel(execution: dict) -> None:
        """``scancel`` every job of ``execution`` (the way a user, an admin or a preemption would)."""
        subprocess.run(["scancel", "-n", execution["cluster"]["job_name"]], check=True)


def _slurm_up() -> bool:
    if not shutil.which("sinfo"):
        return False
    out = subprocess.run(["sinfo", "-h", "-o", "%t"], capture_output=True, text=True)
    return out.returncode == 0 and any(s.strip() in ("idle", "mix", "alloc") for s in out.stdout.splitlines())


def _start_slurm() -> str | None:
    """Start the local SLURM; None on success, else why it could not."""
    if _slurm_up():
        return None
    if os.geteuid() != 0:
        return f"SLURM is not running and starting it needs root: run `sudo {START_SCRIPT}`"
    try:
        proc = subprocess.run(["bash", str(START_SCRIPT)], capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        return f"{START_SCRIPT.name} did not finish within 600 s"
    if proc.returncode != 0 or not _slurm_up():
        tail = " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-5:])
        return f"{START_SCRIPT.name} failed (exit {proc.returncode}): {tail}"
    return None


@pytest.fixture(scope="session")
def slurm() -> LocalSlurm:
    """A one-node SLURM on 127.0.0.1, started if needed; skips the test, with the reason, where it cannot."""
    reason = _start_slurm()
    if reason is not None:
        print(f"SLURM unavailable: {reason}")
        pytest.skip(f"SLURM unavailable: {reason}")
    return LocalSlurm()
