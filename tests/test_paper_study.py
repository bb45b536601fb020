"""The paper study's script (``bench/paper_study.py``).

Cost figures: wall hours count the time evaluations ran and the driver's surrogate step, never the hours a
stopped study waited for its ``resume``. Archive (``--archive``): finished runs only, unless asked to carry
an unfinished one to another machine (its store, without fields), which continues from the copy; the
fields a finished run lacks are solved again."""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from optimizer.campaign.config import load_campaign
from optimizer.campaign.driver import resume_campaign, run_campaign
from optimizer.campaign.fields import fields_path
from optimizer.campaign.packed import packed_path
from optimizer.campaign.record import evaluate_payload
from optimizer.campaign.store import STORE_NAME, Store

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def paper_study():
    spec = importlib.util.spec_from_file_location("paper_study", ROOT / "bench" / "paper_study.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# ---------------------------------------------------------------------------------------------- costs
def _row(submitted: str, finished: str):
    return SimpleNamespace(submitted=f"2026-01-01T{submitted}+00:00", finished=f"2026-01-01T{finished}+00:00")


def test_overlapping_evaluations_count_once_and_a_stop_inside_a_generation_not_at_all(paper_study):
    rows = [_row("10:00:00", "10:10:00"), _row("10:05:00", "10:20:00"),    # two workers: 10:00-10:20
            _row("14:00:00", "14:30:00")]                                     # the same generation, resumed
    generations = [SimpleNamespace(search={"seconds": {"fit": 60.0, "screen": 120.0}}),
                   SimpleNamespace(search=None)]
    assert paper_study.busy_hours(rows, generations) == pytest.approx((20 + 30 + 3) / 60)


def test_rows_never_submitted_cost_nothing(paper_study):
    rows = [SimpleNamespace(submitted=None, finished="2026-01-01T10:00:00+00:00")]
    assert paper_study.busy_hours(rows, []) == 0.0


# -------------------------------------------------------------------------------------------- archive
@pytest.fixture
def interrupted(tmp_path):
    """``OUT/medium/design_g1``: a campaign of three generations of 6 interrupted (Ctrl-C) in its third, a
    fields file for every design (an analytic problem stands in for the blade: the archive reads only the
    store)."""
    config = tmp_path / "c.yaml"
    config.write_text("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 3, "
                      "seed: 3}\nexecution: {backend: inline}\n")
    run = tmp_path / "out" / "medium" / "design_g1"
    calls = []

    def stopped_in_the_third_generation(payload):
        calls.append(payload)
        if len(calls) == 15:
            raise KeyboardInterrupt
        return evaluate_payload(payload)

    with pytest.raises(KeyboardInterrupt):
        run_campaign(load_campaign(config), run, fn=stopped_in_the_third_generation)
    with Store(run / STORE_NAME, readonly=True) as store:
        assert store.campaign().state == "interrupted"
        keys = [r.key for r in store.evaluations()]
        front = {r.key for r in store.front()}
    for key in keys:
        fields_path(run, key).parent.mkdir(exist_ok=True)
        fields_path(run, key).write_bytes(b"fields")
    assert 0 < len(front) < len(keys)
    return run, front


def test_an_unfinished_run_is_left_out_unless_asked_for(paper_study, interrupted, tmp_path, capsys):
    run, _ = interrupted
    paper_study.archive(run.parents[1], "medium", ["design_g1"], tmp_path / "kept")
    assert not (tmp_path / "kept" / "medium" / "design_g1").exists()
    assert "not archived, the campaign is interrupted" in capsys.readouterr().err


def test_an_unfinished_run_is_copied_without_fields_and_continues_from_the_copy(paper_study, interrupted, tmp_path):
    run, _ = interrupted
    paper_study.archive(run.parents[1], "medium", ["design_g1"], tmp_path / "kept", unfinished=True)
    kept = tmp_path / "kept" / "medium" / "design_g1"
    assert packed_path(kept / STORE_NAME).exists() and not (kept / STORE_NAME).exists()
    assert not (kept / "fields").exists()

    again = tmp_path / "elsewhere" / "medium" / "design_g1"
    shutil.copytree(kept, again)
    with Store(run / STORE_NAME, readonly=True) as store:
        before = {r.key for r in store.evaluations()}
    assert resume_campaign(again).state == "finished"
    with Store(again / STORE_NAME, readonly=True) as store:
        rows = list(store.evaluations())
    assert before < {r.key for r in rows} and len(rows) == 18          # the rest of the third generation only


def test_a_copy_names_itself_within_its_repository_not_by_this_machine_s_path(paper_study, interrupted, tmp_path):
    """The store's message ("continue with `millfoil resume DIR`") names the copy from the root of the git
    repository it is kept in, wherever the study and the script ran."""
    run, _ = interrupted
    repository = tmp_path / "clone"
    (repository / ".git").mkdir(parents=True)
    paper_study.archive(run.parents[1], "medium", ["design_g1"], repository / "runs" / "paper", unfinished=True)
    kept = repository / "runs" / "paper" / "medium" / "design_g1"
    with Store(packed_path(kept / STORE_NAME), readonly=True) as store:
        message = store.campaign().message
    assert "millfoil resume runs/paper/medium/design_g1" in message and str(tmp_path) not in message


def test_a_finished_run_archived_before_is_left_as_it_is(paper_study, interrupted, tmp_path, capsys,
                                                           monkeypatch):
    """Archived, then copied back without the fields its report does not draw and archived again: its front
    is not solved again and the copy is not touched."""
    run, _ = interrupted
    assert resume_campaign(run).state == "finished"
    paper_study.archive(run.parents[1], "medium", ["design_g1"], tmp_path / "kept")
    kept = tmp_path / "kept" / "medium" / "design_g1"
    before = {p: p.stat().st_mtime_ns for p in kept.rglob("*")}
    shutil.rmtree(run / "fields")

    def solve_again(directory):
        raise AssertionError(f"{directory} solved again")

    monkeypatch.setattr(paper_study, "restore_fields", solve_again)
    capsys.readouterr()
    paper_study.archive(run.parents[1], "medium", ["design_g1"], tmp_path / "kept")
    assert f"already archived in {kept}" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in kept.rglob("*")} == before


@pytest.mark.slow
def test_a_finished_run_missing_front_fields_gets_them_solved_again(paper_study, tmp_path):
    """A run continued from a copy without fields: the archive solves its front designs again, and the files
    are those the first solves wrote (the solver is deterministic)."""
    run = tmp_path / "coarse" / "design_g1"
    config = load_campaign(ROOT / "configs" / "paper" / "design_g1.yaml",
                           ["mesh.level=coarse", "algorithm.population=3", "algorithm.generations=1",
                            "execution.backend=inline"])
    run_campaign(config, run)
    with Store(run / STORE_NAME, readonly=True) as store:
        front = [r.key for r in store.front()]
    originals = {k: dict(np.load(fields_path(run, k))) for k in front}
    for k in front[:2]:
        fields_path(run, k).unlink()
    assert paper_study.restore_fields(run) == min(2, len(front))
    for k in front:
        again = np.load(fields_path(run, k))
        assert all(np.array_equal(again[name], value) for name, value in originals[k].items()
                   if value.dtype.kind != "f")
        assert all(np.array_equal(again[name], value, equal_nan=True) for name, value in originals[k].items()
                   if value.dtype.kind == "f")
    assert paper_study.restore_fields(run) == 0                     # nothing missing: nothing solved
