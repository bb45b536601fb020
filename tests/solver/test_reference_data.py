"""The reference data shipped in solver/validation/reference/ is the published data, unchanged."""

import csv
import hashlib
from pathlib import Path

import pytest

from solver.validation.cylinder import REFERENCE

PACKAGED = Path(__file__).parents[2] / "solver" / "validation" / "reference"
#: ``sha256sum *.csv`` of the published files as copied in (each file's header names its source).
SUMS = dict(line.split()[::-1] for line in (PACKAGED / "SHA256SUMS").read_text().splitlines() if line.strip())


def test_every_reference_file_has_a_checksum():
    assert sorted(SUMS) == sorted(p.name for p in PACKAGED.glob("*.csv"))


@pytest.mark.parametrize("path", sorted(PACKAGED.glob("*.csv")), ids=lambda p: p.name)
def test_packaged_copies_are_unchanged(path):
    assert hashlib.sha256(path.read_bytes()).hexdigest() == SUMS[path.name]


def test_cylinder_constants_are_the_tabulated_values():
    rows = [r for r in csv.DictReader(line for line in (PACKAGED / "schaefer_turek_cylinder.csv").open()
                                      if not line.startswith("#")) if r["case"] == "2D-1" and r["value"]]
    assert {r["quantity"]: float(r["value"]) for r in rows} == REFERENCE
