"""A damaged campaign store is a bad input: every command that reads it exits 2 with one line saying what is
damaged and what can still be read, writes nothing and never shows a traceback; ``millfoil status`` first
prints what it can read.

Each damage is made by corrupting a real store, written by a small analytic campaign (ZDT1, inline, no CFD:
about 0.2 s): truncated to half its size, overwritten with random bytes, emptied, a row's JSON broken, the
configuration's YAML broken, a table dropped.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from optimizer.campaign.store import STORE_NAME, Store, StoreDamaged, inspect_store
from optimizer.cli import main
from optimizer.config import ConfigError

ZDT1 = ("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 2, seed: 3}\n"
        "execution: {backend: inline}\noutput: {sync: normal}\n")
#: What the driver leaves in a run directory besides the store: its lock file (kept by design, rewritten by
#: the next driver) and SQLite's own side files of a WAL database, which a reader may create.
SIDE_FILES = {"driver.lock", f"{STORE_NAME}-wal", f"{STORE_NAME}-shm"}


@pytest.fixture(scope="module")
def pristine(finished_zdt1) -> Path:
    """A finished analytic campaign's run directory (6 + 6 evaluations, 2 generations)."""
    return finished_zdt1


def _sql(statement: str):
    def damage(path: Path) -> None:
        db = sqlite3.connect(path)
        with db:
            db.execute(statement)
        db.close()
    return damage


def _truncate(path: Path) -> None:
    os.truncate(path, path.stat().st_size // 2)


def _random(path: Path) -> None:
    path.write_bytes(os.urandom(path.stat().st_size))


def _empty(path: Path) -> None:
    path.write_bytes(b"")


#: name -> (damage, a fragment of what the message says is damaged, of what it says can be read)
DAMAGES = {
    "truncated": (_truncate, "malformed", "nothing in it can be read"),
    "random": (_random, "is not an SQLite database", "nothing in it can be read"),
    "empty": (_empty, "the file is empty (0 bytes)", "nothing in it can be read"),
    "json": (_sql("UPDATE evaluations SET objectives='{\"f1\": 0.5,' WHERE rowid=3"),
             "design 3 has invalid JSON in its 'objectives' column", "the evaluations table (11 of 12 rows)"),
    "yaml": (_sql("UPDATE campaign SET config='algorithm: [1, 2\nseed: :' WHERE id=1"),
             "the stored campaign configuration is not valid YAML (line 2", "the evaluations table (12 rows)"),
    "dropped": (_sql("DROP TABLE generations"), "the generations table is missing",
                "still readable: the campaign table (1 row), the evaluations table (12 rows)"),
}


@pytest.fixture(params=sorted(DAMAGES))
def damaged(request, pristine, tmp_path) -> tuple[Path, str, str]:
    """(run directory with a damaged store, damage fragment, readable fragment)."""
    damage, what, readable = DAMAGES[request.param]
    run = tmp_path / "run"
    shutil.copytree(pristine, run)
    damage(run / STORE_NAME)
    return run, what, readable


def _snapshot(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in directory.iterdir() if p.is_file() and p.name not in SIDE_FILES}


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("millfoil: error: ") and "Traceback" not in err
    return lines[0]


# ----------------------------------------------------------------------------------------- inspection
def test_a_sound_store_is_not_damaged(pristine):
    inspection = inspect_store(pristine / STORE_NAME)
    assert not inspection.damaged
    assert [(t.name, t.rows) for t in inspection.tables] == [("campaign", 1), ("evaluations", 12), ("generations", 2)]
    with Store(pristine / STORE_NAME, readonly=True) as store:
        assert len(list(store.evaluations())) == 12


def test_inspection_says_what_is_damaged_and_what_can_be_read(damaged):
    run, what, readable = damaged
    inspection = inspect_store(run / STORE_NAME)
    assert inspection.damaged
    assert what in inspection.damage and readable in inspection.readable
    json.dumps(inspection.to_dict())          # millfoil status --json prints it


@pytest.mark.parametrize("readonly", [True, False])
def test_opening_a_damaged_store_raises_store_damaged_and_changes_nothing(damaged, readonly):
    run, what, readable = damaged
    before = _snapshot(run)
    with pytest.raises(StoreDamaged) as caught:
        with Store(run / STORE_NAME, readonly=readonly):
            pass
    assert isinstance(caught.value, ConfigError)           # a bad input: exit status 2
    message = str(caught.value)
    assert message.startswith(f"{run / STORE_NAME} is damaged: ") and what in message and readable in message
    assert "\n" not in message
    assert _snapshot(run) == before       # the driver's open never "repairs" it (a dropped table made anew)


def test_damage_met_while_reading_an_open_store(pristine, tmp_path):
    """Damage after the check at opening (another process writes into the file) is StoreDamaged too."""
    run = tmp_path / "run"
    shutil.copytree(pristine, run)
    with Store(run / STORE_NAME, readonly=True) as store:
        _sql("UPDATE evaluations SET x='[0.1, ' WHERE rowid=5")(run / STORE_NAME)
        with pytest.raises(StoreDamaged, match=r"design 5 has invalid JSON in its 'x' column"):
            list(store.evaluations())


def test_many_invalid_rows_are_counted_not_listed(pristine, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(pristine, run)
    _sql("UPDATE evaluations SET minimised='[' WHERE rowid > 2")(run / STORE_NAME)
    inspection = inspect_store(run / STORE_NAME)
    assert inspection.damage.count("has invalid JSON") == 3
    assert "7 more invalid value(s) in the evaluations table" in inspection.damage
    assert "the evaluations table (2 of 12 rows)" in inspection.readable


# --------------------------------------------------------------------------------------------- commands
def test_status_prints_what_it_can_read_then_the_error(damaged, capsys):
    run, what, readable = damaged
    before = _snapshot(run)
    assert main(["status", str(run)]) == 2
    out, err = capsys.readouterr()
    line = _one_error_line(err)
    assert f"{run / STORE_NAME} is damaged: " in line and what in line and readable in line
    assert out.startswith(f"campaign {run}: damaged store")
    if "nothing" not in readable:
        assert "evaluations table: " in out
    assert _snapshot(run) == before


def test_status_json_of_a_damaged_store(damaged, capsys):
    run, what, _ = damaged
    assert main(["status", str(run), "--json"]) == 2
    out, err = capsys.readouterr()
    assert json.loads(out)["damaged"]["damaged"] is True
    assert what in _one_error_line(err)


@pytest.mark.parametrize("command", ["report", "export", "run", "resume"])
def test_every_command_refuses_a_damaged_store_and_writes_nothing(damaged, command, capsys):
    run, what, readable = damaged
    config = run.parent / "zdt1.yaml"
    config.write_text(ZDT1)
    argv = {"report": ["report", str(run)], "export": ["export", str(run), "--id", "1", "--format", "csv"],
            "run": ["run", str(config), "--out", str(run)], "resume": ["resume", str(run)]}[command]
    before = _snapshot(run)
    assert main(argv) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert line == f"millfoil: error: {run / STORE_NAME} is damaged: " + line.split(" is damaged: ", 1)[1]
    assert what in line and readable in line
    assert _snapshot(run) == before
    assert sorted(p.name for p in run.iterdir() if p.is_dir()) == []      # no report/, no export/


@pytest.mark.slow
@pytest.mark.parametrize("command", ["status", "report"])
def test_millfoil_process_on_a_damaged_store(pristine, tmp_path, command):
    """The installed entry point as a user runs it: exit 2, one line, no traceback."""
    run = tmp_path / "run"
    shutil.copytree(pristine, run)
    _truncate(run / STORE_NAME)
    proc = subprocess.run([sys.executable, "-m", "optimizer.cli", command, str(run)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "malformed" in _one_error_line(proc.stderr)
