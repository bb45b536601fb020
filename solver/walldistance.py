"""Exact distance from points (cell centroids) to the wall faces of a mesh, vectorised.

The walls are the boundary faces of the groups whose condition is ``wall`` / ``no_slip_wall`` /
``moving_wall`` (:data:`WALL_TYPES`); each face is a straight segment. The distance of a point to the wall
is the minimum over all wall segments of the exact point-segment distance. To avoid the
``points x segments`` product, candidate segments come from a k-d tree of points sampled along every
segment (:func:`wall_distance`): the ``k`` nearest samples of each query point name the candidate
segments, and the exact distance is taken over those only. With ``samples`` points per segment
(end points included) the nearest segment is always among the candidates unless ``k`` samples of other
segments are closer than the nearest segment's nearest sample; ``k = 16`` with 5 samples per segment
covers every mesh we use (checked against brute force in ``tests/test_solver_turbulence.py``). Below
:data:`BRUTE_FORCE_PAIRS` point-segment pairs every segment is taken (a compiled loop, faster than the tree
there).
"""

from __future__ import annotations

import numpy as np

from .fvmesh import FVMesh
from .kernels import nearest_segment_distance

#: Boundary-condition types that are walls (no-slip): distance is measured to their faces.
WALL_TYPES: tuple[str, ...] = ("wall", "no_slip_wall", "moving_wall")

#: Up to this many point-segment pairs, :func:`wall_distance` takes every segment (one compiled loop,
#: :func:`solver.kernels.nearest_segment_distance`, ~4 ns a pair) instead of the k-d tree's candidates: the
#: exact minimum, which the candidates contain on every blade mesh (bitwise the same distances, benchmark
#: and random blades 0 and 1 at coarse and medium), 8-10x faster at coarse (5 500 cells, 80 wall faces:
#: 17 -> 2 ms), 3-4x at medium (16 600-19 600 cells, 220 faces).
BRUTE_FORCE_PAIRS = 20_000_000


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Exact distance ``(...)`` from points ``p (..., 2)`` to segments ``a -> b`` ``(..., 2)`` (broadcast), m."""
    ab = b - a
    t = np.einsum("...i,...i->...", p - a, ab) / np.maximum(np.einsum("...i,...i->...", ab, ab), 1e-300)
    q = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.sqrt(np.einsum("...i,...i->...", p - q, p - q))


def wall_faces(mesh: FVMesh, types: dict) -> np.ndarray:
    """Global indices of the wall faces: the boundary groups whose type (``{group: type}``, e.g.
    :attr:`solver.boundary.BoundaryData.types`) is in :data:`WALL_TYPES`."""
    groups = [g for g, t in types.items() if t in WALL_TYPES]
    if not groups:
        return np.zeros(0, dtype=np.int64)
    return np.concatenate([mesh.boundary[g] for g in groups])


def wall_distance(mesh: FVMesh, faces: np.ndarray, points: np.ndarray | None = None, *, samples: int = 5,
                  k: int = 16) -> np.ndarray:
    """Distance ``(n,)`` from ``points (n, 2)`` (default: the cell centroids) to the nearest of the wall
    ``faces`` (global face indices), m. ``inf`` everywhere when there is no wall face.

    Example
    -------
    >>> from solver.validation.meshes import square_mesh
    >>> m = square_mesh(4, triangles="none")
    >>> d = wall_distance(m, m.boundary["bottom"])
    >>> bool(np.allclose(d, m.centroid[:, 1]))
    True
    """
    from scipy.spatial import cKDTree

    pts = mesh.centroid if points is None else np.asarray(points, float)
    if len(faces) == 0:
        return np.full(len(pts), np.inf)
    a = mesh.points[mesh.faces[faces, 0]]
    b = mesh.points[mesh.faces[faces, 1]]
    if len(pts) * len(faces) <= BRUTE_FORCE_PAIRS:
        return nearest_segment_distance(np.ascontiguousarray(pts, dtype=float), a, b)
    t = np.linspace(0.0, 1.0, samples)
    sample = (a[:, None, :] * (1.0 - t)[None, :, None] + b[:, None, :] * t[None, :, None]).reshape(-1, 2)
    owner_seg = np.repeat(np.arange(len(faces)), samples)
    kk = min(k, len(sample))
    _, idx = cKDTree(sample).query(pts, k=kk)
    idx = idx.reshape(len(pts), kk)
    seg = owner_seg[idx]                                            # (n, k) candidate segments
    d = segment_distance(pts[:, None, :], a[seg], b[seg])
    return d.min(axis=1)
