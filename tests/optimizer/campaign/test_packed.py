"""Packed stores: `pack` and `unpack` round-trip a store byte for byte, every reading command reads a packed
store as it is, `resume` unpacks it, and nothing packs under a live driver or over a damaged file."""

from __future__ import annotations

import lzma
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import CampaignError, resume_campaign, run_campaign
from optimizer.campaign.lock import DirectoryInUse
from optimizer.campaign.packed import PackError, pack, packed_path, unpack
from optimizer.campaign.progress import status_of
from optimizer.campaign.store import STORE_NAME, Store, StoreDamaged, inspect_store
from optimizer.cli import main
from optimizer.report.run import load_run

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def run(tmp_path, finished_zdt1):
    copy = tmp_path / "run"
    shutil.copytree(finished_zdt1, copy)
    return copy


def test_pack_and_unpack_round_trip_the_store_byte_for_byte(run):
    original = (run / STORE_NAME).read_bytes()
    done = pack(run / STORE_NAME)
    assert not (run / STORE_NAME).exists() and done.written == packed_path(run / STORE_NAME)
    assert done.after < done.before == len(original)
    assert lzma.decompress(done.written.read_bytes()) == original
    unpack(run / STORE_NAME)
    assert (run / STORE_NAME).read_bytes() == original and not packed_path(run / STORE_NAME).exists()


def test_the_write_ahead_log_is_folded_in(run):
    """A store whose last writes are still in its WAL packs whole: the packed copy has them."""
    with Store(run / STORE_NAME) as store:
        store.end_campaign("finished", "written last")
        with Store(run / STORE_NAME, readonly=True) as reader:     # a reader keeps the WAL from being folded
            assert reader.campaign().message == "written last"
            pack(run / STORE_NAME)
    assert not (run / f"{STORE_NAME}-wal").exists()
    with Store(run / STORE_NAME, readonly=True) as packed:
        assert packed.campaign().message == "written last"


@pytest.mark.slow
def test_reading_commands_read_a_packed_store_as_it_is(run, finished_zdt1, capsys):
    pack(run / STORE_NAME)
    assert status_of(run)["evaluations"] == status_of(finished_zdt1)["evaluations"]
    assert [d.key for d in load_run(run).designs] == [d.key for d in load_run(finished_zdt1).designs]
    assert main(["status", str(run)]) == 0
    assert main(["report", str(run), "--out", str(run.parent / "report")]) == 0
    assert (run.parent / "report" / "index.html").exists()
    assert not (run / STORE_NAME).exists()                           # nothing was unpacked in place


def test_resume_unpacks_and_continues(tmp_path, capsys):
    (tmp_path / "c.yaml").write_text("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, "
                                     "generations: 3, seed: 3}\nexecution: {backend: inline}\n")
    run_campaign(load_campaign(tmp_path / "c.yaml", ["algorithm.generations=2"]), tmp_path / "run")
    with Store(tmp_path / "run" / STORE_NAME) as store:       # as if it had been stopped after generation 2
        store.end_campaign("interrupted")
    pack(tmp_path / "run" / STORE_NAME)
    lines = []
    outcome = resume_campaign(tmp_path / "run", log=lines.append)
    assert outcome.state == "finished"
    assert any(line.startswith("unpacked campaign.sqlite.xz") for line in lines)
    assert (tmp_path / "run" / STORE_NAME).exists() and not packed_path(tmp_path / "run" / STORE_NAME).exists()


def test_run_into_a_packed_campaign_is_refused(run, tmp_path):
    pack(run / STORE_NAME)
    (tmp_path / "c.yaml").write_text("analytic: {problem: zdt1, variables: 4}\nexecution: {backend: inline}\n")
    with pytest.raises(CampaignError, match="already holds a campaign, packed: continue it with `millfoil resume"):
        run_campaign(load_campaign(tmp_path / "c.yaml", []), run)
    assert not (run / STORE_NAME).exists()


def test_pack_and_unpack_refuse_what_they_cannot_do(run, capsys):
    assert main(["unpack", str(run)]) == 2
    assert "campaign.sqlite is there already" in capsys.readouterr().err
    pack(run / STORE_NAME)
    with pytest.raises(PackError, match="it is packed already"):
        pack(run / STORE_NAME)
    assert main(["pack", str(run.parent / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"millfoil: error: {run.parent / 'nowhere'}: no such run directory"]


def test_nothing_is_packed_under_a_live_driver(run):
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\nfrom optimizer.campaign.lock import "
                               "DriverLock\nlock = DriverLock(sys.argv[1], 'run').acquire()\n"
                               "print('held', flush=True)\ntime.sleep(600)", str(run)], stdout=subprocess.PIPE,
                              text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(DirectoryInUse, match=f"millfoil run, pid {holder.pid}"):
            pack(run / STORE_NAME)
        assert (run / STORE_NAME).exists() and not packed_path(run / STORE_NAME).exists()
    finally:
        holder.kill()
        holder.wait()


def test_a_damaged_packed_store_is_reported_as_damaged(run, capsys):
    pack(run / STORE_NAME)
    packed = packed_path(run / STORE_NAME)
    packed.write_bytes(packed.read_bytes()[:200])                        # truncated in a copy
    with pytest.raises(StoreDamaged, match=r"campaign\.sqlite\.xz is damaged: the packed store cannot be unpacked"):
        status_of(run)
    assert inspect_store(run / STORE_NAME).path == packed
    assert main(["report", str(run), "--out", str(run.parent / "r")]) == 2
    assert main(["unpack", str(run)]) == 2
    assert "cannot be unpacked" in capsys.readouterr().err
    assert not (run / STORE_NAME).exists() and not (run / f".{STORE_NAME}.partial").exists()


@pytest.mark.slow
@pytest.mark.parametrize("packed", sorted(str(p.relative_to(ROOT)) for p in (ROOT / "runs" / "examples").rglob(
    f"{STORE_NAME}.xz")) or [pytest.param(None, marks=pytest.mark.skip(reason="no example stores"))])
def test_the_example_stores_read_on_a_fresh_clone(packed):
    """Every store kept under runs/examples is packed, whole, and names no directory outside the repository."""
    directory = (ROOT / packed).parent
    summary = status_of(directory)
    assert summary["evaluations"] > 0
    assert not (directory / STORE_NAME).exists()
    with Store(directory / STORE_NAME, readonly=True) as store:
        message = store.campaign().message or ""
    assert not re.search(r"(^|[\s`'\"(])/", message), message          # no absolute path


def test_a_refused_resume_leaves_a_packed_store_packed(run, capsys):
    pack(run / STORE_NAME)
    before = packed_path(run / STORE_NAME).read_bytes()
    assert main(["resume", str(run), "--set", "execution.workers=0", "--quiet"]) == 2
    assert "execution.workers" in capsys.readouterr().err
    assert packed_path(run / STORE_NAME).read_bytes() == before and not (run / STORE_NAME).exists()
