"""Hybrid mesh around a blade: boundary groups, conservation of area, levels, quality, determinism."""

import numpy as np
import pytest

from geometry import BladeSpec, ParameterSpace, Profile, blade_curves, build_profile, evaluate_blade, machine
from geometry.blade import tool_path_pieces
from geometry.examples import TABLE4_C2_DESIGN, TABLE5_G1_TOOLPATH
from meshing import (
    BOUNDARY_GROUPS,
    Mesh2D,
    MeshingError,
    MeshQualityError,
    MeshSpec,
    build_mesh,
    cell_quality,
    check_quality,
    domain_box,
    first_cell_height,
    interior_faces,
    plot_mesh,
)

COARSE = MeshSpec.for_level("coarse")


def profile_of(example):
    return build_profile(BladeSpec.from_values(example["mode"], example["continuity"], example["parameters"]))


@pytest.fixture(scope="module", params=[TABLE4_C2_DESIGN, pytest.param(TABLE5_G1_TOOLPATH, marks=pytest.mark.slow)],
                ids=["table4_design", "table5_toolpath"])  # one coarse mesh (~3 s) in the fast tier
def case(request):
    profile = profile_of(request.param)
    return profile, build_mesh(profile, COARSE)


def boundary_loops(edges: np.ndarray) -> list[list[int]]:
    """Chain directed edges into closed loops; fails if a node does not have one edge in and one out."""
    nxt = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist(), strict=True))
    assert len(nxt) == len(edges), "a node starts two boundary edges"
    assert sorted(nxt) == sorted(edges[:, 1].tolist()), "a boundary node lacks an incoming or outgoing edge"
    loops, seen = [], set()
    for start in nxt:
        if start in seen:
            continue
        loop, node = [], start
        while node not in seen:
            seen.add(node)
            loop.append(node)
            node = nxt[node]
        assert node == start, "open boundary chain"
        loops.append(loop)
    return loops


def test_groups_present_and_boundary_loops_closed(case):
    _, mesh = case
    assert set(mesh.boundary) == set(BOUNDARY_GROUPS)
    assert all(len(mesh.boundary[g]) > 0 for g in BOUNDARY_GROUPS)
    loops = boundary_loops(np.vstack([mesh.boundary[g] for g in BOUNDARY_GROUPS]))
    assert len(loops) == 2  # the rectangle and the blade
    blade_nodes = set(mesh.boundary["blade"].ravel().tolist())
    assert sum(set(loop) == blade_nodes for loop in loops) == 1
    # Fluid on the left: the rectangle runs counter-clockwise, the blade clockwise.
    outer = sum(mesh.boundary_area(g) for g in ("inlet", "outlet", "top", "bottom"))
    assert outer > 0 and mesh.boundary_area("blade") < 0
    # The named edges are exactly the faces owned by a single cell.
    _, _, free = interior_faces(mesh)
    named = np.sort(np.vstack([mesh.boundary[g] for g in BOUNDARY_GROUPS]), axis=1)
    assert {tuple(e) for e in free.tolist()} == {tuple(e) for e in named.tolist()}


def test_boundary_sides_lie_on_the_rectangle(case):
    profile, mesh = case
    x0, x1, y0, y1 = domain_box(profile, COARSE)
    np.testing.assert_allclose(mesh.points[mesh.boundary["inlet"].ravel(), 0], x0, atol=1e-12)
    np.testing.assert_allclose(mesh.points[mesh.boundary["outlet"].ravel(), 0], x1, atol=1e-12)
    np.testing.assert_allclose(mesh.points[mesh.boundary["bottom"].ravel(), 1], y0, atol=1e-12)
    np.testing.assert_allclose(mesh.points[mesh.boundary["top"].ravel(), 1], y1, atol=1e-12)


def test_cell_area_is_domain_minus_blade(case):
    profile, mesh = case
    x0, x1, y0, y1 = domain_box(profile, COARSE)
    domain = (x1 - x0) * (y1 - y0)
    blade = -mesh.boundary_area("blade")  # the meshed wall polygon
    assert mesh.total_area() == pytest.approx(domain - blade, rel=1e-9)
    assert blade == pytest.approx(profile.area, rel=5e-3)  # wall nodes resample the profile
    assert all((a > 0).all() for a in mesh.cell_areas().values())  # counter-clockwise, none inverted


def test_wall_nodes_lie_on_the_profile_and_keep_its_corners(case):
    import shapely

    profile, mesh = case
    wall = mesh.points[np.unique(mesh.boundary["blade"])]
    ring = shapely.LinearRing(profile.points)
    assert np.max(shapely.distance(ring, shapely.points(wall))) < 1e-9
    for corner in (profile.points[0], profile.points[profile.te_index]):
        assert np.min(np.linalg.norm(wall - corner, axis=1)) < 1e-12


def test_first_cell_height_and_growth(case):
    profile, mesh = case
    h0 = COARSE.first_cell_height(profile.chord)
    assert h0 == pytest.approx(2.3e-6, rel=0.05)  # water, 10 m/s, 0.1 m chord, y+ = 1
    assert first_cell_height(2.0, 10.0, 0.1, 1e-6) == pytest.approx(2 * h0)
    assert mesh.info["first_cell_height"] == h0
    assert mesh.info["growth_max"] <= COARSE.growth + 1e-9
    # The first layer: nodes one h0 away from their wall node along the wall normal.
    blade = np.unique(mesh.boundary["blade"])
    quads = mesh.cells["quad"]
    at_wall = np.isin(quads[:, 0], blade) & ~np.isin(quads[:, 1], blade)
    h = np.linalg.norm(mesh.points[quads[at_wall, 1]] - mesh.points[quads[at_wall, 0]], axis=1)
    np.testing.assert_allclose(h, h0, rtol=1e-6)


def test_quality_within_thresholds(case):
    _, mesh = case
    report = check_quality(mesh)
    summary = report.summary()
    assert summary["min_angle_min"] > 15.0 and summary["scaled_jacobian_min"] > 0.4
    assert summary["non_orthogonality_max"] < 70.0
    assert len(report.min_angle) == mesh.n_cells


def test_bad_cells_raise_naming_the_worst():
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [5.0, 0.5], [3.0, 2.0]])  # tri 0: 14°
    cells = {"quad": np.array([[0, 1, 2, 3]]), "triangle": np.array([[1, 4, 2], [4, 5, 2]])}
    mesh = Mesh2D(points, cells, {})
    report = cell_quality(mesh)
    np.testing.assert_allclose(report.scaled_jacobian[0], 1.0)
    with pytest.raises(MeshQualityError, match="triangle 0") as err:
        check_quality(mesh)
    assert err.value.worst[0] == 1  # global cell numbering: quads first, then triangles
    check_quality(mesh, min_angle=10.0, min_jacobian=0.2)  # a looser threshold lets it pass


def test_perturbed_mesh_raises(case):
    _, mesh = case
    quad = mesh.cells["quad"][len(mesh.cells["quad"]) // 2]
    points = mesh.points.copy()
    points[quad[2]] = points[quad[0]] + 0.1 * (points[quad[2]] - points[quad[0]])  # fold one cell
    bad = Mesh2D(points, mesh.cells, mesh.boundary)
    with pytest.raises(MeshQualityError, match="below the quality thresholds"):
        check_quality(bad)


@pytest.mark.slow
def test_deterministic():
    profile = profile_of(TABLE5_G1_TOOLPATH)
    a, b = build_mesh(profile, COARSE), build_mesh(profile, COARSE)
    assert np.array_equal(a.points, b.points)
    for key in a.cells:
        assert np.array_equal(a.cells[key], b.cells[key])
    for key in a.boundary:
        assert np.array_equal(a.boundary[key], b.boundary[key])


@pytest.mark.slow
def test_cell_count_grows_with_level():
    profile = profile_of(TABLE4_C2_DESIGN)
    counts = [build_mesh(profile, MeshSpec.for_level(level)).n_cells for level in ("coarse", "medium", "fine")]
    assert counts[0] < counts[1] < counts[2]
    assert 3_000 < counts[0] < 10_000 and 12_000 < counts[1] < 30_000 and 50_000 < counts[2] < 120_000


@pytest.mark.slow
@pytest.mark.parametrize("mode,continuity", [("design", "G1"), ("toolpath", "G0"), ("toolpath", "C2")])
def test_random_feasible_blades_mesh_within_thresholds(mode, continuity):
    space = ParameterSpace.default(mode, continuity)
    meshed = 0
    for x in space.sample(40, np.random.default_rng(3)):
        result = evaluate_blade(space.spec(x))
        if not result.feasible:
            continue
        check_quality(build_mesh(result.profile, COARSE))
        meshed += 1
        if meshed == 2:
            break
    assert meshed == 2


def test_write_msh_and_vtu(case, tmp_path):
    import meshio

    _, mesh = case
    for name in ("mesh.msh", "mesh.vtu"):
        mesh.write(tmp_path / name)
        back = meshio.read(tmp_path / name)
        assert len(back.points) == mesh.n_points
        counts = {}
        for block in back.cells:
            counts[block.type] = counts.get(block.type, 0) + len(block.data)
        assert counts["quad"] == len(mesh.cells["quad"]) and counts["triangle"] == len(mesh.cells["triangle"])
        assert counts["line"] == sum(len(e) for e in mesh.boundary.values())


@pytest.mark.slow
def test_plot_zooms_on_the_edges(case, tmp_path):
    profile, mesh = case
    plot_mesh(mesh, tmp_path / "mesh.png", profile)
    assert (tmp_path / "mesh.png").stat().st_size > 10_000


def test_spec_validation():
    with pytest.raises(ValueError, match="growth"):
        MeshSpec(growth=1.3)
    with pytest.raises(ValueError, match="unknown mesh level"):
        MeshSpec.for_level("huge")
    assert MeshSpec.for_level("fine", y_plus=2.0).y_plus == 2.0


@pytest.mark.slow
def test_sharp_leading_edge_fan_rays_turn_smoothly():
    """A ~10° wedge (``bench/bench_robustness.py`` sweep): the fan's last ray turns smoothly where its straight
    part meets the field line (a kink of ~65° there makes a quad with scaled Jacobian 0.395 at medium). The
    wedge is where the cutter of this G0 tool path cuts through the blade: the machined part is two pieces (a
    split blade, infeasible since a machined G0 tool path), and the wedge is the tip of the rear piece, meshed
    here as an outline of its own."""
    values = {"L": 0.1, "alpha": -2.3450748970232063, "beta1": -3.3346406298029905,
              "beta1bar": 34.904135393777345, "u_s1": 0.05545520146762559, "u_s2": 0.30621013205189723,
              "d_s1": 0.009516768934614029, "d_s2": 0.006545306812336067, "d_s3": 0.03190649602985245,
              "d_s4": 0.002, "u_p1": 0.04439536366390561, "u_p2": 0.21296242246079378,
              "d_p1": 0.010617559734537256, "d_p2": 0.005938933901197068, "d_p3": 0.042361935166918344,
              "d_p4": 0.002, "R": 0.005}
    curves = blade_curves(BladeSpec.from_values("toolpath", "G0", values))
    rear = machine(tool_path_pieces(curves), curves.radius)
    assert rear.split and rear.pieces == 2
    le, te = int(np.argmin(rear.points[:, 0])), int(np.argmin(np.abs(rear.sigma - 2.0)))
    profile = Profile(rear.points, le, te, curves)  # the rear piece, from its pressure trailing-edge corner
    mesh = build_mesh(profile, MeshSpec.for_level("medium"))
    report = check_quality(mesh)
    quads = report.cell_type == "quad"
    assert report.scaled_jacobian[quads].min() > 0.6 and report.min_angle[quads].min() > 40.0


BENCH_G1_DESIGN = {"L": 0.1, "alpha": 9.013, "beta1": -0.179, "beta1bar": 27.983, "u_s2": 0.23291,
                   "u_p2": 0.32049, "d_s1": 0.00674, "d_p1": 0.00767, "d_s2": 0.00721, "d_p2": 0.01319,
                   "d_s3": 0.02225, "d_p3": 0.03083, "d_s4": 0.002, "d_p4": 0.002}


@pytest.mark.slow
@pytest.mark.parametrize("half_height", [0.6, 1.0])
def test_narrow_channel_passes_quality(half_height):
    """configs/examples/bench_g1_design.yaml (half_height 1): the top and bottom walls follow the graded size
    field, which asks for cells a few times smaller there than the far-field size (one chord at coarse).
    Meshed at the far-field size, the wall's coarse front meets the ring's fine one in triangles of scaled
    Jacobian 0.31-0.39 (0.03 at half_height 0.6)."""
    profile = build_profile(BladeSpec.from_values("design", "G1", BENCH_G1_DESIGN))
    spec = MeshSpec.for_level("coarse", half_height=half_height)
    mesh = build_mesh(profile, spec)
    summary = check_quality(mesh).summary()
    assert summary["min_angle_min"] > 25.0 and summary["scaled_jacobian_min"] > 0.5
    # The walls are graded: fine next to the O-layer, never coarser than a quarter of the channel height.
    x0, x1, y0, y1 = domain_box(profile, spec)
    top = mesh.points[mesh.boundary["top"]]
    assert np.all(top[:, :, 1] == y1)
    lengths = np.linalg.norm(top[:, 1] - top[:, 0], axis=1)
    assert lengths.max() <= 0.25 * (y1 - y0) * 1.05 and lengths.min() < 0.5 * lengths.max()


@pytest.mark.slow
def test_domain_too_narrow_for_the_o_layer_raises():
    profile = build_profile(BladeSpec.from_values("design", "G1", BENCH_G1_DESIGN))
    with pytest.raises(MeshingError, match="does not contain the O-layer"):
        build_mesh(profile, MeshSpec.for_level("coarse", half_height=0.2))


def test_small_leading_edge_radius_keeps_the_trailing_edge_resolved():
    """A tool-path blade whose leading-edge radius (~0.2 mm) asks for more than the coarse level's 80 wall
    nodes by itself (``bench/bench_robustness.py``, random blade 17): without the cap on the largest spacing
    (``MAX_SPACING_RATIO``) it, and with it the corner spacing, goes to its bisection bound, leaving the 4 mm
    blunt trailing edge one face wide (the solve then diverges from the free stream within 6 iterations). The
    cap keeps the corners refined."""
    from meshing.hybrid import MAX_SPACING_RATIO, resample_wall

    values = {"L": 0.1, "alpha": -3.4080443890744947, "beta1": -5.528279231195464, "beta1bar": 4.241415410124693,
              "u_s2": 0.07934284503700965, "d_s1": 0.010817313870633623, "d_s2": 0.009609143599030303,
              "d_s3": 0.031140582360566573, "d_s4": 0.002, "u_p2": 0.10499310014391451,
              "d_p2": 0.011404291734741525, "d_p3": 0.03003746312494445, "d_p4": 0.002, "R": 0.005}
    profile = build_profile(BladeSpec.from_values("toolpath", "C1", values))
    nodes, _ = resample_wall(profile, COARSE)
    closed = np.vstack([nodes, nodes[:1]])
    h = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    perimeter = h.sum()
    te = profile.points[[profile.te_index, 0]]
    edge = te[1] - te[0]
    on_te = np.array([abs(edge[0] * (p - te[0])[1] - edge[1] * (p - te[0])[0]) / np.linalg.norm(edge) < 1e-9
                      and np.dot(p - te[0], te[1] - te[0]) > 1e-12
                      and np.dot(p - te[1], te[0] - te[1]) > 1e-12 for p in nodes])
    assert on_te.sum() >= 2                                  # 3 faces or more across the trailing edge
    assert len(nodes) > COARSE.wall_nodes                    # the curvature takes more than the budget
    assert h.max() <= 1.01 * MAX_SPACING_RATIO * perimeter / COARSE.wall_nodes


#: A feasible G1 design (found by a coarse campaign) whose trailing edge is thinner than the coarse wall
#: spacing: its resampled wall crosses itself near x = 0.070 m, and gmsh's frontal mesher never returned on it.
THIN_TRAILING_EDGE = {"L": 0.1, "alpha": 4.324181313802892, "beta1": -19.377530187285583,
                      "beta1bar": 49.745075061897836, "u_s2": 0.15928271548094095, "d_s1": 0.005605507739512727,
                      "d_s2": 0.010579452559881328, "d_s3": 0.034839169382184176, "d_s4": 0.002,
                      "u_p2": 0.34889523921464277, "d_p1": 0.005016744475424478, "d_p2": 0.0050148036625023255,
                      "d_p3": 0.04989654543045035, "d_p4": 0.002}

SUBPROCESS_MESH = """
import sys
from geometry import BladeSpec, build_profile
from meshing import MeshingError, MeshSpec, build_mesh
from tests.meshing.test_meshing import THIN_TRAILING_EDGE
profile = build_profile(BladeSpec.from_values("design", "G1", THIN_TRAILING_EDGE))
try:
    build_mesh(profile, MeshSpec.for_level(sys.argv[1]))
    print("meshed")
except MeshingError as exc:
    print("MeshingError:", exc)
"""


@pytest.mark.parametrize("level,outcome", [("coarse", "MeshingError: the blade wall resampled for this mesh level"),
                                           pytest.param("medium", "meshed", marks=pytest.mark.slow)])
@pytest.mark.slow
def test_a_wall_that_resamples_into_a_crossing_polygon_fails_at_once(level, outcome):
    """Refused with the place where it crosses, in about a second, instead of hanging the worker until the
    campaign's timeout; the finer level, whose spacing resolves the thin edge, meshes it."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", SUBPROCESS_MESH, level], capture_output=True, text=True, timeout=120,
                          cwd=root, env={**os.environ, "PYTHONPATH": str(root)})
    assert done.stdout.startswith(outcome), done
    if level == "coarse":
        assert "crosses itself at x = 0.07014 m, y = -0.01016 m" in done.stdout
