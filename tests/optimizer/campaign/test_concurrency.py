"""One driver per run directory: a second `run` or `resume` is refused while a driver lives, never after it
died; a run refused before its first evaluation leaves nothing that blocks a corrected one."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import CampaignError, resume_campaign, run_campaign
from optimizer.campaign.lock import LOCK_NAME, DirectoryInUse, DriverLock
from optimizer.campaign.problem import EmptySpaceError
from optimizer.campaign.store import STORE_NAME, Store
from optimizer.cli import main

ZDT1 = "analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 2, seed: 3}\n" \
       "execution: {backend: inline}\n"

#: A process that takes the run directory's lock, says so, and holds it until killed.
HOLDER = """
import sys, time
from optimizer.campaign.lock import DriverLock
lock = DriverLock(sys.argv[1], "run").acquire()
print("held", flush=True)
time.sleep(600)
"""


def campaign(tmp_path: Path, text: str = ZDT1, *overrides: str):
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return load_campaign(path, overrides)


@pytest.fixture
def holder(tmp_path):
    """A live process holding ``tmp_path/run``'s lock; yields (directory, process)."""
    run = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(run)], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])})
    try:
        assert proc.stdout.readline().strip() == "held"
        yield run, proc
    finally:
        proc.kill()
        proc.wait()


def test_a_second_driver_is_refused_naming_the_holder(tmp_path, holder):
    run, proc = holder
    with pytest.raises(DirectoryInUse, match=rf"in use by another millfoil driver \(millfoil run, pid {proc.pid} "
                                             r"on .+ since \d{4}-.*millfoil resume"):
        run_campaign(campaign(tmp_path), run)
    assert not (run / STORE_NAME).exists()                   # refused before it wrote anything


def test_a_driver_refused_while_the_holder_writes_its_details_still_names_it(tmp_path):
    """The holder writes who it is just after it takes the lock; a driver refused in between waits for it."""
    import fcntl
    import threading
    run = tmp_path / "run"
    run.mkdir()
    handle = open(run / LOCK_NAME, "a+", encoding="utf-8")   # noqa: SIM115
    fcntl.lockf(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)       # a forked child would not see this lock: use a thread
    late = threading.Timer(0.4, lambda: (handle.write('{"host": "h", "pid": 7, "command": "run", '
                                                      '"since": "2026-01-01T00:00:00+00:00"}\n'), handle.flush()))
    try:
        late.start()
        script = ("import sys\nfrom optimizer.campaign.lock import DriverLock, DirectoryInUse\n"
                  "try:\n    DriverLock(sys.argv[1], 'resume').acquire()\nexcept DirectoryInUse as e:\n"
                  "    print(e)\n")
        out = subprocess.run([sys.executable, "-c", script, str(run)], capture_output=True, text=True, timeout=60,
                             env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])})
        assert "(millfoil run, pid 7 on h since 2026-01-01" in out.stdout, out
    finally:
        late.join()
        handle.close()


def test_resume_is_refused_while_the_driver_lives(tmp_path, holder):
    run, proc = holder
    (run / STORE_NAME).touch()
    with pytest.raises(DirectoryInUse, match=f"pid {proc.pid}"):
        resume_campaign(run)


def test_the_cli_refuses_a_second_driver_with_exit_2_and_one_line(tmp_path, holder, capsys):
    run, proc = holder
    (tmp_path / "c.yaml").write_text(ZDT1)
    assert main(["run", str(tmp_path / "c.yaml"), "--out", str(run), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millfoil: error: ") and f"pid {proc.pid}" in err[0]


def test_a_killed_driver_never_blocks(tmp_path, holder):
    run, proc = holder
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    outcome = run_campaign(campaign(tmp_path), run)
    assert outcome.state == "finished"
    assert (run / LOCK_NAME).exists()                       # the file stays; its lock died with the driver


def test_the_lock_is_released_when_the_driver_ends(tmp_path):
    run_campaign(campaign(tmp_path), tmp_path / "run")
    with DriverLock(tmp_path / "run", "resume"):
        pass


@pytest.mark.slow
def test_a_run_refused_before_any_evaluation_leaves_nothing_that_blocks(tmp_path):
    blade = ("blade: {mode: design, continuity: G1, bounds: {alpha: [-5, -4], beta1: [20, 30]}}\n"
             "mesh: {level: coarse}\nalgorithm: {population: 4, initial_draws: 10}\n")
    run = tmp_path / "run"
    with pytest.raises(EmptySpaceError):
        run_campaign(campaign(tmp_path, blade), run)
    assert not run.exists()                                  # the directory it created is gone again
    existing = tmp_path / "existing"
    existing.mkdir()
    (existing / "notes.txt").write_text("mine")
    with pytest.raises(EmptySpaceError):
        run_campaign(campaign(tmp_path, blade), existing)
    assert sorted(p.name for p in existing.iterdir()) == [LOCK_NAME, "notes.txt"]
    assert run_campaign(campaign(tmp_path), existing).state == "finished"


def test_a_store_that_never_evaluated_a_design_is_replaced(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    with Store(run / STORE_NAME) as store:
        store.start_campaign("algorithm: {}\n", 1, "0")
    lines = []
    assert run_campaign(campaign(tmp_path), run, log=lines.append).state == "finished"
    assert any("never evaluated a design" in line for line in lines)
    with pytest.raises(CampaignError, match="already holds a campaign"):
        run_campaign(campaign(tmp_path), run)


def _generations(store: Path) -> int:
    try:
        with Store(store, readonly=True) as s:
            return len(s.generations())
    except Exception:            # not there yet
        return 0


@pytest.mark.slow
def test_two_real_drivers_on_one_directory(tmp_path):
    """Started together into a fresh directory: one runs to the end, the other is refused with exit 2 and one
    line naming the holder; then a `resume` started while the winner runs is refused the same way."""
    config = tmp_path / "c.yaml"
    config.write_text(ZDT1.replace("variables: 4}", "variables: 4, delay: 0.2}").replace("generations: 2",
                                                                                         "generations: 8"))
    run = tmp_path / "run"
    command = [sys.executable, "-m", "optimizer.cli", "run", str(config), "--out", str(run), "--quiet"]
    procs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    t0 = time.monotonic()
    while not _generations(run / STORE_NAME):        # the winner is inside its campaign (about 10 s in all)
        assert time.monotonic() - t0 < 120
        time.sleep(0.1)
    resume = subprocess.run([sys.executable, "-m", "optimizer.cli", "resume", str(run), "--quiet"],
                            capture_output=True, text=True, timeout=120)
    results = [(p.wait(timeout=300), *p.communicate()) for p in procs]
    codes = sorted(code for code, _, _ in results)
    assert codes == [0, 2], results
    refused = next(err for code, _, err in results if code == 2).strip().splitlines()
    assert len(refused) == 1 and "in use by another millfoil driver (millfoil run, pid" in refused[0]
    assert resume.returncode == 2 and "in use by another millfoil driver" in resume.stderr
    assert len(resume.stderr.strip().splitlines()) == 1
    with Store(run / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "finished"
        assert len(store.generations()) == 8


# ------------------------------------------------------------------ status: is the driver still there?
def _says_running(tmp_path: Path, run: Path) -> None:
    """A finished campaign's store and configuration in ``run``, its state set back to "running", as a driver
    killed outright leaves it."""
    import sqlite3
    run_campaign(campaign(tmp_path), tmp_path / "done")
    for name in (STORE_NAME, "config.yaml"):
        (run / name).write_bytes((tmp_path / "done" / name).read_bytes())
    with sqlite3.connect(run / STORE_NAME) as db:
        db.execute("UPDATE campaign SET state = 'running', ended = NULL, message = NULL")


def _status_line(run: Path) -> str:
    from optimizer.campaign.progress import format_status, status_of
    return format_status(status_of(run)).splitlines()[0]


def test_status_names_the_live_driver_of_a_running_campaign(tmp_path, holder):
    run, proc = holder
    _says_running(tmp_path, run)
    line = _status_line(run)
    assert f"running (driver: millfoil run, pid {proc.pid} on " in line and "last evaluation stored" in line
    with pytest.raises(DirectoryInUse):                      # the probe left the holder's lock as it was
        DriverLock(run, "resume").acquire()


def test_status_tells_a_killed_driver_from_a_running_one(tmp_path, holder):
    run, proc = holder
    _says_running(tmp_path, run)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    line = _status_line(run)
    assert "stopped without recording it: no driver holds the directory" in line
    assert line.endswith(f"continue with `millfoil resume {run}`")
    from optimizer.campaign.progress import status_of, status_table
    assert status_table([status_of(run)]).splitlines()[1].split()[1:4] == ["stopped", "(no", "driver)"]
    assert resume_campaign(run).state == "finished"


def test_status_without_a_lock_file_falls_back_to_the_age_of_the_last_result(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    _says_running(tmp_path, run)                             # a copy made without a lock file
    line = _status_line(run)
    assert line.startswith(f"campaign {run}: running (last evaluation stored ") and line.endswith(" ago)")


def test_a_probe_in_the_driver_s_own_process_keeps_its_lock(tmp_path):
    from optimizer.campaign.lock import probe
    run = tmp_path / "run"
    with DriverLock(run, "run"):
        assert probe(run) == (True, f"this process, pid {os.getpid()}")
        refused = subprocess.run([sys.executable, "-c", "import sys\nfrom optimizer.campaign.lock import "
                                  "DriverLock\nDriverLock(sys.argv[1], 'resume').acquire()", str(run)],
                                 capture_output=True, text=True, timeout=60,
                                 env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])})
        assert "DirectoryInUse" in refused.stderr
    assert probe(run) == (False, "")


def test_a_driver_starting_during_a_probe_waits_for_it(tmp_path):
    """A probe holds a shared lock for an instant; a driver that meets it tries again instead of refusing."""
    import fcntl
    run = tmp_path / "run"
    DriverLock(run, "run").acquire().release()
    script = ("import sys, time\nfrom optimizer.campaign.lock import DriverLock\nprint('ready', flush=True)\n"
              "sys.stdin.readline()\nstart = time.monotonic()\nDriverLock(sys.argv[1], 'resume').acquire()\n"
              "print(time.monotonic() - start, flush=True)\n")
    driver = subprocess.Popen([sys.executable, "-c", script, str(run)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])})
    try:
        assert driver.stdout.readline().strip() == "ready"
        with open(run / LOCK_NAME, encoding="utf-8") as handle:
            fcntl.lockf(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)     # a probe in its instant, drawn out to 0.3 s
            driver.stdin.write("go\n")
            driver.stdin.flush()
            time.sleep(0.3)
        waited = driver.stdout.readline().strip()
        assert waited, driver.stderr.read()
        assert 0.15 < float(waited) < 5.0                          # it met the shared lock and waited for it
    finally:
        driver.kill()
        driver.wait()
