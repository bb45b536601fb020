"""Finite-volume geometry of a 2D mesh of triangles and quads: built once, read only.

Conventions (rows are entities, as in meshio):

* cells are numbered type by type in :data:`CELL_TYPES` order (all quads, then all triangles);
* faces are numbered internal first (``0 .. n_internal-1``), then boundary faces grouped by boundary
  name in the order of :attr:`FVMesh.group_names`;
* face vectors point from the owner to the neighbour (outward from the domain on boundary faces);
* the domain is 2D with unit depth: a face "area" is an edge length (m), a cell "volume" an area (m²).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Supported cell types in global-numbering order; counter-clockwise node order is required.
CELL_TYPES: tuple[str, ...] = ("quad", "triangle")
#: Edges of each cell type as local node pairs, in counter-clockwise order.
_LOCAL_EDGES = {"triangle": ((0, 1), (1, 2), (2, 0)), "quad": ((0, 1), (1, 2), (2, 3), (3, 0))}
#: Largest number of faces of one cell (quads).
MAX_FACES = 4


class MeshError(ValueError):
    """The input does not describe a valid conforming 2D mesh with fully named boundaries."""


@dataclass(frozen=True, eq=False)
class FVMesh:
    """Finite-volume geometry of a 2D mesh (metres, unit depth). Build with :func:`build_fvmesh`.

    Attributes (``nc`` cells, ``nf`` faces, ``ni`` internal faces, ``nb = nf - ni`` boundary faces)
    ----------
    points: ``(n, 2)`` node coordinates, m.
    cells: ``{"quad": (nq, 4), "triangle": (nt, 3)}`` node indices, counter-clockwise.
    faces: ``(nf, 2)`` node pairs, ordered so that the owner lies on the left of ``faces[:, 0] -> [:, 1]``.
    owner: ``(nf,)`` owner cell of each face.
    neighbour: ``(nf,)`` neighbour cell, ``-1`` on boundary faces.
    n_internal: number of internal faces ``ni``.
    sf: ``(nf, 2)`` face area vectors ``normal * length``, owner -> neighbour (outward on boundaries), m.
    normal: ``(nf, 2)`` unit normals, owner -> neighbour.
    length: ``(nf,)`` face lengths (face areas per unit depth), m.
    face_centre: ``(nf, 2)`` face mid-points, m.
    volume: ``(nc,)`` cell areas (volumes per unit depth), m².
    centroid: ``(nc, 2)`` cell centroids, m.
    d: ``(nf, 2)`` owner centroid -> neighbour centroid (boundary: -> face centre), m.
    weight: ``(nf,)`` owner interpolation weight ``w`` in ``phi_f = w phi_P + (1 - w) phi_N`` (1 on boundaries).
    diff_coeff: ``(nf,)`` ``|S|² / (d·S)`` (dimensionless), the implicit part of the over-relaxed split
        ``S = E + T`` with ``E = d |S|²/(d·S)``: a face gradient flux is
        ``grad_f·S ≈ diff_coeff (phi_N - phi_P) + grad_f·T``.
    t_vec: ``(nf, 2)`` the explicit non-orthogonal part ``T = S - E``, m.
    group_names: boundary group names, in face order.
    boundary: ``{name: (k,) face indices}`` (global face numbers, contiguous per group).
    cell_faces: ``(nc, 4)`` face indices of each cell, ``-1`` padded (triangles).
    cell_other: ``(nc, 4)`` index into ``concat(cell values (nc,), boundary-face values (nb,))`` of the
        value across each cell face (the cell itself on padding), for stencils and limiters.
    cell_r: ``(nc, 4, 2)`` cell centroid -> face centre vectors (zero on padding), m.
    ls_weights: ``(nc, 4, 2)`` least-squares gradient weights: ``grad phi_c = sum_k
        ls_weights[c, k] (phi_other[c, k] - phi_c)`` (inverse-distance-squared weighting), 1/m.
    """

    points: np.ndarray
    cells: dict[str, np.ndarray]
    faces: np.ndarray
    owner: np.ndarray
    neighbour: np.ndarray
    n_internal: int
    sf: np.ndarray
    normal: np.ndarray
    length: np.ndarray
    face_centre: np.ndarray
    volume: np.ndarray
    centroid: np.ndarray
    d: np.ndarray
    weight: np.ndarray
    diff_coeff: np.ndarray
    t_vec: np.ndarray
    group_names: tuple[str, ...]
    boundary: dict[str, np.ndarray]
    cell_faces: np.ndarray
    cell_other: np.ndarray
    cell_r: np.ndarray
    ls_weights: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def n_cells(self) -> int:
        return int(self.volume.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.owner.shape[0])

    @property
    def n_boundary(self) -> int:
        return self.n_faces - self.n_internal

    def boundary_local(self, name: str) -> np.ndarray:
        """Indices of group ``name`` into boundary-face arrays (``face - n_internal``)."""
        return self.boundary[name] - self.n_internal

    def cell_size(self) -> np.ndarray:
        """``sqrt(volume)``, a length scale per cell, m."""
        return np.sqrt(self.volume)


# --------------------------------------------------------------------------------------------- builders
def build_fvmesh(points, cells: dict, boundary: dict) -> FVMesh:
    """Build the finite-volume geometry of a 2D mesh.

    Parameters
    ----------
    points: ``(n, 2)`` (or ``(n, 3)``, z dropped) node coordinates, m.
    cells: ``{"triangle": (nt, 3), "quad": (nq, 4)}`` node indices, counter-clockwise.
    boundary: ``{name: (k, 2)}`` boundary edges as node pairs (either orientation).

    Raises :class:`MeshError` for clockwise/degenerate cells, faces shared by more than two cells, a
    boundary face in no group or in two groups, and a group edge that is not a boundary face.

    Example
    -------
    >>> m = build_fvmesh([[0, 0], [1, 0], [1, 1], [0, 1]], {"quad": [[0, 1, 2, 3]]},
    ...                  {"wall": [[0, 1], [1, 2], [2, 3], [3, 0]]})
    >>> float(m.volume.sum())
    1.0
    """
    pts = np.asarray(points, dtype=float)[:, :2].copy()
    conn = {k: np.asarray(v, dtype=np.int64).reshape(-1, len(_LOCAL_EDGES[k]))
            for k, v in cells.items() if k in CELL_TYPES and len(v)}
    unknown = set(cells) - set(CELL_TYPES)
    if unknown:
        raise MeshError(f"unsupported cell types {sorted(unknown)}; only {CELL_TYPES}")
    conn = {k: conn[k] for k in CELL_TYPES if k in conn}
    volume, centroid = _cell_geometry(pts, conn)
    if np.any(volume <= 0):
        bad = np.flatnonzero(volume <= 0)
        raise MeshError(f"{bad.size} cells are clockwise or degenerate (first: cell {bad[0]}, "
                        f"area {volume[bad[0]]:.3e} m²); cells must be counter-clockwise")
    faces, owner, neighbour, cell_faces, n_internal = _faces(pts, conn)
    faces, owner, neighbour, cell_faces, group_names, groups = _group_boundary(
        faces, owner, neighbour, cell_faces, n_internal, boundary, len(pts))
    return _assemble(pts, conn, faces, owner, neighbour, n_internal, volume, centroid, cell_faces,
                     group_names, groups)


def from_meshio(mesh, groups: dict[str, int] | None = None) -> FVMesh:
    """Build from a ``meshio.Mesh`` with gmsh physical groups: line elements carry the boundary groups.

    ``groups`` maps a name to a physical tag; by default it is read from ``mesh.field_data``
    (``{name: [tag, dim]}``, dimension-1 entries). Cells are re-oriented counter-clockwise if needed.
    """
    if groups is None:
        groups = {name: int(v[0]) for name, v in mesh.field_data.items() if int(v[1]) == 1}
    phys = mesh.cell_data.get("gmsh:physical")
    if phys is None:
        raise MeshError("mesh has no 'gmsh:physical' cell data: boundary groups cannot be named")
    cells: dict[str, list] = {}
    lines, line_tags = [], []
    for block, tags in zip(mesh.cells, phys, strict=True):
        if block.type in CELL_TYPES:
            cells.setdefault(block.type, []).append(block.data)
        elif block.type == "line":
            lines.append(block.data)
            line_tags.append(np.asarray(tags))
    pts = np.asarray(mesh.points, dtype=float)[:, :2]
    cells = {k: _ccw(pts, np.concatenate(v)) for k, v in cells.items()}
    lines = np.concatenate(lines) if lines else np.zeros((0, 2), dtype=np.int64)
    line_tags = np.concatenate(line_tags) if line_tags else np.zeros(0, dtype=int)
    boundary = {name: lines[line_tags == tag] for name, tag in groups.items() if np.any(line_tags == tag)}
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    return build_fvmesh(pts, cells, boundary) if used.size == len(pts) else _compact(pts, cells, boundary)


def from_msh(path: str | Path) -> FVMesh:
    """Read a gmsh ``.msh`` file (any version meshio reads) with named physical line groups."""
    import meshio

    return from_meshio(meshio.read(path))


def _compact(pts, cells, boundary) -> FVMesh:
    """Drop nodes used by no cell (gmsh geometry points) and renumber."""
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    new = np.full(len(pts), -1, dtype=np.int64)
    new[used] = np.arange(used.size)
    return build_fvmesh(pts[used], {k: new[v] for k, v in cells.items()},
                        {k: new[v] for k, v in boundary.items()})


def _ccw(pts: np.ndarray, conn: np.ndarray) -> np.ndarray:
    """Reverse the node order of clockwise cells."""
    conn = np.asarray(conn, dtype=np.int64)
    flip = _polygon_area_centroid(pts, conn)[0] < 0
    conn = conn.copy()
    conn[flip] = conn[flip, ::-1]
    return conn


# --------------------------------------------------------------------------------------------- geometry
def _polygon_area_centroid(pts: np.ndarray, conn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed area (m², CCW positive) and centroid (m) of polygons ``pts[conn]`` (shoelace formula)."""
    p = pts[conn]
    q = np.roll(p, -1, axis=1)
    cross = p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1]
    area = 0.5 * cross.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = ((p + q) * cross[..., None]).sum(axis=1) / (6.0 * area[:, None])
    return area, c


def _cell_geometry(pts, conn) -> tuple[np.ndarray, np.ndarray]:
    res = [_polygon_area_centroid(pts, c) for c in conn.values()]
    if not res:
        raise MeshError("mesh has no triangle or quad cells")
    return np.concatenate([r[0] for r in res]), np.concatenate([r[1] for r in res])


def _faces(pts, conn):
    """Unique edges with owner/neighbour; returns faces (internal first), owner, neighbour,
    cell_faces (nc, 4) and the number of internal faces."""
    half, cell_of, slot_of = [], [], []
    start = 0
    for k, c in conn.items():
        nc = len(c)
        for s, (a, b) in enumerate(_LOCAL_EDGES[k]):
            half.append(np.column_stack([c[:, a], c[:, b]]))
            cell_of.append(np.arange(start, start + nc))
            slot_of.append(np.full(nc, s))
        start += nc
    n_cells = start
    half = np.concatenate(half)
    cell_of = np.concatenate(cell_of)
    slot_of = np.concatenate(slot_of)
    key = np.minimum(half[:, 0], half[:, 1]) * len(pts) + np.maximum(half[:, 0], half[:, 1])
    uniq, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    if np.any(counts > 2):
        e = half[first[np.argmax(counts)]]
        raise MeshError(f"edge {e.tolist()} is shared by {counts.max()} cells (non-manifold mesh)")
    # owner = first half-edge of each unique edge; neighbour = the other one (if any)
    n_unique = uniq.size
    other = np.full(n_unique, -1, dtype=np.int64)
    second = np.setdiff1d(np.arange(half.shape[0]), first, assume_unique=True)
    other[inverse[second]] = cell_of[second]
    if np.any(half[second, 0] != half[first[inverse[second]], 1]):
        raise MeshError("neighbouring cells traverse a shared edge in the same direction "
                        "(inconsistent orientation)")
    internal = other >= 0
    order = np.concatenate([np.flatnonzero(internal), np.flatnonzero(~internal)])
    new_id = np.empty(n_unique, dtype=np.int64)
    new_id[order] = np.arange(n_unique)
    faces = half[first][order]
    owner = cell_of[first][order]
    neighbour = other[order]
    cell_faces = np.full((n_cells, MAX_FACES), -1, dtype=np.int64)
    cell_faces[cell_of, slot_of] = new_id[inverse]
    return faces, owner, neighbour, cell_faces, int(internal.sum())


def _group_boundary(faces, owner, neighbour, cell_faces, ni, boundary, n_points):
    """Sort boundary faces by group; check that every boundary face has exactly one group."""
    nb = faces.shape[0] - ni
    bkey = np.minimum(faces[ni:, 0], faces[ni:, 1]) * n_points + np.maximum(faces[ni:, 0], faces[ni:, 1])
    sorter = np.argsort(bkey)
    group_of = np.full(nb, -1, dtype=np.int64)
    names = tuple(boundary)
    for gid, name in enumerate(names):
        e = np.asarray(boundary[name], dtype=np.int64).reshape(-1, 2)
        k = np.minimum(e[:, 0], e[:, 1]) * n_points + np.maximum(e[:, 0], e[:, 1])
        pos = np.searchsorted(bkey, k, sorter=sorter)
        pos = np.clip(pos, 0, max(nb - 1, 0))
        hit = sorter[pos] if nb else pos
        ok = (bkey[hit] == k) if nb else np.zeros(len(k), bool)
        if not np.all(ok):
            bad = e[np.flatnonzero(~ok)[0]]
            raise MeshError(f"boundary group {name!r}: edge {bad.tolist()} is not a boundary face of the "
                            f"mesh ({np.count_nonzero(~ok)} such edges)")
        if np.any(group_of[hit] >= 0):
            j = hit[group_of[hit] >= 0][0]
            raise MeshError(f"boundary face {faces[ni + j].tolist()} is in groups {names[group_of[j]]!r} "
                            f"and {name!r}")
        group_of[hit] = gid
    if np.any(group_of < 0):
        j = np.flatnonzero(group_of < 0)
        raise MeshError(f"{j.size} boundary faces belong to no boundary group (first: nodes "
                        f"{faces[ni + j[0]].tolist()}); name every boundary edge")
    order = np.argsort(group_of, kind="stable")
    perm = np.concatenate([np.arange(ni), ni + order])
    new_id = np.empty_like(perm)
    new_id[perm] = np.arange(perm.size)
    cell_faces = np.where(cell_faces >= 0, new_id[np.maximum(cell_faces, 0)], -1)
    counts = np.bincount(group_of, minlength=len(names))
    bounds = ni + np.concatenate([[0], np.cumsum(counts)])
    groups = {n: np.arange(bounds[i], bounds[i + 1]) for i, n in enumerate(names) if counts[i]}
    names = tuple(n for n in names if n in groups)
    return faces[perm], owner[perm], neighbour[perm], cell_faces, names, groups


def _assemble(pts, conn, faces, owner, neighbour, ni, volume, centroid, cell_faces, names, groups):
    """Derived face and stencil geometry."""
    nc, nf = volume.size, faces.shape[0]
    edge = pts[faces[:, 1]] - pts[faces[:, 0]]
    sf = np.column_stack([edge[:, 1], -edge[:, 0]])          # owner on the left of the edge -> outward
    length = np.hypot(sf[:, 0], sf[:, 1])
    if np.any(length <= 0):
        raise MeshError("zero-length face")
    normal = sf / length[:, None]
    fc = 0.5 * (pts[faces[:, 0]] + pts[faces[:, 1]])
    xn = np.where(neighbour[:, None] >= 0, centroid[np.maximum(neighbour, 0)], fc)
    d = xn - centroid[owner]
    dn = np.einsum("ij,ij->i", d, normal)
    if np.any(dn <= 0):
        raise MeshError(f"{np.count_nonzero(dn <= 0)} faces have the neighbour centroid behind the face "
                        "(severely distorted cells)")
    weight = np.ones(nf)
    fo = np.einsum("ij,ij->i", fc[:ni] - centroid[owner[:ni]], normal[:ni])
    weight[:ni] = 1.0 - fo / dn[:ni]
    diff_coeff = length**2 / (dn * length)
    t_vec = sf - d * diff_coeff[:, None]
    # per-cell stencil tables
    pad = cell_faces < 0
    f = np.where(pad, 0, cell_faces)
    cells = np.arange(nc)[:, None]
    is_owner = owner[f] == cells
    across = np.where(is_owner, neighbour[f], owner[f])
    other = np.where(neighbour[f] < 0, nc + (f - ni), across)
    other = np.where(pad, np.broadcast_to(cells, other.shape), other)
    r = np.where(pad[..., None], 0.0, fc[f] - centroid[:, None, :])
    x_other = np.concatenate([centroid, fc[ni:]])[other]
    dx = np.where(pad[..., None], 0.0, x_other - centroid[:, None, :])
    ls = _ls_weights(dx, pad)
    return FVMesh(points=pts, cells=conn, faces=faces, owner=owner, neighbour=neighbour, n_internal=ni,
                  sf=sf, normal=normal, length=length, face_centre=fc, volume=volume, centroid=centroid,
                  d=d, weight=weight, diff_coeff=diff_coeff, t_vec=t_vec, group_names=names,
                  boundary=groups, cell_faces=cell_faces, cell_other=other, cell_r=r, ls_weights=ls)


def _ls_weights(dx: np.ndarray, pad: np.ndarray) -> np.ndarray:
    """Least-squares gradient weights ``G^-1 w dx`` per cell and stencil entry (w = 1/|dx|²)."""
    d2 = np.einsum("ckj,ckj->ck", dx, dx)
    w = np.where(pad, 0.0, 1.0 / np.where(pad, 1.0, d2))
    g = np.einsum("ck,cki,ckj->cij", w, dx, dx)
    det = g[:, 0, 0] * g[:, 1, 1] - g[:, 0, 1] * g[:, 1, 0]
    if np.any(det <= 1e-14 * np.einsum("cii->c", g) ** 2):
        raise MeshError("least-squares gradient stencil is singular for some cell (collinear stencil)")
    ginv = np.stack([np.stack([g[:, 1, 1], -g[:, 0, 1]], -1), np.stack([-g[:, 1, 0], g[:, 0, 0]], -1)], 1)
    ginv /= det[:, None, None]
    return np.einsum("cij,ck,ckj->cki", ginv, w, dx)
