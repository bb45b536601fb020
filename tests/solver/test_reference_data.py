"""The reference data shipped in solver/validation/reference/ is the published data, unchanged."""

import csv
from pathlib import Path

import pytest

from solver.validation.cylinder import REFERENCE

PACKAGED = Path(__file__).parents[2] / "solver" / "validation" / "reference"
SHARED = Path(__file__).parents[3] / "shared" / "reference"


@pytest.mark.skipif(not SHARED.is_dir(), reason="the project's shared/reference folder is not beside the checkout")
@pytest.mark.parametrize("path", sorted(PACKAGED.glob("*.csv")), ids=lambda p: p.name)
def test_packaged_copies_match_the_shared_reference(path):
    assert path.read_bytes() == (SHARED / path.name).read_bytes()


def test_cylinder_constants_are_the_tabulated_values():
    rows = [r for r in csv.DictReader(line for line in (PACKAGED / "schaefer_turek_cylinder.csv").open()
                                      if not line.startswith("#")) if r["case"] == "2D-1" and r["value"]]
    assert {r["quantity"]: float(r["value"]) for r in rows} == REFERENCE
