"""The paper study's cost figures (``bench/paper_study.py``): wall hours count the time evaluations ran and
the driver's surrogate step, never the hours a stopped study waited for its ``resume``."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def paper_study():
    spec = importlib.util.spec_from_file_location("paper_study", ROOT / "bench" / "paper_study.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
