"""solver.validation.openfoam: the polyMesh written from a finite-volume mesh, and the field-file reader.

No OpenFOAM needed: the checks are the invariants OpenFOAM's checkMesh tests (upper-triangular order,
owner < neighbour, every closed cell's face vectors summing to zero with normals from owner to neighbour)
and that boundary face i of a patch is face i of the millfoil group (the side-by-side compares per face).
"""

from __future__ import annotations

import numpy as np

from solver.validation.meshes.naca_mesh import CMeshSpec, naca0012_cmesh
from solver.validation.openfoam import (
    field_body,
    nonuniform_vectors,
    polymesh_arrays,
    read_field,
    write_file,
    write_polymesh,
)

SPEC = CMeshSpec(n_side=16, n_wake=8, ds_le=1e-2, ds_te=2e-2, first_cell=5e-3, growth=1.2, switch=0.02,
                 far_growth=1.5, radius=20.0)


def _mesh():
    return naca0012_cmesh(SPEC, alpha_deg=10.0).mesh


def _face_vectors(points, faces):
    """Area vectors of planar polygons (Newell's formula), (nf, 3)."""
    out = np.zeros((len(faces), 3))
    for i, f in enumerate(faces):
        p = points[f]
        q = np.roll(p, -1, axis=0)
        out[i] = 0.5 * np.cross(p, q).sum(axis=0)
    return out


def test_polymesh_order_orientation_and_closure():
    m = _mesh()
    a = polymesh_arrays(m)
    ni = m.n_internal
    own, nei = a["owner"], a["neighbour"]
    assert len(nei) == ni and np.all(own[:ni] < nei)
    assert np.all(np.diff(own[:ni]) >= 0)                                   # sorted by owner ...
    same = own[1:ni] == own[:ni - 1]
    assert np.all(np.diff(nei)[same] > 0)                                   # ... then by neighbour
    sf = _face_vectors(a["points"], a["faces"])
    centre = np.array([a["points"][f].mean(axis=0) for f in a["faces"]])
    cell_centre = np.column_stack([m.centroid, np.full(m.n_cells, 0.005)])
    # normals point from the owner's centre out through the face
    assert np.all(np.einsum("ij,ij->i", sf, centre - cell_centre[own]) > 0)
    net = np.zeros((m.n_cells, 3))
    np.add.at(net, own, sf)
    np.add.at(net, nei, -sf[:ni])
    assert np.abs(net).max() < 1e-12 * np.abs(sf).max() * 10


def test_patch_faces_follow_the_group_order():
    m = _mesh()
    a = polymesh_arrays(m)
    for group, n, start in a["patches"]:
        assert n == len(m.boundary[group])
        xy = np.array([a["points"][f][:2, :2].mean(axis=0) for f in a["faces"][start:start + n]])
        assert np.allclose(xy, m.face_centre[m.boundary[group]], atol=1e-12)
    assert len(a["faces"]) == a["patches"][-1][2] + a["patches"][-1][1] + 2 * m.n_cells


def test_write_polymesh_boundary_file(tmp_path):
    m = _mesh()
    write_polymesh(m, tmp_path, {"wall": "wall"})
    text = (tmp_path / "constant/polyMesh/boundary").read_text()
    assert "wall\n    {\n        type wall;" in text and "frontAndBack" in text and "type empty;" in text
    assert f"nCells: {m.n_cells}" in (tmp_path / "constant/polyMesh/owner").read_text()


def test_read_field_round_trip(tmp_path):
    u = np.array([[1.0, 2.0], [3.0, -4.5], [0.0, 1e-9]])
    body = field_body("[0 1 -1 0 0 0 0]", "(0 0 0)", {"wall": "type noSlip;"},
                      "    inlet { type fixedValue; value uniform (1 0 0); }\n")
    body = body.replace("internalField uniform (0 0 0)", "internalField " + nonuniform_vectors(u))
    write_file(tmp_path, "0/U", "volVectorField", body)
    internal, patches = read_field(tmp_path / "0/U", 3)
    assert np.allclose(internal[:, :2], u) and np.allclose(internal[:, 2], 0)
    assert np.allclose(patches["inlet"], [[1, 0, 0]]) and "wall" not in patches
    write_file(tmp_path, "0/p", "volScalarField", field_body("[0 2 -2 0 0 0 0]", "0.25", {}))
    p, _ = read_field(tmp_path / "0/p", 4)
    assert np.allclose(p, 0.25) and p.shape == (4,)


def test_read_face_flux_maps_faces_and_signs(tmp_path):
    from solver.validation.openfoam import DEPTH, face_order, read_face_flux

    m = _mesh()
    flux = np.arange(len(m.owner), dtype=float) - 7.5          # millfoil mass flux per unit depth, rho = 2
    faces, sign = face_order(m)
    ni = m.n_internal
    of_internal = sign[:ni] * flux[faces[:ni]] / 2.0 * DEPTH     # OpenFOAM's volumetric flux, its orientation
    lines = "\n".join(f"{v:.17g}" for v in of_internal)
    patches = "".join(f"    {g}\n    {{\n        type calculated;\n        value nonuniform List<scalar> "
                      f"{len(m.boundary[g])}\n(\n" + "\n".join(f"{v:.17g}" for v in flux[m.boundary[g]] / 2.0 * DEPTH)
                      + "\n)\n;\n    }\n" for g in m.group_names)
    body = (f"dimensions [0 3 -1 0 0 0 0];\ninternalField nonuniform List<scalar> {ni}\n(\n{lines}\n)\n;\n"
            f"boundaryField\n{{\n{patches}    frontAndBack {{ type empty; value nonuniform List<scalar> 0(); }}\n}}\n")
    write_file(tmp_path, "1/phi", "surfaceScalarField", body)
    assert np.allclose(read_face_flux(tmp_path / "1/phi", m, rho=2.0), flux, rtol=1e-14, atol=1e-12)
    # owner < neighbour in OpenFOAM's numbering: the faces whose sign flips are exactly the swapped ones
    assert np.array_equal(sign[:ni] < 0, m.owner[faces[:ni]] > m.neighbour[faces[:ni]])
