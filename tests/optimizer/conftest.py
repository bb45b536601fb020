"""Fixtures shared by the optimizer tests."""

from __future__ import annotations

from pathlib import Path

import pytest

#: A small analytic campaign: ZDT1 with 4 variables, 6 + 6 evaluations, in process (no CFD, about 0.2 s).
ZDT1_CAMPAIGN = ("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 2, seed: 3}\n"
                 "execution: {backend: inline}\noutput: {sync: normal}\n")


@pytest.fixture(scope="module")
def finished_zdt1(tmp_path_factory) -> Path:
    """The run directory of a finished :data:`ZDT1_CAMPAIGN` (a real store to read, damage or report on)."""
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.driver import run_campaign

    base = tmp_path_factory.mktemp("zdt1")
    (base / "zdt1.yaml").write_text(ZDT1_CAMPAIGN)
    run_campaign(load_campaign(base / "zdt1.yaml", []), base / "run")
    return base / "run"
