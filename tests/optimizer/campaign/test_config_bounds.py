"""What ``run`` needs is refused when the campaign is loaded: ``check`` and ``run`` exit 2 with one line
``millfoil: error: ...`` naming the key (file:line or ``--set``) and what is allowed, and nothing is written —
no run directory, no store (docs/reference/errors.md, "Campaign values"). ``resume --set execution.*`` is
validated the same way, before the driver takes the run directory."""

from __future__ import annotations

import pytest

from optimizer.campaign.config import MAX_EVALUATIONS, MAX_SEED, load_campaign
from optimizer.campaign.store import STORE_NAME
from optimizer.cli import main

ZDT1 = ("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 4, generations: 2, seed: 1}\n"
        "execution: {backend: inline}\noutput: {sync: normal}\n")

ALL_FIXED = """\
blade:
  mode: design
  continuity: G1
  fixed: {alpha: 10, beta1: 5, beta1bar: 25, u_s2: 0.2, d_s1: 0.006, d_s2: 0.01, d_s3: 0.03, u_p2: 0.2,
          d_p1: 0.006, d_p2: 0.01, d_p3: 0.03}
mesh: {level: coarse}
"""


def refused(capsys, argv: list[str], *expected: str) -> str:
    """``main(argv)`` exits 2 with one error line holding every ``expected`` text; returns the line."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("millfoil: error: "), err
    assert "Traceback" not in err
    for text in expected:
        assert text in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def zdt1(tmp_path):
    path = tmp_path / "zdt1.yaml"
    path.write_text(ZDT1)
    return path


def written(directory) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


# ------------------------------------------------------------------------------ refused by check and run
@pytest.mark.parametrize(("override", "expected"), [
    ("algorithm.population=1000000000", ("--set algorithm.population=1000000000", "outside [2, 10000]")),
    ("algorithm.offspring=1000000000", ("--set algorithm.offspring=1000000000", "outside [1, 10000]")),
    ("algorithm.generations=100000", ("'algorithm.generations' = 100000 is outside [1, 10000]",)),
    ("algorithm.seed=18446744073709551616", ("--set algorithm.seed=", "'algorithm.seed'", "2**63 - 1")),
    ("algorithm.seed=-1", ("'algorithm.seed'", "outside [0, ")),
    ("algorithm.initial_draws=1000000000", ("'algorithm.initial_draws'", "outside [1, 100000]")),
    ("execution.cluster.memory=lots", ("--set execution.cluster.memory=lots", "not a memory size", "4GiB")),
    ("execution.cluster.memory=4kB", ("'execution.cluster.memory'", "outside [256 MiB, 64 TiB]")),
    ("execution.cluster.memory=100TiB", ("'execution.cluster.memory'", "outside [256 MiB, 64 TiB]")),
    ("execution.cluster.walltime=lots", ("--set execution.cluster.walltime=lots", "[D-]HH:MM[:SS]")),
    ("execution.cluster.queue=two words", ("'execution.cluster.queue'", "not one word")),
    ("execution.cluster.cores=100000", ("'execution.cluster.cores' = 100000 is outside [1, 1024]",)),
    ("execution.workers=1000000", ("'execution.workers' = 1000000 is outside [1, 10000]",)),
    ("execution.retries=1000000", ("'execution.retries'", "outside [0, 100]")),
    ("execution.timeout=1e12", ("'execution.timeout'", "outside (0, 604800] s")),
    ("execution.workers=true", ("--set execution.workers=true", "not a boolean")),
    ("execution.retries=on", ("--set execution.retries=on", "not a boolean")),
    ("execution.cluster.cores=true", ("--set execution.cluster.cores=true", "not a boolean")),
    ("objectives=[]", ("--set objectives=[]", "there is no objective")),
    ("output.directory=''", ("--set output.directory=''", "the run directory is empty")),
    ("objectivs=[]", ("--set objectivs", "unknown key 'objectivs'", "objectives, constraints", "algorithm")),
    # an error of the section as a whole that an override caused names the override, not the file's line
    ("execution.cluster.lifetime=2h", ("--set execution.cluster.lifetime=2h: 'execution.cluster'",)),
])
@pytest.mark.parametrize("command", ["check", "run"])
def test_a_bad_value_is_refused_before_anything_is_written(command, override, expected, tmp_path, monkeypatch,
                                                          capsys):
    monkeypatch.chdir(tmp_path)
    line = refused(capsys, [command, "--set", override, *(["--out", "out"] if command == "run" else [])], *expected)
    assert "quickstart.yaml" not in line          # located at the --set, not at the file's section
    assert written(tmp_path) == []


def test_the_evaluations_of_a_campaign_are_bounded(tmp_path, capsys):
    refused(capsys, ["check", "--set", "algorithm.population=10000", "--set", "algorithm.generations=1000"],
            "'algorithm': population + (generations - 1) x offspring", f"more than the limit of {MAX_EVALUATIONS:,}")


def test_the_largest_seed_runs_and_is_stored(tmp_path, zdt1, capsys):
    run = tmp_path / "run"
    assert main(["run", str(zdt1), "--out", str(run), "--set", f"algorithm.seed={MAX_SEED}", "--quiet"]) == 0
    assert main(["status", str(run), "--json"]) == 0
    assert f'"seed": {MAX_SEED}' in capsys.readouterr().out


def test_a_memory_in_the_schedulers_units_is_accepted():
    for memory in ("4GB", "500MB", "16GiB", "1 GiB", "2.5GB"):
        assert load_campaign(None, [f"execution.cluster.memory={memory}"]).execution.cluster.memory == memory
    # the memory is per job: four worker processes need four workers' worth
    with pytest.raises(ValueError, match="outside \\[1 GiB, 64 TiB\\] for 4 worker process"):
        load_campaign(None, ["execution.cluster.cores=4", "execution.cluster.memory=500MB"])


def test_a_campaign_with_every_parameter_fixed_is_refused(tmp_path, monkeypatch, capsys):
    path = tmp_path / "fixed.yaml"
    path.write_text(ALL_FIXED)
    monkeypatch.chdir(tmp_path)
    for command in (["check", str(path)], ["run", str(path), "--out", "out"]):
        refused(capsys, command, f"{path}:4: 'blade.fixed': every parameter of design G1 blades is fixed",
                "at least one design variable")
    assert written(tmp_path) == ["fixed.yaml"]


def test_booleans_in_the_execution_section_of_a_file_are_refused(tmp_path, capsys):
    path = tmp_path / "b.yaml"
    path.write_text("analytic: {problem: zdt1}\nexecution:\n  workers: true\n  retries: on\n  cluster:\n"
                    "    cores: yes\n")
    refused(capsys, ["check", str(path)], f"{path}:3: 'execution.workers': a number is expected, not a boolean",
            f"{path}:4: 'execution.retries'", f"{path}:6: 'execution.cluster.cores'")


def test_an_empty_objective_list_in_a_file_is_refused(tmp_path, capsys):
    path = tmp_path / "o.yaml"
    path.write_text("analytic: {problem: zdt1}\nobjectives: []\n")
    refused(capsys, ["check", str(path)], f"{path}:2: 'objectives': there is no objective")
    path.write_text("analytic: {problem: zdt1}\n")            # left out: the problem's own pair
    assert [o.figure for o in load_campaign(path).objectives] == ["f1", "f2"]


def test_an_empty_run_directory_is_refused(tmp_path, zdt1, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", str(zdt1), "--out", ""], "--out '': the run directory is empty")
    refused(capsys, ["run", str(zdt1), "--out", "  "], "--out '  ': the run directory is empty")
    path = tmp_path / "d.yaml"
    path.write_text(ZDT1.replace("output: {sync: normal}", "output: {sync: normal, directory: ''}"))
    refused(capsys, ["run", str(path)], f"{path}:4: 'output.directory': the run directory is empty")
    assert written(tmp_path) == ["d.yaml", "zdt1.yaml"]


def test_an_unknown_bare_key_is_an_unknown_campaign_key_and_a_parameter_is_still_one(capsys):
    line = refused(capsys, ["check", "--set", "objectivs=[]"], "unknown key 'objectivs'")
    assert "blade.parameters" not in line
    assert main(["check", "--set", "alpha=10"]) == 0       # a blade parameter: warned, not refused
    assert "blade.parameters (alpha) is not used by a campaign" in capsys.readouterr().err


def test_a_section_error_with_an_override_names_both(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(ZDT1.replace("execution: {backend: inline}", "execution:\n  backend: inline\n"
                                 "  cluster: {walltime: '01:00:00'}"))
    refused(capsys, ["check", str(path), "--set", "execution.cluster.lifetime=2h"],
            f"--set execution.cluster.lifetime=2h (with {path}:5): 'execution.cluster': lifetime")


# ------------------------------------------------------------------------------------------------- resume
@pytest.fixture
def stopped_run(tmp_path, zdt1, capsys):
    """A finished ZDT1 run directory and the names in it."""
    run = tmp_path / "run"
    assert main(["run", str(zdt1), "--out", str(run), "--quiet"]) == 0
    capsys.readouterr()
    return run


@pytest.mark.parametrize(("override", "expected"), [
    ("execution.workers=true", ("--set execution.workers=true: 'execution.workers'", "not a boolean")),
    ("execution.workers=0", ("--set execution.workers=0: 'execution.workers'",)),
    ("execution.cluster.memory=lots", ("--set execution.cluster.memory=lots", "not a memory size")),
    ("execution.backend=nowhere", ("--set execution.backend=nowhere: 'execution.backend' = 'nowhere' is not "
                                   "allowed",)),
    ("execution.backend=scheduler", ("--set execution.backend=scheduler: 'execution'", "needs address")),
    ("execution.wrokers=2", ("--set execution.wrokers=2: unknown key 'execution.wrokers'",)),
    ("execution.workers=[", ("--set execution.workers", "not valid YAML")),
    ("algorithm.seed=2", ("--set 'algorithm.seed=2': resume changes only execution.KEY=VALUE",)),
])
def test_resume_validates_its_overrides_as_run_does(stopped_run, override, expected, capsys):
    def files() -> dict[str, int]:        # SQLite's side files (-wal, -shm) come with any reader of the store
        return {p.name: p.stat().st_mtime_ns for p in stopped_run.iterdir() if not p.name.endswith(("-wal", "-shm"))}

    before = files()
    refused(capsys, ["resume", str(stopped_run), "--set", override], *expected)
    assert files() == before
    assert main(["status", str(stopped_run), "--json"]) == 0
    assert '"state": "finished"' in capsys.readouterr().out


def test_resume_with_a_valid_override_runs(stopped_run, capsys):
    assert main(["resume", str(stopped_run), "--set", "execution.retries=1", "--quiet"]) == 0
    assert (stopped_run / STORE_NAME).is_file()
