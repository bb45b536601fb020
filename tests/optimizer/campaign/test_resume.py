"""Resume after the driver dies: a real ``millfoil run`` process killed with SIGKILL mid-generation, then
``millfoil resume`` (no finished evaluation lost or solved twice, and the final population equal
to an uninterrupted run with the same seed). The problem is ZDT1 through the same driver, store and CLI,
each evaluation sleeping a little so that the kill lands inside a generation."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import final_population, run_campaign
from optimizer.campaign.store import STORE_NAME, Store

pytestmark = pytest.mark.slow

CONFIG = """\
analytic: {problem: zdt1, variables: 5, delay: 0.04}
algorithm: {population: 10, generations: 6, seed: 11}
execution: {backend: inline}
"""


def millfoil(*args: str) -> list[str]:
    return [sys.executable, "-m", "optimizer.cli", *args]


def stored(path: Path) -> tuple[int, dict[str, str]]:
    """(finished generations, {key: finished timestamp}) read as another process would, or (0, {})."""
    if not path.exists():
        return 0, {}
    try:
        with Store(path, readonly=True) as store:
            return len(store.generations()), {r.key: r.finished for r in store.evaluations()}
    except Exception:             # the driver may be creating the tables right now
        return 0, {}


def wait_until_mid_generation(proc: subprocess.Popen, path: Path, generation: int, timeout: float = 120.0):
    """Poll the store until ``generation`` generations are finished and a few evaluations of the next one
    are stored (so the driver is inside a generation), then return."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, "the campaign ended before it could be killed"
        done, rows = stored(path)
        if done == generation:
            with Store(path, readonly=True) as store:
                if len(list(store.evaluations(generation))) >= 3:
                    return
        time.sleep(0.01)
    raise AssertionError("the campaign did not reach the generation in time")


#: The surrogate-assisted search: batches of 5, models rebuilt from the store on resume.
SURROGATE = CONFIG.replace("seed: 11}", "seed: 11, method: surrogate, offspring: 5,\n            "
                           "surrogate: {pool: 10, training: 40}}")


@pytest.mark.parametrize("config, batch", [(CONFIG, 10), (SURROGATE, 5)], ids=["nsga2", "surrogate"])
def test_sigkill_mid_generation_then_resume(tmp_path, config, batch):
    config_path = tmp_path / "zdt1.yaml"
    config_path.write_text(config)
    # the uninterrupted run, same seed
    run_campaign(load_campaign(config_path), tmp_path / "whole")

    run = tmp_path / "killed"
    proc = subprocess.Popen(millfoil("run", str(config_path), "--out", str(run), "--quiet"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        wait_until_mid_generation(proc, run / STORE_NAME, generation=3)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    generations, before = stored(run / STORE_NAME)
    assert generations == 3
    with Store(run / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "running"             # it never had the chance to say otherwise
        partial = len(list(store.evaluations(3)))
    assert 3 <= partial < batch                                # killed inside generation 4

    done = subprocess.run(millfoil("resume", str(run), "--quiet"), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "non-dominated designs" in done.stdout

    with Store(run / STORE_NAME, readonly=True) as resumed, \
            Store(tmp_path / "whole" / STORE_NAME, readonly=True) as whole:
        after = {r.key: r.finished for r in resumed.evaluations()}
        assert all(after[k] == t for k, t in before.items())   # nothing lost, nothing solved again
        assert set(after) == {r.key for r in whole.evaluations()}
        assert final_population(resumed) == final_population(whole)
        assert [g.members for g in resumed.generations()] == [g.members for g in whole.generations()]
        assert [g.offspring for g in resumed.generations()] == [g.offspring for g in whole.generations()]
        assert resumed.campaign().state == "finished"


def test_sigint_exits_130_and_marks_the_run_interrupted(tmp_path):
    config_path = tmp_path / "zdt1.yaml"
    config_path.write_text(CONFIG)
    run = tmp_path / "run"
    # SIGINT back to its default in the child: a shell running this suite in the background ignores it,
    # the child would inherit that, and Python then installs no Ctrl-C handler.
    proc = subprocess.Popen(millfoil("run", str(config_path), "--out", str(run)), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_until_mid_generation(proc, run / STORE_NAME, generation=1)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert f"millfoil resume {run}" in err
    with Store(run / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "interrupted"
    status = subprocess.run(millfoil("status", str(run)), capture_output=True, text=True, timeout=60)
    assert status.returncode == 0 and "interrupted" in status.stdout
