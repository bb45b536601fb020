"""Finite-volume mesh geometry and gradients: invariants that hold by construction, exactness on linear
fields, boundary-group checks, the gmsh/meshio loader and the fixed sparsity pattern."""

import numpy as np
import pytest
import scipy.sparse as sp

from solver.fvmesh import MeshError, build_fvmesh, from_msh
from solver.gradient import LIMITERS, limited_gradient, ls_gradient, neighbour_bounds
from solver.linalg import FVPattern
from solver.validation.meshes import square_mesh


@pytest.fixture(scope="module", params=["checker", "right_half", "all"])
def distorted(request):
    """A skewed, non-orthogonal mixed mesh of [0, 2]² (random node displacements of 30 % of the spacing)."""
    return square_mesh(12, triangles=request.param, strength=0.4, distort=0.3, seed=3, size=2.0)


def linear(xy):
    return 1.5 + 3.0 * xy[:, 0] - 2.0 * xy[:, 1]


def test_areas_sum_to_domain(distorted):
    assert distorted.volume.min() > 0
    assert distorted.volume.sum() == pytest.approx(4.0, rel=1e-13)


def test_face_vectors_of_each_cell_sum_to_zero(distorted):
    m = distorted
    s = np.zeros((m.n_cells, 2))
    np.add.at(s, m.owner, m.sf)
    np.add.at(s, m.neighbour[:m.n_internal], -m.sf[:m.n_internal])
    assert np.abs(s).max() < 1e-14


def test_boundary_faces_outward_and_grouped(distorted):
    m = distorted
    assert m.group_names == ("bottom", "right", "top", "left")
    assert sum(len(f) for f in m.boundary.values()) == m.n_boundary
    assert np.all(m.neighbour[m.n_internal:] == -1) and np.all(m.neighbour[:m.n_internal] >= 0)
    outward = {"bottom": (0, -1), "right": (1, 0), "top": (0, 1), "left": (-1, 0)}
    for g, n in outward.items():
        assert np.allclose(m.normal[m.boundary[g]], n)
    # closed surface: boundary face vectors sum to zero; perimeter 8
    assert np.abs(m.sf[m.n_internal:].sum(axis=0)).max() < 1e-13
    assert m.length[m.n_internal:].sum() == pytest.approx(8.0)


def test_nonorthogonal_split(distorted):
    m = distorted
    e = m.sf - m.t_vec
    # E is parallel to d, T is perpendicular to S (over-relaxed split), weights in (0, 1)
    assert np.abs(e[:, 0] * m.d[:, 1] - e[:, 1] * m.d[:, 0]).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", m.t_vec, m.sf)).max() < 1e-12
    w = m.weight[:m.n_internal]
    assert w.min() > 0 and w.max() < 1


def test_linear_gradient_is_exact(distorted):
    m = distorted
    g = ls_gradient(m, linear(m.centroid), linear(m.face_centre[m.n_internal:]))
    assert np.abs(g - [3.0, -2.0]).max() < 1e-11
    # vector fields: grad[c, component, direction]
    u = np.column_stack([linear(m.centroid), 2 * m.centroid[:, 0]])
    ub = np.column_stack([linear(m.face_centre[m.n_internal:]), 2 * m.face_centre[m.n_internal:, 0]])
    gu = ls_gradient(m, u, ub)
    assert np.abs(gu - [[3.0, -2.0], [2.0, 0.0]]).max() < 1e-11


@pytest.mark.parametrize("limiter", sorted(LIMITERS))
def test_limiters_bound_face_values(distorted, limiter):
    m = distorted
    rng = np.random.default_rng(0)
    phi = np.sin(3 * m.centroid[:, 0]) + 0.3 * rng.standard_normal(m.n_cells)   # rough field
    phib = np.sin(3 * m.face_centre[m.n_internal:, 0])
    g = limited_gradient(m, phi, phib, limiter=limiter, k=1e-3)    # Venkatakrishnan: eps -> 0
    if limiter == "none":
        assert np.allclose(g, ls_gradient(m, phi, phib))
        return
    face = phi[:, None] + np.einsum("cki,ci->ck", m.cell_r, g)
    hi, lo = neighbour_bounds(m, phi, phib)
    slack = 1e-9
    assert np.all(face <= hi[:, None] + slack) and np.all(face >= lo[:, None] - slack)


def test_limiter_keeps_linear_field_in_smooth_interior():
    m = square_mesh(12, triangles="none")
    phi = linear(m.centroid)
    g = limited_gradient(m, phi, linear(m.face_centre[m.n_internal:]), limiter="barth_jespersen")
    assert np.allclose(g, [3.0, -2.0])


def test_unit_square_doctest_values():
    m = build_fvmesh([[0, 0], [1, 0], [1, 1], [0, 1]], {"quad": [[0, 1, 2, 3]]},
                     {"wall": [[0, 1], [1, 2], [2, 3], [3, 0]]})
    assert m.n_cells == 1 and m.n_internal == 0 and m.centroid.tolist() == [[0.5, 0.5]]


def test_unnamed_boundary_face_is_an_error():
    with pytest.raises(MeshError, match="belong to no boundary group"):
        build_fvmesh([[0, 0], [1, 0], [1, 1], [0, 1]], {"triangle": [[0, 1, 2], [0, 2, 3]]},
                     {"wall": [[0, 1], [1, 2], [2, 3]]})


def test_group_edge_that_is_not_a_boundary_face_is_an_error():
    with pytest.raises(MeshError, match="'cut'.*not a boundary face"):
        build_fvmesh([[0, 0], [1, 0], [1, 1], [0, 1]], {"triangle": [[0, 1, 2], [0, 2, 3]]},
                     {"wall": [[0, 1], [1, 2], [2, 3], [3, 0]], "cut": [[0, 2]]})


def test_clockwise_cells_are_an_error():
    with pytest.raises(MeshError, match="clockwise"):
        build_fvmesh([[0, 0], [1, 0], [1, 1]], {"triangle": [[0, 2, 1]]}, {"w": [[0, 1], [1, 2], [2, 0]]})


def test_pattern_matches_coo_assembly(distorted):
    m = distorted
    pat = FVPattern.from_mesh(m)
    rng = np.random.default_rng(1)
    d, up, lo = rng.random(m.n_cells), rng.random(m.n_internal), rng.random(m.n_internal)
    o, n = m.owner[:m.n_internal], m.neighbour[:m.n_internal]
    ref = sp.coo_matrix((np.concatenate([d, up, lo]),
                         (np.concatenate([np.arange(m.n_cells), o, n]),
                          np.concatenate([np.arange(m.n_cells), n, o])))).toarray()
    assert np.array_equal(pat.matrix(d, up, lo).toarray(), ref)


def test_msh_roundtrip(tmp_path):
    """A gmsh 2.2 file written with physical line groups loads with the same geometry and groups
    (cells are reordered quads first, then triangles, as in meshing.Mesh2D)."""
    import meshio

    m = square_mesh(6, triangles="checker", distort=0.2)
    pts = np.column_stack([m.points, np.zeros(len(m.points))])
    names = m.group_names
    blocks = [("quad", m.cells["quad"]), ("triangle", m.cells["triangle"])]
    phys = [np.full(len(m.cells["quad"]), 10), np.full(len(m.cells["triangle"]), 10)]
    for gid, g in enumerate(names, start=1):
        blocks.append(("line", m.faces[m.boundary[g]]))
        phys.append(np.full(len(m.boundary[g]), gid))
    fd = {g: np.array([gid, 1]) for gid, g in enumerate(names, start=1)}
    fd["fluid"] = np.array([10, 2])
    path = tmp_path / "sq.msh"
    meshio.Mesh(pts, blocks, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys},
                field_data=fd).write(path, file_format="gmsh22", binary=False)
    r = from_msh(path)
    assert set(r.group_names) == set(names)
    assert r.n_cells == m.n_cells and r.n_internal == m.n_internal
    assert np.allclose(np.sort(r.volume), np.sort(m.volume))
    for g in names:
        assert r.length[r.boundary[g]].sum() == pytest.approx(1.0)


def test_gmsh_mixed_mesh_gradient_exact():
    from solver.validation.meshes import gmsh_square

    m = gmsh_square(0.1, quads="left_half")
    assert set(m.cells) == {"quad", "triangle"}
    assert m.volume.sum() == pytest.approx(1.0, rel=1e-12)
    g = ls_gradient(m, linear(m.centroid), linear(m.face_centre[m.n_internal:]))
    assert np.abs(g - [3.0, -2.0]).max() < 1e-10


def test_green_gauss_gradient_exact_for_linear(distorted):
    """The Green–Gauss gradient on skewness-corrected face values is exact for a linear field."""
    from solver.gradient import green_gauss_gradient

    m = distorted
    phi, phib = linear(m.centroid), linear(m.face_centre[m.n_internal:])
    g = green_gauss_gradient(m, phi, phib, ls_gradient(m, phi, phib))
    assert np.abs(g - [3.0, -2.0]).max() < 1e-10
