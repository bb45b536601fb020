"""Limits of a mesh specification (bound what the inputs drive): every field in its range, the
chord Reynolds number, the first cell within the O-layer and the estimated cell count within the budget;
each refusal names the field, the value, the range and why."""

import math

import pytest

from meshing import BOUNDS, CELL_BUDGET, LEVELS, REYNOLDS_RANGE, MeshSpec, MeshSpecError

WATER = 1.002e-3 / 998.2       # kinematic viscosity of water at 20 °C, m²/s (the flow: defaults)
#: Cells measured on the paper's blades (module docstring of meshing.spec; default domain, half_height 1).
MEASURED = {"coarse": 5_500, "medium": 19_500, "fine": 70_400}
MEASURED_NARROW = {"coarse": 3_524 + 1_450, "medium": 11_868 + 5_000, "fine": 42_588 + 18_600}


@pytest.mark.parametrize("name", list(BOUNDS))
def test_every_field_is_refused_outside_its_range_with_the_reason(name):
    bound = BOUNDS[name]
    outside = [bound.lower if bound.open_lower else bound.lower * 0.5 - 1e-3, math.nan]
    if math.isfinite(bound.upper):
        outside.append(bound.upper * 2 + 1)
    for value in outside:
        with pytest.raises(MeshSpecError) as info:
            MeshSpec(**{name: int(value) if name == "wall_nodes" and math.isfinite(value) else value})
        assert info.value.field == name
        text = str(info.value)
        assert text.startswith(f"{name} = ") and bound.text() in text and bound.why in text, text


@pytest.mark.parametrize("level", list(LEVELS))
def test_the_presets_lie_within_the_limits(level):
    spec = MeshSpec.for_level(level, viscosity=WATER)
    spec.check_for(0.1)
    spec.with_(half_height=1.0).check_for(0.1)


@pytest.mark.parametrize("level", list(LEVELS))
def test_the_cell_estimate_matches_the_measured_counts(level):
    """Within 5 % of the counts measured on the paper's blades at Re = 1e6 (a failure means the mesher's
    size laws changed: re-measure the table in meshing.spec, then refit TRIANGLE_AREA)."""
    spec = MeshSpec.for_level(level, viscosity=WATER)
    assert spec.estimate_cells(0.1)["cells"] == pytest.approx(MEASURED[level], rel=0.05)
    narrow = spec.with_(half_height=1.0).estimate_cells(0.1)["cells"]
    assert narrow == pytest.approx(MEASURED_NARROW[level], rel=0.05)


def test_the_cell_budget_is_refused_with_the_estimate():
    spec = MeshSpec.for_level("fine", viscosity=WATER, upstream=100, downstream=100, half_height=50,
                              far_size=0.05)
    with pytest.raises(MeshSpecError, match=r"about [\d,]+ cells \([\d,]+ quads in \d+ layers of 484 rays, "
                       rf"[\d,]+ triangles\), more than the budget of {CELL_BUDGET:,}"):
        spec.check_for(0.1)


@pytest.mark.parametrize("speed,chord,viscosity,message", [
    (1e-3, 1e-3, 1e-3, "is outside [10, 1e+09]"),
    (100.0, 10.0, 1e-9, "is outside [10, 1e+09]"),
    (10.0, 0.1, 1e-3, "puts the first cell"),          # Re = 1000 at y+ = 1: 0.97 mm, the O-layer 1 cm
])
def test_reynolds_numbers_and_first_cells_the_mesh_cannot_place_are_refused(speed, chord, viscosity, message):
    spec = MeshSpec(flow_speed=speed, viscosity=viscosity, y_plus=1.0 if "first" not in message else 20.0)
    with pytest.raises(MeshSpecError, match=message.replace("[", r"\[").replace("+", r"\+")):
        spec.check_for(chord)
    assert REYNOLDS_RANGE == (10.0, 1.0e9)


def test_the_laminar_test_setting_is_accepted():
    """Re = 20, y+ = 0.05 (tests/optimizer/test_pipeline.py): the first cell is 0.76 mm, within a tenth of
    the 1 cm O-layer."""
    MeshSpec.for_level("coarse", flow_speed=0.2, viscosity=1e-3, y_plus=0.05).check_for(0.1)


@pytest.mark.slow
def test_the_estimate_matches_a_real_coarse_mesh():
    """The estimate against a mesh actually built around the Table 4 blade, within 10 %."""
    from geometry import BladeSpec, build_profile
    from geometry.examples import TABLE4_C2_DESIGN
    from meshing import build_mesh

    blade = BladeSpec.from_values(TABLE4_C2_DESIGN["mode"], TABLE4_C2_DESIGN["continuity"],
                                  TABLE4_C2_DESIGN["parameters"])
    spec = MeshSpec.for_level("coarse", viscosity=WATER, half_height=2.0, upstream=3.0)
    mesh = build_mesh(build_profile(blade), spec)
    estimate = spec.estimate_cells(0.1)
    assert estimate["layers"] == pytest.approx(mesh.info["layers"], abs=2)
    assert estimate["cells"] == pytest.approx(mesh.n_cells, rel=0.1)
