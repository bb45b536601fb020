"""No half-written outputs: ``report``, ``export`` and the end of ``run`` write every file under a temporary
name in its directory and rename them together at the end (docs/reference/errors.md), so an output path
that is a directory is refused before anything is written and a full disk part-way leaves no file.

A full disk is simulated by a writer that writes half its file and raises ENOSPC; where this process may
mount a small tmpfs (root), the same commands also run on a real full file system.
"""

from __future__ import annotations

import errno
import os
import subprocess
import uuid
from pathlib import Path

import pytest

from optimizer.campaign.store import STORE_NAME, Store
from optimizer.cli import main

ZDT1 = ("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 2, seed: 3}\n"
        "execution: {backend: inline}\noutput: {sync: normal}\n")
BLADE = Path(__file__).resolve().parents[2] / "configs" / "examples" / "table5_g1_toolpath.yaml"


@pytest.fixture(scope="module")
def run(finished_zdt1) -> Path:
    """A finished analytic campaign's run directory (no CFD)."""
    return finished_zdt1


def _one_error_line(err: str, progress: str = "") -> str:
    """The one line of ``err`` (after the command's ``progress`` line, where it announced its work)."""
    lines = err.strip().splitlines()
    if progress:
        assert lines[0].startswith(progress), err
        lines = lines[1:]
    assert len(lines) == 1, err
    assert lines[0].startswith("millfoil: error: ") and "Traceback" not in err
    return lines[0]


def _files(directory: Path) -> dict[str, bytes]:
    """Every file below ``directory`` (temporaries included) with its content."""
    return {str(p.relative_to(directory)): p.read_bytes() for p in directory.rglob("*") if p.is_file()}


def _half_then_full(write):
    """``write`` made to fail like a full disk: it writes its file, which is then cut to half, and raises ENOSPC."""
    def failing(*args):
        path = Path(args[-1])
        write(*args)
        os.truncate(path, path.stat().st_size // 2)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return failing


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 48 KiB tmpfs (a disk that fills part-way through a report or a DXF), or a skip saying why not."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root; the ENOSPC tests simulate a full disk instead")
    mount = tmp_path / f"full-{uuid.uuid4().hex[:6]}"
    mount.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=48k", "tmpfs", str(mount)], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({proc.stderr.strip() or proc.returncode}); the ENOSPC tests "
                    "simulate a full disk instead")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


# --------------------------------------------------------------------------------------------- report
def test_report_refuses_an_output_path_that_is_a_directory_and_writes_nothing(run, tmp_path, capsys):
    out = tmp_path / "D"
    (out / "index.html").mkdir(parents=True)
    assert main(["report", str(run), "--out", str(out)]) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert f"{out / 'index.html'} is a directory" in line
    assert [p.name for p in out.iterdir()] == ["index.html"] and not any((out / "index.html").iterdir())


@pytest.mark.slow
def test_report_on_a_full_disk_leaves_no_file_and_the_previous_report(run, tmp_path, capsys, monkeypatch):
    import optimizer.report.html as page

    out = tmp_path / "report"
    assert main(["report", str(run), "--out", str(out)]) == 0
    before = _files(out)
    assert "health_0.svg" in before and "index.html" in before
    monkeypatch.setattr(page, "health_figure", _half_then_full(page.health_figure))
    capsys.readouterr()
    assert main(["report", str(run), "--out", str(out)]) == 4
    line = _one_error_line(capsys.readouterr().err, progress="millfoil: drawing the report of 1 run in ")
    assert "No space left on device" in line and "no file was written" in line
    assert _files(out) == before          # no temporary, no truncated SVG, the earlier report untouched
    fresh = tmp_path / "fresh"
    assert main(["report", str(run), "--out", str(fresh)]) == 4
    assert not fresh.exists()             # the directory the report would have made is gone too


@pytest.mark.slow
def test_report_on_a_real_full_file_system(run, small_tmpfs, capsys):
    out = small_tmpfs / "report"
    assert main(["report", str(run), "--out", str(out)]) == 4
    _one_error_line(capsys.readouterr().err, progress="millfoil: drawing the report of 1 run in ")
    assert not out.exists() and list(small_tmpfs.iterdir()) == []


# --------------------------------------------------------------------------------------------- export
def test_export_on_a_full_disk_leaves_no_truncated_dxf(tmp_path, capsys, monkeypatch):
    target = tmp_path / "blade.dxf"
    real = Path.write_text

    def write_text(self, text, *args, **kwargs):
        if ".partial" in self.name:       # the export's staged file: the disk fills part-way
            real(self, text[: len(text) // 2], *args, **kwargs)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
        return real(self, text, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    assert main(["export", "--config", str(BLADE), "--format", "dxf", "--out", str(target)]) == 4
    line = _one_error_line(capsys.readouterr().err)
    assert f"cannot write {target}: No space left on device; nothing was written" in line
    assert list(tmp_path.iterdir()) == []


def test_export_refuses_an_output_path_that_is_a_directory(tmp_path, capsys):
    (tmp_path / "blade.dxf").mkdir()
    assert main(["export", "--config", str(BLADE), "--format", "dxf", "--out", str(tmp_path / "blade.dxf")]) == 2
    assert "is a directory; nothing was written" in _one_error_line(capsys.readouterr().err)


def test_export_on_a_real_full_file_system(small_tmpfs, capsys):
    (small_tmpfs / "filler").write_bytes(b"\0" * 24 * 1024)      # the DXF (about 35 KB) then fits half-way
    target = small_tmpfs / "blade.dxf"
    assert main(["export", "--config", str(BLADE), "--format", "dxf", "--out", str(target)]) == 4
    _one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["filler"]


# ----------------------------------------------------------------------------------------- run: front.csv
def test_run_whose_front_csv_cannot_be_written_says_the_store_has_everything(tmp_path, capsys):
    config = tmp_path / "zdt1.yaml"
    config.write_text(ZDT1)
    directory = tmp_path / "run"
    (directory / "front.csv").mkdir(parents=True)
    assert main(["run", str(config), "--out", str(directory), "--quiet"]) == 4
    err = capsys.readouterr().err       # the campaign's phase lines, then one error line
    errors = [x for x in err.splitlines() if x.startswith("millfoil: error:")]
    assert len(errors) == 1 and "Traceback" not in err and err.strip().splitlines()[-1] == errors[0]
    line = errors[0]
    assert line.startswith(f"millfoil: error: the campaign finished and is stored in {directory}, but front.csv "
                           "could not be written: ")
    assert line.endswith(f"; millfoil report {directory} reads the store")
    assert not any(".partial" in p.name for p in directory.iterdir())
    with Store(directory / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "finished" and len(store.generations()) == 2
