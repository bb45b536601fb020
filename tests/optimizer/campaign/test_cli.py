"""``millfoil run | resume | status | check`` in process, on ZDT1 (no CFD), and the progress display."""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from optimizer.campaign.driver import GenerationProgress
from optimizer.campaign.progress import ProgressDisplay, format_status, progress_line, remaining, status_of
from optimizer.cli import main

ROOT = Path(__file__).resolve().parents[3]

ZDT1 = "analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 8, generations: 3, seed: 1}\n" \
       "execution: {backend: inline}\noutput: {sync: normal}\n"


@pytest.fixture
def zdt1(tmp_path):
    path = tmp_path / "zdt1.yaml"
    path.write_text(ZDT1)
    return path


def test_check_without_a_file_prints_the_embedded_quickstart(capsys):
    assert main(["check"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("campaign the embedded quickstart campaign (optimizer/campaign/quickstart.yaml): valid")
    assert "design variables (11)" in out and "alpha" in out and "max |fy|, min c_max" in out
    assert "# resolved campaign" in out and "half_height: 1.0" in out
    assert "population: 4" in out and "directory: runs/quickstart" in out


def test_check_with_a_file_names_it(capsys):
    assert main(["check", "optimizer/campaign/quickstart.yaml", "--set", "algorithm.population=6"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("campaign optimizer/campaign/quickstart.yaml: valid") and "population: 6" in out


def test_run_without_a_file_announces_the_quickstart(tmp_path, monkeypatch, capsys):
    """No CONFIG: the header says the embedded quickstart runs (the driver is replaced here: nothing runs)."""
    import optimizer.campaign.driver as driver

    seen = {}

    def fake_run(config, directory, **_):
        seen.update(config=config, directory=directory)
        raise driver.CampaignError("stopped by the test")

    monkeypatch.setattr(driver, "run_campaign", fake_run)
    monkeypatch.chdir(tmp_path)
    assert main(["run"]) == 2
    out = capsys.readouterr().out
    assert "running the embedded quickstart campaign (optimizer/campaign/quickstart.yaml)" in out
    assert str(seen["directory"]) == "runs/quickstart" and seen["config"].algorithm.population == 4


def test_check_bad_config_exits_2_with_file_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("algorithm:\n  population: 8\n  generatons: 3\n")
    assert main(["check", str(bad)]) == 2
    assert f"{bad}:3: unknown key 'algorithm.generatons'" in capsys.readouterr().err


def test_run_status_resume(tmp_path, zdt1, capsys):
    run = tmp_path / "run"
    assert main(["run", str(zdt1), "--out", str(run)]) == 0
    captured = capsys.readouterr()
    assert f"results in {run}/" in captured.out and "non-dominated designs" in captured.out
    assert captured.err.count("generation ") == 3         # one line per generation off a terminal
    with open(run / "front.csv") as fh:
        header = next(csv.reader(fh))
    assert header[:5] == ["f1", "f2", "class", "generation", "key"] and "x1" in header
    assert (run / "config.yaml").exists()

    assert main(["status", str(run), "--json"]) == 0
    status = json.loads(capsys.readouterr().out)
    assert status["state"] == "finished" and status["generations"] == {"done": 3, "total": 3}
    assert status["by_status"] == {"ok": status["evaluations"]}
    assert status["units"] == {"f1": "", "f2": ""}
    assert main(["status", str(run)]) == 0
    text = capsys.readouterr().out
    assert "finished" in text and "  best: f1 " in text and ", f2 " in text

    assert main(["run", str(zdt1), "--out", str(run)]) == 2            # never overwritten
    assert "millfoil resume" in capsys.readouterr().err
    assert main(["resume", str(run)]) == 0                              # finished: nothing to do
    assert "non-dominated designs" in capsys.readouterr().out


def test_remaining_evaluations_at_the_recent_pace_without_the_stops():
    """40 evaluations stored 10 s apart, then a night's stop before the resume: 60 of 100 left, at 10 s."""
    from types import SimpleNamespace

    times = [f"2026-01-01T10:{10 * i // 60:02d}:{10 * i % 60:02d}+00:00" for i in range(20)]
    times += [f"2026-01-02T08:{10 * i // 60:02d}:{10 * i % 60:02d}+00:00" for i in range(20)]
    rows = [SimpleNamespace(finished=t) for t in times]
    left = remaining(100, rows, [SimpleNamespace(cache_hits=0)])
    assert left["evaluations"] == 60 and left["seconds"] == pytest.approx(600.0)
    assert remaining(100, rows[:5], [])["seconds"] is None          # too few to tell a pace


def test_status_says_what_is_left_until_the_campaign_finishes(tmp_path, zdt1):
    run = tmp_path / "run"
    assert main(["run", str(zdt1), "--out", str(run)]) == 0
    status = status_of(run)
    assert status["remaining"] is None and "remaining" not in format_status(status)
    status = {**status, "state": "interrupted", "remaining": {"evaluations": 60, "seconds": 600.0}}
    assert "remaining: about 60 evaluations, 10m00s at the recent pace" in format_status(status)


def test_status_of_a_study_prints_a_line_per_run_and_names_the_unreadable_ones(tmp_path, zdt1, capsys):
    study = tmp_path / "study"
    for name in ("a", "b"):
        assert main(["run", str(zdt1), "--out", str(study / name), "--set", "algorithm.generations=2"]) == 0
    (study / "c").mkdir()
    (study / "c" / "campaign.sqlite").write_text("not a database")
    capsys.readouterr()

    assert main(["status", str(study / "a"), str(study / "b")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["run", "state", "generations", "evaluations", "ok", "best", "remaining"]
    assert [line.split()[:5] for line in lines[1:]] == [[str(study / n), "finished", "2/2", "16", "16"]
                                                         for n in ("a", "b")]
    assert "f1 " in lines[1] and ", f2 " in lines[1] and lines[1].endswith("-")

    assert main(["status", str(study)]) == 2                  # a directory of runs: each below it, two levels at most
    out, err = capsys.readouterr()
    assert [line.split()[0] for line in out.splitlines()[1:]] == [str(study / n) for n in "ab"] + [f"{study / 'c'}:"]
    assert "unreadable:" in out.splitlines()[-1] and "is damaged" in out.splitlines()[-1]
    assert err.strip() == (f"millfoil: error: 1 of 3 runs could not be read: {study / 'c'} "
                           "(`millfoil status RUN` on one says what it holds)")

    assert main(["status", str(study / "a"), str(study / "b"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [r["directory"] for r in summary["runs"]] == [str(study / "a"), str(study / "b")]
    assert summary["unreadable"] == []

    (tmp_path / "empty").mkdir()
    assert main(["status", str(tmp_path / "empty")]) == 2
    assert "no campaign store (campaign.sqlite) here or in its subdirectories" in capsys.readouterr().err


def test_resume_errors(tmp_path, capsys):
    assert main(["resume", str(tmp_path / "nothing")]) == 2
    assert "no campaign store" in capsys.readouterr().err
    assert main(["resume", str(tmp_path), "--set", "solver.max_iter=5"]) == 2
    assert "only execution.KEY=VALUE" in capsys.readouterr().err
    assert main(["status", str(tmp_path / "nothing")]) == 2


def test_progress_display_live_on_a_terminal_and_lines_elsewhere():
    running = GenerationProgress(1, 5, total=10, submitted=8, done=3, failed=1, infeasible=2, workers=2,
                                 best={"|fy|": 9924.3, "c_max": 21.0}, units={"|fy|": "N/m", "c_max": "m/s"},
                                 hypervolume=1.5, eta_s=3725)
    assert "generation 2/5" in progress_line(running) and "2 running" in progress_line(running)
    assert "ETA 1h02m" in progress_line(running) and "best |fy| 9924 N/m, c_max 21 m/s |" in progress_line(running)
    finished = GenerationProgress(1, 5, total=10, done=7, failed=1, infeasible=2, finished=True)

    log = io.StringIO()
    ProgressDisplay(log, live=False)(running)
    ProgressDisplay(log, live=False)(finished)
    assert log.getvalue().count("\n") == 1 and "running" not in log.getvalue()

    tty = io.StringIO()
    display = ProgressDisplay(tty, live=True)
    display(running)
    display(running)
    display(finished)
    text = tty.getvalue()
    assert text.count("\r\033[K") == 2 and text.endswith("\n")      # the live line is redrawn in place


def test_run_refuses_an_unusable_run_directory_before_starting(tmp_path, zdt1, capsys):
    (tmp_path / "file").write_text("")
    assert main(["run", str(zdt1), "--out", str(tmp_path / "file")]) == 2
    assert "--out" in capsys.readouterr().err
    assert main(["run", str(zdt1), "--set", "output.directory=/proc/x"]) == 2
    assert "output.directory /proc/x" in capsys.readouterr().err


def test_run_creates_a_missing_chain_of_directories(tmp_path, zdt1):
    run = tmp_path / "a" / "b" / "run"
    assert main(["run", str(zdt1), "--out", str(run), "--quiet"]) == 0
    assert (run / "campaign.sqlite").is_file()


@pytest.mark.slow
def test_an_interrupt_inside_a_string_evaluation_still_exits_130_under_python_m(tmp_path):
    """CPython ends a ``-m`` run by SIGINT, whatever its exit status, once a KeyboardInterrupt ended a
    string exec (a dataclass being built as Ctrl-C arrives), even one caught: main keeps 130."""
    probe = tmp_path / "probe"
    probe.mkdir()
    (probe / "__main__.py").write_text(
        "import sys\n"
        "import optimizer.cli as cli\n"
        "def interrupted(parser, argv):\n"
        "    exec('raise KeyboardInterrupt', {})\n"
        "cli._main = interrupted\n"
        "sys.exit(cli.main(['status']))\n")
    done = subprocess.run([sys.executable, "-m", "probe"], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "millfoil: interrupted"
