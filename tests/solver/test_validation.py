"""Validation API (``millfoil validate``) at CI size, and the DFG 2D-1 cylinder mesh and case.

Full-resolution figures (not run here): ``python -c "from solver.validation import run_case;
print(run_case('cylinder', 'fine'))"`` and likewise ``cavity`` / ``mms`` at ``medium`` / ``fine``.
"""

import json

import numpy as np
import pytest

from solver.validation import CASES, LEVELS, Comparison, ValidationReport, run_case


def test_registry_and_errors():
    assert set(CASES) == {"cavity", "cylinder", "flatplate", "mms", "naca0012"}
    assert LEVELS == ("coarse", "medium", "fine")
    with pytest.raises(ValueError, match="cavity.*cylinder.*flatplate.*mms.*naca0012"):
        run_case("airfoil")
    with pytest.raises(ValueError, match="coarse.*medium.*fine"):
        run_case("cavity", "huge")


def test_comparison_pass_and_json():
    c = Comparison.of("x (error: %)", 1.0, 1.1, 9.1, 10.0)
    assert c.passed and json.loads(json.dumps(c.as_json()))["pass"] is True
    assert set(c.as_json()) == {"name", "computed", "reference", "error", "tolerance", "pass"}
    assert not Comparison.of("x", 1.0, 1.0, float("nan"), 1.0).passed
    r = ValidationReport("t", "coarse", "d", (c, Comparison.of("y", 0, 0, 2.0, 1.0)), 0.1, {})
    assert not r.passed


def test_dfg_mesh_geometry():
    """Areas sum to the channel minus the (polygonal) cylinder; the cylinder group has 4 n_quarter faces
    whose polygon has nodes at the two Δp points; groups are named."""
    from solver.validation.meshes import dfg_cylinder

    m = dfg_cylinder(8, h_far=0.04, growth=0.1)
    assert m.group_names == ("inlet", "outlet", "walls", "cylinder")
    faces = m.boundary["cylinder"]
    assert faces.size == 32
    polygon = 0.5 * 32 * 0.05**2 * np.sin(2 * np.pi / 32)
    assert m.volume.sum() == pytest.approx(2.2 * 0.41 - polygon, rel=1e-12)
    nodes = m.points[np.unique(m.faces[faces])]
    for x in (0.15, 0.25):
        assert np.min(np.hypot(nodes[:, 0] - x, nodes[:, 1] - 0.2)) < 1e-9
    assert len(m.cells["quad"]) > 0 and np.all(np.einsum("ij,ij->i", m.d, m.normal) > 0)


@pytest.mark.slow
def test_cylinder_coarse_report():
    """DFG 2D-1 on 1 826 cells in about a second; tolerances and why they catch first-order upwind in
    :data:`solver.validation.cylinder.CYLINDER_TOLERANCES`."""
    r = run_case("cylinder", "coarse")
    assert r.details["status"] == "converged"
    assert r.passed, [c for c in r.comparisons if not c.passed]
    assert [c.name.split()[0] for c in r.comparisons] == ["C_D", "dp", "C_L"]


@pytest.mark.slow
def test_cylinder_upwind_fails_coarse_tolerance():
    """The coarse tolerances fail a first-order convection scheme (measured C_D error 13 %)."""
    from solver.validation.cylinder import CYLINDER_TOLERANCES, cylinder_settings, errors, run_cylinder

    _, c = run_cylinder("coarse", cylinder_settings(convection="upwind"))
    assert 100 * errors(c)["C_D"] > CYLINDER_TOLERANCES["coarse"]["C_D"]


@pytest.mark.slow
def test_cavity_coarse_report():
    r = run_case("cavity", "coarse")
    assert r.passed and r.details["re100"]["converged"]


@pytest.mark.slow
def test_mms_coarse_report():
    r = run_case("mms", "coarse")
    assert r.passed, r.comparisons
    assert all(m["status"] == "converged" for m in r.details["meshes"])
