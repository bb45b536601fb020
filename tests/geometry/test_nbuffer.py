"""N-buffer machining simulation against the exact envelope (tests/geometry/envelope.py)."""

import numpy as np
import pytest
import shapely
from envelope import exact_machined, hausdorff

from geometry import BezierCurve, BladeSpec, ParameterSpace, blade_curves, build_profile, evaluate_blade, machine
from geometry.blade import tool_path_pieces
from geometry.examples import TABLE5_G1_TOOLPATH
from geometry.feasibility import minimum_curvature_radius

TOLERANCE = 1e-6  # m, the default: machined profile within 1 µm of the exact envelope
R = 5e-3


def polygon_path(vertices):
    """A closed path of straight segments through ``vertices`` (counter-clockwise)."""
    v = np.asarray(vertices, float)
    return [BezierCurve([v[i], v[(i + 1) % len(v)]]) for i in range(len(v))]


def table5():
    return BladeSpec.from_values(TABLE5_G1_TOOLPATH["mode"], TABLE5_G1_TOOLPATH["continuity"],
                                 TABLE5_G1_TOOLPATH["parameters"])


def test_table5_within_one_micrometre():
    profile = build_profile(table5())
    exact = exact_machined(tool_path_pieces(profile.curves), R)
    assert exact.geom_type == "Polygon"
    assert hausdorff(profile.points, exact) <= TOLERANCE


def feasible_tool_paths(count_per_class, seed=2013):
    """Seeded random tool paths from Table 6 that pass Eq. 21 and Eq. 22, over all continuity classes."""
    rng = np.random.default_rng(seed)
    found = []
    for continuity in ["G0", "G1", "C1", "G2", "C2"]:
        space = ParameterSpace.default("toolpath", continuity)
        kept = 0
        while kept < count_per_class:
            spec = space.spec(space.sample(1, rng)[0])
            if not spec["beta1"] <= spec["alpha"] <= spec["beta1bar"]:
                continue
            curves = blade_curves(spec)
            if min(minimum_curvature_radius(curves.suction)[0], minimum_curvature_radius(curves.pressure)[0]) < R:
                continue
            found.append(spec)
            kept += 1
    return found


def test_fifty_random_feasible_tool_paths_within_one_micrometre():
    worst = 0.0
    for spec in feasible_tool_paths(10):
        exact = exact_machined(tool_path_pieces(blade_curves(spec)), R)
        result = evaluate_blade(spec)
        if exact.geom_type != "Polygon":  # the cutter cuts the blade in two: must be reported, not meshed
            assert not result.feasible and result.profile is None
            continue
        assert result.profile is not None, [c.reason for c in result.violations]
        worst = max(worst, hausdorff(result.profile.points, exact))
    assert worst <= TOLERANCE


def test_global_interference_at_convex_corners_and_a_concave_corner():
    """An L-shaped path: at its convex corners the neighbouring cutter positions gouge each other's
    local offset (global interference); at the concave corner the cutter leaves an arc."""
    pieces = polygon_path([[0, 0], [0.04, 0], [0.04, 0.015], [0.015, 0.015], [0.015, 0.04], [0, 0.04]])
    result = machine(pieces, R)
    exact = exact_machined(pieces, R)
    assert hausdorff(result.points, exact) <= TOLERANCE
    assert result.gouged_fraction > 0.05 and not result.split
    # The local offset alone (every own tip kept) would be wrong by millimetres at the corners.
    naive = np.vstack([p.points(np.linspace(0, 1, 50)) + R * np.array([[-d[1], d[0]]]) / np.linalg.norm(d)
                       for p in pieces for d in [p.end - p.start]])
    assert shapely.distance(shapely.points(naive), exact.exterior).max() > 1e-3


def test_curved_path_gouging_itself():
    """A C-shaped path whose arms pass close to each other: the cutter on one arm gouges the other."""
    t = np.linspace(0.3, 2 * np.pi - 0.3, 9)
    outer = np.stack([0.03 * np.cos(t), 0.03 * np.sin(t)], 1)
    inner = np.stack([0.017 * np.cos(t[::-1]), 0.017 * np.sin(t[::-1])], 1)
    pieces = polygon_path(np.vstack([outer, inner]))
    exact = exact_machined(pieces, R)
    result = machine(pieces, R)
    assert exact.geom_type == "Polygon" and not result.split
    assert hausdorff(result.points, exact) <= TOLERANCE


def test_split_and_vanished_parts_are_reported():
    dumbbell = polygon_path([[0, 0], [0.03, 0], [0.03, 0.012], [0.05, 0.012], [0.05, 0], [0.08, 0],
                             [0.08, 0.03], [0.05, 0.03], [0.05, 0.018], [0.03, 0.018], [0.03, 0.03], [0, 0.03]])
    assert exact_machined(dumbbell, R).geom_type == "MultiPolygon"  # the 6 mm neck is narrower than 2R
    assert machine(dumbbell, R).split
    sliver = polygon_path([[0, 0], [0.05, 0], [0.05, 0.008], [0, 0.008]])  # thinner than 2R everywhere
    assert machine(sliver, R).points.shape[0] == 0


def test_eq22_flags_a_path_tighter_than_the_cutter():
    spec = table5().with_values(d_s1=0.006, d_p1=0.006)  # a sharp leading edge for the cutter path
    result = evaluate_blade(spec)
    eq22 = next(c for c in result.constraints if c.name == "eq22_curvature")
    assert eq22.value > 0 and not result.feasible
    assert "< R = 5 mm" in eq22.reason
    radius, _ = minimum_curvature_radius(blade_curves(spec).suction)
    assert eq22.value == pytest.approx(1 - min(radius, minimum_curvature_radius(blade_curves(spec).pressure)[0]) / R)


def test_the_envelope_check_can_fail():
    """A profile shifted by 2 µm along its normals must exceed the 1 µm bound."""
    profile = build_profile(table5())
    exact = exact_machined(tool_path_pieces(profile.curves), R)
    p = profile.points
    tangent = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], 1) / np.linalg.norm(tangent, axis=1)[:, None]
    assert hausdorff(p + 2e-6 * normal, exact) > TOLERANCE
