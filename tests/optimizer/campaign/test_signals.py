"""Signals to real `millfoil` processes: Ctrl-C (SIGINT to the terminal's whole process group, workers
included) and SIGTERM (a batch system's wall time), early and mid-campaign, end with exit status 130 and
one line, never a traceback from the driver or any worker."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from optimizer.campaign.store import STORE_NAME, Store

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[3]
CONFIG = """\
analytic: {problem: zdt1, variables: 4, delay: 0.3}
algorithm: {population: 8, generations: 30, seed: 3}
execution: {backend: local, workers: 2}
"""


def start(tmp_path: Path, *args: str) -> subprocess.Popen:
    """``millfoil ARGS`` in a process group of its own (as a terminal's foreground job), SIGINT at its
    default (a shell running the suite in the background would have it ignored)."""
    return subprocess.Popen([sys.executable, "-m", "optimizer.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, cwd=tmp_path,
                            env={**os.environ, "PYTHONPATH": str(ROOT)},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def generations(store: Path) -> int:
    try:
        with Store(store, readonly=True) as s:
            return len(s.generations())
    except Exception:
        return 0


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_to_the_process_group_mid_campaign(tmp_path, signum):
    (tmp_path / "c.yaml").write_text(CONFIG)
    proc = start(tmp_path, "run", "c.yaml", "--out", "run", "--quiet")
    try:
        t0 = time.monotonic()
        while generations(tmp_path / "run" / STORE_NAME) < 2:
            assert proc.poll() is None and time.monotonic() - t0 < 120
            time.sleep(0.1)
        os.killpg(proc.pid, signum)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Error" not in err, err
    assert err.strip().splitlines()[-1] == "millfoil: interrupted; what finished is stored. Continue with: " \
                                           "millfoil resume run"
    with Store(tmp_path / "run" / STORE_NAME, readonly=True) as s:
        assert s.campaign().state == "interrupted"


@pytest.mark.parametrize("delay", [0.1, 0.4, 0.8, 1.5])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_while_the_command_starts(tmp_path, signum, delay):
    (tmp_path / "c.yaml").write_text(CONFIG)
    proc = start(tmp_path, "run", "c.yaml", "--out", "run", "--quiet")
    time.sleep(delay)
    os.killpg(proc.pid, signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err, err
    assert err.strip().splitlines()[-1].startswith("millfoil: interrupted")
