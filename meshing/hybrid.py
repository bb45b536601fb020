"""Hybrid mesh around a blade: structured O-layer of quads, unstructured triangles to a rectangle.

Topology (Vessaz et al. 2013, §3.2):

1. The wall is resampled (:func:`resample_wall`): spacing limited by the wall curvature and refined
   towards sharp corners (the blunt trailing edge's corners, a sharp leading edge); corners are kept.
2. The O-layer's outer boundary is the convex hull of the profile offset by ``side_offset`` chords, and
   by ``te_offset`` chords around the trailing edge (:func:`offset_hull`).
3. The O-layer's grid lines ("rays") are field lines of the harmonic function phi that is 0 on the wall
   and 1 on the hull (P1 finite elements on an auxiliary gmsh triangulation, :func:`harmonic_field`).
   In a doubly connected region such a function has no critical point, so its field lines never cross,
   leave the wall orthogonally and all reach the hull, whatever the camber: this is what makes the
   O-layer robust. Near the wall each ray is a straight segment along the wall normal (orthogonal
   boundary-layer cells) that then turns smoothly into the field direction (no kink, see
   :func:`trace_rays`); convex sharp corners get a fan of rays (a few triangles at the wall).
4. Along every ray the layers follow a geometric progression from the first-cell height given by the
   target y+ (:meth:`MeshSpec.first_cell_height`) to the hull; the number of layers is common to all rays
   and set by the longest one with the largest growth ratio ``growth`` (shorter rays grow slower).
   The outer layers' nodes then slide along their layer so that the spacing on the outer ring varies
   smoothly (:func:`even_out_ring`); the near-wall layers are left as they are.
5. gmsh meshes the region between the O-layer's outer ring (its nodes kept as they are) and the
   rectangular domain with triangles (frontal-Delaunay, size growing linearly away from the ring up to
   the far-field size). The rectangle's sides are discretised beforehand with the same size law
   (:func:`far_field_size`, :func:`side_nodes`), so that in a narrow channel the walls carry the small
   cells the field asks for next to the O-layer.

Everything is vectorised over nodes and cells; gmsh runs single-threaded so that the same input gives
the identical mesh. gmsh keeps global state: call :func:`build_mesh` from one thread at a time (use
processes for parallel meshing). If gmsh is already initialised by the caller it is left initialised.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable

import numpy as np
import shapely

from meshing.mesh import Mesh2D, polygon_areas
from meshing.spec import MeshSpec

CORNER_TURN_DEG = 25.0  # a profile point turning more than this (degrees) is a sharp corner
FAN_TURN_DEG = 60.0  # convex corners turning more than this get a fan of rays
FAN_SECTOR_DEG = 50.0  # largest angle between two rays of a fan
#: Largest wall spacing, as a multiple of the mean spacing ``perimeter / wall_nodes``. The corner spacing is
#: ``corner_ratio`` times the largest spacing; when the leading edge's curvature alone asks for more than
#: ``wall_nodes`` nodes, the bisection of :func:`resample_wall` would push the largest spacing to its bound
#: (a quarter of the perimeter) and leave a blunt trailing edge one face wide. Measured on the 50 random
#: Table 6 blades at ``coarse``: 34 between 2.2 and 6.1, none between 6.1 and 8.4, 16 (toolpath blades with a
#: small leading-edge radius) from 8.4 to the bound; at ``medium`` all between 1.2 and 1.7.
MAX_SPACING_RATIO = 7.0
WALL_STRAIGHT = 0.5  # straight normal part of each ray, in local wall spacings
WALL_BLEND = 3.0  # each ray then turns into the field direction over this many straight lengths
PHI_STEPS = 120  # integration steps along each ray
FEM_HULL_SIZE = 0.02  # auxiliary triangulation size on the hull, chords
RING_SMOOTH = 1.5  # Gaussian smoothing of the ring spacing, rays
RING_BLEND_START = 0.1  # layers nearer the wall than this fraction of the ray are not slid
FAR_HEIGHT_FRACTION = 0.25  # far-field triangles no larger than this fraction of the channel height


class MeshingError(RuntimeError):
    """The mesh could not be built (gmsh failure, rays that do not reach the hull in order...)."""


# --------------------------------------------------------------------------------------------- wall


def _turning(points: np.ndarray) -> np.ndarray:
    """Signed turning angle (rad, left turn positive) at every vertex of a closed polyline."""
    t_in = points - np.roll(points, 1, axis=0)
    t_out = np.roll(points, -1, axis=0) - points
    cross = t_in[:, 0] * t_out[:, 1] - t_in[:, 1] * t_out[:, 0]
    return np.arctan2(cross, np.sum(t_in * t_out, axis=1))


def _densify(points: np.ndarray, max_len: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed polyline with extra points so that no segment exceeds ``max_len`` (m); returns the new
    points and, for every original point, its index in the new array."""
    seg = np.roll(points, -1, axis=0) - points
    k = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / max_len).astype(int))
    start = np.concatenate([[0], np.cumsum(k)[:-1]])
    owner = np.repeat(np.arange(len(points)), k)
    frac = (np.arange(k.sum()) - start[owner]) / k[owner]
    return points[owner] + frac[:, None] * seg[owner], start


def wall_spacing(profile_points: np.ndarray, corner_mask: np.ndarray, spec: MeshSpec, dense: np.ndarray,
                 dense_of: np.ndarray) -> Callable[[float], np.ndarray]:
    """Target wall spacing (m) at every point of the densified wall ``dense``, as a function of ``h_max``.

    ``min(h_max, h_corner + g d_corner, min_j(h_turn_j + g d_j))``: ``h_corner = corner_ratio * h_max``
    at sharp corners, ``h_turn = max_turn / curvature`` on curved walls, ``g = wall_gradient``, ``d``
    the distance along the wall. The distances do not depend on ``h_max``: computed once here (dense x
    curved-point matrices), not in each step of :func:`resample_wall`'s bisection on ``h_max``.
    """
    s = _arclength(dense)
    perimeter = s[-1] + np.linalg.norm(dense[0] - dense[-1])
    turn = np.abs(_turning(profile_points))
    seg = np.linalg.norm(np.roll(profile_points, -1, axis=0) - profile_points, axis=1)
    curvature = turn / (0.5 * (seg + np.roll(seg, 1)))
    curvature[corner_mask] = 0.0
    src = np.flatnonzero(curvature > 0)
    h_turn = math.radians(spec.max_turn) / curvature[src]
    d = np.abs(s[:, None] - s[dense_of[src]][None, :])
    d = np.minimum(d, perimeter - d)
    h_curv = np.min(h_turn[None, :] + spec.wall_gradient * d, axis=1) if len(src) else np.inf
    dc = np.abs(s[:, None] - s[dense_of[corner_mask]][None, :])
    d_corner = np.min(np.minimum(dc, perimeter - dc), axis=1)

    def spacing(h_max: float) -> np.ndarray:
        return np.minimum(np.minimum(h_max, spec.corner_ratio * h_max + spec.wall_gradient * d_corner), h_curv)

    return spacing


def _arclength(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def resample_wall(profile, spec: MeshSpec) -> tuple[np.ndarray, np.ndarray]:
    """Wall nodes (m, counter-clockwise, on the profile polyline) and a mask of the sharp corners.

    Corners (the two trailing-edge corners, any profile point turning more than ``CORNER_TURN_DEG``)
    are kept as nodes; between corners, nodes are equidistributed in ``∫ ds / h`` with ``h`` from
    :func:`wall_spacing`, whose largest value is chosen so that there are about ``spec.wall_nodes``, and is
    at most :data:`MAX_SPACING_RATIO` times the mean spacing (then there are more nodes than ``wall_nodes``).
    """
    pts = np.asarray(profile.points, dtype=float)
    chord = profile.chord
    corner_mask = np.abs(_turning(pts)) > math.radians(CORNER_TURN_DEG)
    corner_mask[[0, profile.te_index]] = True
    dense, dense_of = _densify(pts, 1e-3 * chord)
    closed = np.vstack([dense, dense[:1]])
    s = _arclength(closed)
    ds = np.diff(s)

    spacing = wall_spacing(pts, corner_mask, spec, dense, dense_of)

    def count(h_max: float) -> tuple[float, np.ndarray]:
        h = spacing(h_max)
        w = 1.0 / h
        return float(np.sum(0.5 * (w + np.roll(w, -1)) * ds)), w

    lo, hi = 1e-4 * s[-1], s[-1] / 4
    for _ in range(50):  # bisection on the largest spacing (count is monotone decreasing)
        mid = math.sqrt(lo * hi)
        if count(mid)[0] > spec.wall_nodes:
            lo = mid
        else:
            hi = mid
    # the cap binds only where the curvature takes the whole budget; there the count exceeds wall_nodes
    _, w = count(min(hi, MAX_SPACING_RATIO * s[-1] / spec.wall_nodes))
    wc = np.concatenate([w, w[:1]])
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (wc[:-1] + wc[1:]) * ds)])  # ∫ds/h at closed points
    anchors = np.concatenate([dense_of[np.flatnonzero(corner_mask)], [len(dense)]])
    targets, firsts = [], []
    for a, b in zip(anchors[:-1], anchors[1:], strict=True):  # one segment between two corners
        n = max(1, int(round(cum[b] - cum[a])))
        t = np.interp(cum[a] + (cum[b] - cum[a]) * np.arange(n) / n, cum[a:b + 1], s[a:b + 1])
        t[0] = s[a]
        targets.append(t)
        firsts.append(np.arange(n) == 0)
    s_nodes = np.concatenate(targets)
    nodes = np.column_stack([np.interp(s_nodes, s, closed[:, 0]), np.interp(s_nodes, s, closed[:, 1])])
    return nodes, np.concatenate(firsts)


# ---------------------------------------------------------------------------------------- hull


def offset_hull(profile, spec: MeshSpec) -> shapely.Polygon:
    """Convex hull (shapely polygon, m) of the profile offset by ``side_offset`` chords, and by
    ``te_offset`` chords around the trailing-edge segment."""
    chord = profile.chord
    blade = shapely.Polygon(profile.points).buffer(0)
    te = shapely.LineString(profile.trailing_edge)
    region = shapely.union(blade.buffer(spec.side_offset * chord, quad_segs=16),
                           te.buffer(spec.te_offset * chord, quad_segs=16))
    return shapely.convex_hull(region)


def _ring_coords(polygon: shapely.Polygon, max_len: float) -> np.ndarray:
    """Counter-clockwise exterior vertices of ``polygon`` with segments no longer than ``max_len``."""
    ring = shapely.segmentize(shapely.LinearRing(polygon.exterior.coords), max_len)
    if not shapely.is_ccw(ring):
        ring = ring.reverse()
    return np.asarray(ring.coords)[:-1, :2]


# -------------------------------------------------------------------------------- gmsh helpers


def _gmsh_start():
    import gmsh

    owner = not gmsh.isInitialized()
    if owner:
        gmsh.initialize(["-nopopup"], readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.Verbosity", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    return gmsh, owner


def _polygon_loop(gmsh, pts: np.ndarray, sizes: np.ndarray, fixed: bool) -> tuple[int, list[int], list[int]]:
    """Points and lines of a closed polygon in ``gmsh.model.geo``; with ``fixed`` every line keeps its two
    end nodes only. Returns the curve-loop tag, the point tags and the line tags."""
    geo = gmsh.model.geo
    ptags = [geo.addPoint(float(x), float(y), 0.0, float(h)) for (x, y), h in zip(pts, sizes, strict=True)]
    ltags = [geo.addLine(ptags[i], ptags[(i + 1) % len(ptags)]) for i in range(len(ptags))]
    if fixed:
        for lt in ltags:
            geo.mesh.setTransfiniteCurve(lt, 2)
    return geo.addCurveLoop(ltags), ptags, ltags


def _mesh_nodes(gmsh) -> tuple[np.ndarray, np.ndarray]:
    """All mesh nodes: (tags, (n, 2) coordinates), sorted by tag, and a tag -> row lookup array."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    order = np.argsort(tags)
    tags = tags[order].astype(np.int64)
    xy = coords.reshape(-1, 3)[order, :2]
    lookup = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    lookup[tags] = np.arange(len(tags))
    return xy, lookup


def _triangulate(gmsh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mesh the current model with Frontal-Delaunay triangles sized from the boundary points; returns
    the nodes (rows), the gmsh-tag -> row lookup and the triangles."""
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
    gmsh.model.mesh.generate(2)
    xy, lookup = _mesh_nodes(gmsh)
    return xy, lookup, _triangles(gmsh, lookup)


def _triangles(gmsh, lookup: np.ndarray) -> np.ndarray:
    _, node_tags = gmsh.model.mesh.getElementsByType(2)
    return lookup[np.asarray(node_tags, dtype=np.int64)].reshape(-1, 3)


def _point_node_rows(gmsh, ptags: list[int], lookup: np.ndarray) -> np.ndarray:
    return np.array([lookup[int(gmsh.model.mesh.getNodes(0, t)[0][0])] for t in ptags], dtype=np.int64)


# ------------------------------------------------------------------------------ harmonic field


def harmonic_field(gmsh, wall: np.ndarray, wall_h: np.ndarray, hull_pts: np.ndarray, hull_h: float):
    """Solve Laplace(phi) = 0 between the wall (phi = 0) and the hull (phi = 1) with P1 elements.

    Returns the auxiliary triangulation (points (n, 2), triangles (nt, 3)), phi at its nodes and the
    nodal gradient of phi (1/m, area-weighted average of the element gradients).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    gmsh.model.add("millfoil_phi")
    outer, _, hull_lines = _polygon_loop(gmsh, hull_pts, np.full(len(hull_pts), hull_h), fixed=True)
    inner, _, wall_lines = _polygon_loop(gmsh, wall, wall_h, fixed=True)
    surf = gmsh.model.geo.addPlaneSurface([outer, inner])
    gmsh.model.geo.synchronize()
    gmsh.model.addPhysicalGroup(1, wall_lines, 1)
    gmsh.model.addPhysicalGroup(1, hull_lines, 2)
    gmsh.model.addPhysicalGroup(2, [surf], 3)
    xy, lookup, tri = _triangulate(gmsh)
    wall_rows = lookup[gmsh.model.mesh.getNodesForPhysicalGroup(1, 1)[0].astype(np.int64)]
    hull_rows = lookup[gmsh.model.mesh.getNodesForPhysicalGroup(1, 2)[0].astype(np.int64)]
    gmsh.model.remove()

    p = xy[tri]
    area2 = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
             - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    flip = area2 < 0
    tri[flip] = tri[flip][:, ::-1]
    p = xy[tri]
    area2 = np.abs(area2)
    b = np.stack([p[:, 1, 1] - p[:, 2, 1], p[:, 2, 1] - p[:, 0, 1], p[:, 0, 1] - p[:, 1, 1]], axis=1)
    c = np.stack([p[:, 2, 0] - p[:, 1, 0], p[:, 0, 0] - p[:, 2, 0], p[:, 1, 0] - p[:, 0, 0]], axis=1)
    ke = (b[:, :, None] * b[:, None, :] + c[:, :, None] * c[:, None, :]) / (2.0 * area2)[:, None, None]
    n = len(xy)
    rows = np.repeat(tri, 3, axis=1).ravel()
    cols = np.tile(tri, (1, 3)).ravel()
    k = coo_matrix((ke.ravel(), (rows, cols)), shape=(n, n)).tocsr()
    phi = np.zeros(n)
    phi[hull_rows] = 1.0
    fixed = np.zeros(n, dtype=bool)
    fixed[wall_rows] = fixed[hull_rows] = True
    free = np.flatnonzero(~fixed)
    rhs = -k[free][:, np.flatnonzero(fixed)] @ phi[fixed]
    phi[free] = spsolve(k[free][:, free].tocsc(), rhs)

    grad_e = np.stack([np.sum(b * phi[tri], axis=1), np.sum(c * phi[tri], axis=1)], axis=1) / area2[:, None]
    weight = np.repeat(area2, 3)
    grad = np.stack([np.bincount(tri.ravel(), np.repeat(grad_e[:, d], 3) * weight, n) for d in (0, 1)], axis=1)
    grad /= np.bincount(tri.ravel(), weight, n)[:, None]
    return xy, tri, phi, grad


class _FieldInterpolator:
    """Linear interpolation of nodal values on a triangulation (matplotlib's trapezoid-map finder)."""

    def __init__(self, xy: np.ndarray, tri: np.ndarray):
        import matplotlib.tri as mtri

        self.tri = tri
        self.finder = mtri.Triangulation(xy[:, 0], xy[:, 1], tri).get_trifinder()
        p = xy[tri]
        m = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)  # columns: edge vectors
        self.minv = np.linalg.inv(m)
        self.origin = p[:, 0]

    def __call__(self, pts: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interpolated ``values`` (n_nodes, k) at ``pts``; second result: inside mask."""
        t = self.finder(pts[:, 0], pts[:, 1])
        inside = t >= 0
        ti = np.where(inside, t, 0)
        lam12 = np.einsum("nij,nj->ni", self.minv[ti], pts - self.origin[ti])
        lam = np.column_stack([1.0 - lam12.sum(axis=1), lam12])
        out = np.einsum("nk,nkd->nd", lam, values[self.tri[ti]])
        return out, inside


# ------------------------------------------------------------------------------------------- rays


def ray_starts(wall: np.ndarray, is_corner: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rays leaving the wall: wall node of each ray, unit direction, straight length (m).

    Ordinary nodes get one ray along the bisector of the adjacent edge normals; convex sharp corners
    turning more than ``FAN_TURN_DEG`` get a fan from one edge normal to the other, at most
    ``FAN_SECTOR_DEG`` apart. Rays are ordered counter-clockwise around the blade.
    """
    t_in = wall - np.roll(wall, 1, axis=0)
    t_out = np.roll(wall, -1, axis=0) - wall
    l_in, l_out = np.linalg.norm(t_in, axis=1), np.linalg.norm(t_out, axis=1)
    n_in = np.column_stack([t_in[:, 1], -t_in[:, 0]]) / l_in[:, None]  # outward: right of the CCW wall
    n_out = np.column_stack([t_out[:, 1], -t_out[:, 0]]) / l_out[:, None]
    turn = _turning(wall)
    fan = is_corner & (turn > math.radians(FAN_TURN_DEG))
    sectors = np.where(fan, np.ceil(turn / math.radians(FAN_SECTOR_DEG)).astype(int), 0)
    count = np.where(fan, sectors + 1, 1)
    node = np.repeat(np.arange(len(wall)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    a_in = np.arctan2(n_in[:, 1], n_in[:, 0])
    frac = np.where(fan[node], k / np.maximum(sectors[node], 1), 0.0)
    angle = a_in[node] + frac * turn[node]
    fan_dir = np.column_stack([np.cos(angle), np.sin(angle)])
    bis = n_in + n_out
    bis /= np.linalg.norm(bis, axis=1)[:, None]
    direction = np.where(fan[node][:, None], fan_dir, bis[node])
    straight = WALL_STRAIGHT * np.minimum(l_in, l_out)[node]
    return node, direction, straight


def trace_rays(field: _FieldInterpolator, phi: np.ndarray, grad: np.ndarray, start: np.ndarray,
               direction: np.ndarray | None = None, blend: np.ndarray | float = 0.0,
               steps: int = PHI_STEPS) -> np.ndarray:
    """Field lines of phi from ``start`` (r, 2) to phi = 1: (r, steps + 1, 2) points, m.

    Integrates dx/dphi = t/(t.grad) (midpoint rule) over phi values growing geometrically from the start
    value to 1; outside the triangulation the last gradient is kept. ``t`` is the unit field direction,
    except over the first ``blend`` (m, per ray) of arc length, where it turns smoothly from ``direction``
    (the ray's straight start) to it: ``t ∝ (1 - w) direction + w grad/|grad|``, ``w`` a smoothstep of the
    arc length. Near a sharp corner the field lines bend towards the corner bisector, away from the fan's
    straight rays (by ~65° at a 10° wedge): turning abruptly there would kink the ray and make a wedge of
    the thin quad beside it.
    """
    vals = np.column_stack([phi, grad])
    v, inside = field(start, vals)
    if not inside.all():
        raise MeshingError(f"{np.count_nonzero(~inside)} ray start points lie outside the O-layer region")
    phi0 = np.clip(v[:, 0], 1e-9, 0.5)
    levels = phi0[:, None] ** (1.0 - np.arange(steps + 1)[None, :] / steps)
    out = np.empty((len(start), steps + 1, 2))
    out[:, 0] = x = start
    last = v[:, 1:]
    d0 = np.zeros_like(start) if direction is None else direction
    blend = np.broadcast_to(np.asarray(blend, dtype=float), (len(start),))
    s = np.zeros(len(start))  # arc length from the start

    def velocity(pts, s, last):
        g, ok = field(pts, vals)
        g = np.where(ok[:, None], g[:, 1:], last)
        u = np.clip(s / np.maximum(blend, 1e-300), 0.0, 1.0)
        w = np.where(blend > 0, u * u * (3.0 - 2.0 * u), 1.0)[:, None]
        t = (1.0 - w) * d0 + w * g / np.maximum(np.linalg.norm(g, axis=1), 1e-300)[:, None]
        return t / np.maximum(np.sum(t * g, axis=1), 1e-300)[:, None], g

    for i in range(steps):
        dphi = (levels[:, i + 1] - levels[:, i])[:, None]
        f1, last = velocity(x, s, last)
        f2, last = velocity(x + 0.5 * dphi * f1, s + 0.5 * np.linalg.norm(dphi * f1, axis=1), last)
        x = x + dphi * f2
        s = s + np.linalg.norm(dphi * f2, axis=1)
        out[:, i + 1] = x
    return out


def layer_distances(lengths: np.ndarray, h0: float, growth: float) -> np.ndarray:
    """Distances (m) of the layer nodes along every ray: (r, n + 1), geometric from ``h0``.

    The number of layers ``n`` makes the longest ray reach its length with ratio ``growth``; every
    ray's own ratio (≤ ``growth``) is solved by bisection so that its last node lies at its length.
    """
    n = int(math.ceil(math.log1p(lengths.max() * (growth - 1.0) / h0) / math.log(growth)))
    lo = np.full(len(lengths), 1.0 + 1e-12)
    hi = np.full(len(lengths), growth * (1 + 1e-9))
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        too_long = h0 * np.expm1(n * np.log(mid)) / (mid - 1.0) > lengths
        hi = np.where(too_long, mid, hi)
        lo = np.where(too_long, lo, mid)
    r = 0.5 * (lo + hi)
    j = np.arange(n + 1)
    d = h0 * np.expm1(j[None, :] * np.log(r)[:, None]) / (r - 1.0)[:, None]
    d[:, -1] = lengths
    return d


def _points_along(paths: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """Points at arc-length ``distances`` (r, m) along the polylines ``paths`` (r, k, 2): (r, m, 2)."""
    seg = np.linalg.norm(np.diff(paths, axis=1), axis=2)
    s = np.concatenate([np.zeros((len(paths), 1)), np.cumsum(seg, axis=1)], axis=1)
    offset = (s[:, -1].max() + 1.0) * np.arange(len(paths))[:, None]  # one monotone global abscissa
    sg, qg = (s + offset).ravel(), (distances + offset).ravel()
    x = np.interp(qg, sg, paths[..., 0].ravel()).reshape(distances.shape)
    y = np.interp(qg, sg, paths[..., 1].ravel()).reshape(distances.shape)
    return np.stack([x, y], axis=2)


def _cyclic_smooth(values: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing (standard deviation ``sigma`` samples) of a periodic sequence."""
    half = int(math.ceil(3 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    n = len(values)
    reps = 2 * (half // n + 1) + 1
    out = np.convolve(np.tile(values, reps), kernel, mode="same")
    return out[(reps // 2) * n:(reps // 2 + 1) * n]


def even_out_ring(layers: np.ndarray, fraction: np.ndarray, sigma: float | None = None) -> np.ndarray:
    """Slide the outer layers' nodes along their layer so that the spacing on the ring varies smoothly.

    ``layers``: (rays, n, 2) O-layer nodes of layers 1..n; ``fraction``: (rays, n) their distance along
    the ray over the ray's length. The ring's relative spacing is Gaussian-smoothed over ``sigma`` rays
    (default ``RING_SMOOTH``);
    layer j's relative spacing ``a_j`` is multiplied by ``(a* / a_ring)^b_j`` (then normalised), ``a*`` the
    smoothed ring spacing and ``b_j = ((mean(fraction_j) - f0) / (1 - f0))²`` clipped to [0, 1],
    ``f0 = RING_BLEND_START``: the layers within ``f0`` of the wall are untouched, the spacings stay positive
    so the order of the nodes is kept, and each node moves only as far as the local change of ring spacing
    asks. Ray 0 stays in place.
    """
    sigma = RING_SMOOTH if sigma is None else sigma
    rays, n, _ = layers.shape
    closed = np.concatenate([layers, layers[:1]], axis=0)  # (rays + 1, n, 2)
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=2)  # (rays, n)
    a = seg / seg.sum(axis=0)
    target = _cyclic_smooth(a[:, -1], sigma)
    target /= target.sum()
    b = np.clip((np.mean(fraction, axis=0) - RING_BLEND_START) / (1.0 - RING_BLEND_START), 0.0, 1.0) ** 2
    a_new = a * (target / a[:, -1])[:, None] ** b[None, :]
    a_new /= a_new.sum(axis=0)
    s_old = np.concatenate([np.zeros((1, n)), np.cumsum(a, axis=0)])  # (rays + 1, n), 0 .. 1
    s_new = np.concatenate([np.zeros((1, n)), np.cumsum(a_new, axis=0)])[:-1]  # (rays, n)
    offset = 2.0 * np.arange(n)[None, :]  # one monotone abscissa for all layers
    sg, qg = (s_old + offset).T.ravel(), (s_new + offset).T.ravel()
    x = np.interp(qg, sg, closed[..., 0].T.ravel()).reshape(n, rays).T
    y = np.interp(qg, sg, closed[..., 1].T.ravel()).reshape(n, rays).T
    return np.stack([x, y], axis=2)


# ------------------------------------------------------------------------------------ O-layer


def _check_simple(wall: np.ndarray, spec: MeshSpec) -> None:
    """MeshingError if the resampled wall polygon crosses itself. A valid profile thinner than the wall
    spacing (a trailing edge of a few tenths of a millimetre on the coarse level) can resample into a
    crossing polygon, and gmsh's frontal mesher never returns on a crossing boundary."""
    polygon = shapely.Polygon(wall)
    if polygon.is_valid:
        return
    reason = shapely.is_valid_reason(polygon)
    at = re.search(r"\[(\S+) (\S+)\]", reason)
    where = f"at x = {float(at[1]):.4g} m, y = {float(at[2]):.4g} m" if at else f"({reason})"
    raise MeshingError(f"the blade wall resampled for this mesh level ({len(wall)} nodes) crosses itself {where}: "
                       "the profile is thinner there than the wall spacing; a finer level may mesh it")


def o_layer(profile, spec: MeshSpec, gmsh) -> dict:
    """The structured O-layer: points, quads, fan triangles, wall node count, ring node indices."""
    chord = profile.chord
    h0 = spec.first_cell_height(chord)
    wall, is_corner = resample_wall(profile, spec)
    _check_simple(wall, spec)
    seg = np.linalg.norm(np.roll(wall, -1, axis=0) - wall, axis=1)
    wall_h = 0.5 * (seg + np.roll(seg, 1))
    hull = offset_hull(profile, spec)
    hull_size = min(FEM_HULL_SIZE * chord, 4 * float(np.median(seg)))
    hull_pts = _ring_coords(hull, hull_size)
    xy, tri, phi, grad = harmonic_field(gmsh, wall, wall_h, hull_pts, hull_size)
    field = _FieldInterpolator(xy, tri)

    node, direction, straight = ray_starts(wall, is_corner)
    start = wall[node] + straight[:, None] * direction
    traced = trace_rays(field, phi, grad, start, direction, WALL_BLEND * straight)
    # Land every ray on the hull (the integration ends within the discretisation error of it).
    ring = shapely.LinearRing(np.vstack([hull_pts, hull_pts[:1]]))
    where = shapely.line_locate_point(ring, shapely.points(traced[:, -1]))
    traced[:, -1] = shapely.get_coordinates(shapely.line_interpolate_point(ring, where))
    turns = np.sum(np.mod(np.roll(where, -1) - where, ring.length)) / ring.length
    if abs(turns - 1.0) > 1e-6:  # the landing points go once round the hull, in order
        raise MeshingError("the O-layer rays do not reach the hull in order")
    paths = np.concatenate([wall[node][:, None], traced], axis=1)
    lengths = np.sum(np.linalg.norm(np.diff(paths, axis=1), axis=2), axis=1)
    dist = layer_distances(lengths, h0, spec.growth)
    layers = _points_along(paths, dist[:, 1:])  # (rays, n, 2): layers 1..n
    layers = even_out_ring(layers, dist[:, 1:] / lengths[:, None])
    n_rays, n_layers = layers.shape[0], layers.shape[1]

    nw = len(wall)
    points = np.vstack([wall, layers.transpose(1, 0, 2).reshape(-1, 2)])
    idx = np.vstack([node[None, :], nw + np.arange(n_layers)[:, None] * n_rays + np.arange(n_rays)[None, :]])
    r0, r1 = np.arange(n_rays), (np.arange(n_rays) + 1) % n_rays
    quads = np.stack([idx[:-1, r0], idx[1:, r0], idx[1:, r1], idx[:-1, r1]], axis=2)  # (n, rays, 4)
    fan = node[r0] == node[r1]
    fan_tris = np.column_stack([node[r0][fan], idx[1, r0][fan], idx[1, r1][fan]])
    quads = np.concatenate([quads[0][~fan], quads[1:].reshape(-1, 4)])
    blade = np.column_stack([(np.arange(nw) + 1) % nw, np.arange(nw)])  # clockwise: fluid on the left
    growth_used = (dist[:, 2] - dist[:, 1]) / np.maximum(dist[:, 1], 1e-300)
    return {
        "points": points, "quads": quads, "triangles": fan_tris, "blade": blade,
        "ring": idx[-1], "hull": hull,
        "info": {
            "first_cell_height": h0, "layers": n_layers, "wall_nodes": nw, "rays": n_rays,
            "growth_min": float(growth_used.min()), "growth_max": float(growth_used.max()),
            "ray_length_min": float(lengths.min()), "ray_length_max": float(lengths.max()),
            "aux_triangles": len(tri),
        },
    }


# -------------------------------------------------------------------------------- far field


def domain_box(profile, spec: MeshSpec) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the rectangular domain, m (see :class:`MeshSpec`)."""
    chord = profile.chord
    lo, hi = profile.points.min(axis=0), profile.points.max(axis=0)
    yc = 0.5 * (lo[1] + hi[1])
    return (lo[0] - spec.upstream * chord, hi[0] + spec.downstream * chord,
            yc - spec.half_height * chord, yc + spec.half_height * chord)


def far_field_size(ring: np.ndarray, box: tuple[float, float, float, float], spec: MeshSpec,
                   chord: float) -> tuple[np.ndarray, float, float, Callable[[np.ndarray], np.ndarray]]:
    """The far-field size law: ring node sizes (m), the largest size and the grading distance (m), and a
    vectorised function giving the target triangle size (m) at points (n, 2).

    The size grows linearly with the distance ``d`` from the ring, from the nearest ring node's own
    spacing ``h_ring`` to the largest size ``h_far`` at ``d = d_max`` (gmsh's "Extend" field):
    ``h = h_ring + (h_far - h_ring) d / d_max``, ``d_max = (h_far - median(h_ring)) / size_gradient``.
    ``h_far`` is ``far_size`` chords, capped at ``FAR_HEIGHT_FRACTION`` of the channel height so that a
    narrow channel still has several cells across it.
    """
    from scipy.spatial import cKDTree

    seg = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    ring_h = 0.5 * (seg + np.roll(seg, 1))
    far_h = min(spec.far_size * chord, FAR_HEIGHT_FRACTION * (box[3] - box[2]))
    far_h = max(far_h, float(ring_h.max()))
    dist_max = max(far_h - float(np.median(ring_h)), 0.0) / spec.size_gradient
    tree = cKDTree(ring)

    def size(points: np.ndarray) -> np.ndarray:
        d, i = tree.query(points)
        if dist_max <= 0.0:
            return np.full(len(points), far_h)
        return np.where(d < dist_max, ring_h[i] + (far_h - ring_h[i]) * d / dist_max, far_h)

    return ring_h, far_h, dist_max, size


def side_nodes(p0: np.ndarray, p1: np.ndarray, size: Callable[[np.ndarray], np.ndarray],
               step: float) -> np.ndarray:
    """Nodes (m, 2) from ``p0`` to ``p1`` (both included) equidistributed in ``∫ ds / size``; ``size``
    is sampled every ``step`` (m) at most."""
    samples = min(max(1000, int(math.ceil(float(np.linalg.norm(p1 - p0)) / step))), 200_000)
    t = np.linspace(0.0, 1.0, samples + 1)
    pts = p0[None, :] + t[:, None] * (p1 - p0)[None, :]
    w = 1.0 / size(pts)
    length = float(np.linalg.norm(p1 - p0))
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t) * length)])
    n = max(1, int(round(cum[-1])))
    tn = np.interp(cum[-1] * np.arange(n + 1) / n, cum, t)
    tn[0], tn[-1] = 0.0, 1.0
    return p0[None, :] + tn[:, None] * (p1 - p0)[None, :]


def far_field(gmsh, ring: np.ndarray, box: tuple[float, float, float, float], spec: MeshSpec,
              chord: float) -> dict:
    """Triangles between the closed counter-clockwise ``ring`` (its nodes kept) and the rectangle.

    The rectangle's sides are discretised here, with the size law of :func:`far_field_size` (their
    nodes kept by gmsh): in a narrow channel the walls then carry the small cells the graded field asks
    for next to the O-layer. Left to gmsh, the sides got the far-field size whatever their distance to
    the ring (one chord at ``coarse``), and where the coarse front from a wall met the fine one from the
    ring, slivers appeared (scaled Jacobian down to 0.03 at half_height 0.6).

    Returns the gmsh nodes (rows), their triangles, the row of each ring node and the edges of the
    four sides (inlet x = xmin, outlet x = xmax, bottom, top), counter-clockwise.
    """
    geo = gmsh.model.geo
    gmsh.model.add("millfoil_far")
    ring_h, far_h, dist_max, size = far_field_size(ring, box, spec, chord)
    x0, x1, y0, y1 = box
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    if not (x0 < lo[0] and hi[0] < x1 and y0 < lo[1] and hi[1] < y1):
        raise MeshingError(f"the domain x in [{x0:.4g}, {x1:.4g}] m, y in [{y0:.4g}, {y1:.4g}] m does not contain "
                           f"the O-layer (x in [{lo[0]:.4g}, {hi[0]:.4g}] m, y in [{lo[1]:.4g}, {hi[1]:.4g}] m): "
                           "increase upstream, downstream or half_height")
    corners = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    names = ("bottom", "outlet", "top", "inlet")
    step = 0.5 * float(ring_h.min())
    polylines = [side_nodes(corners[k], corners[(k + 1) % 4], size, step)[:-1] for k in range(4)]
    outer_pts = np.vstack(polylines)
    outer, _, outer_lines = _polygon_loop(gmsh, outer_pts, size(outer_pts), fixed=True)
    bounds = np.cumsum([0] + [len(p) for p in polylines])
    sides = {name: outer_lines[bounds[k]:bounds[k + 1]] for k, name in enumerate(names)}
    inner, ring_pts, ring_lines = _polygon_loop(gmsh, ring, ring_h, fixed=True)
    surf = geo.addPlaneSurface([outer, inner])
    geo.synchronize()
    for tag, name in enumerate(("inlet", "outlet", "top", "bottom"), start=1):
        gmsh.model.addPhysicalGroup(1, sides[name], tag, name)
    gmsh.model.addPhysicalGroup(2, [surf], 10, "fluid")
    # Sizes grow linearly from the ring's own edge lengths to the far-field size (gmsh "Extend" field).
    fields = gmsh.model.mesh.field
    ext = fields.add("Extend")
    fields.setNumbers(ext, "CurvesList", ring_lines)
    fields.setNumber(ext, "DistMax", dist_max)
    fields.setNumber(ext, "SizeMax", far_h)
    fields.setNumber(ext, "Power", 1.0)
    fields.setAsBackgroundMesh(ext)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    xy, lookup, tri = _triangulate(gmsh)
    ring_rows = _point_node_rows(gmsh, ring_pts, lookup)
    edges = {}
    for name, lines in sides.items():
        rows = []
        for line in lines:
            _, _, ntags = gmsh.model.mesh.getElements(1, line)
            rows.append(lookup[np.asarray(ntags[0], dtype=np.int64)].reshape(-1, 2))
        edges[name] = np.vstack(rows)
    gmsh.model.remove()
    return {"points": xy, "triangles": tri, "ring_rows": ring_rows, "edges": edges}


# ------------------------------------------------------------------------------------ assembly


def build_mesh(profile, spec: MeshSpec | None = None) -> Mesh2D:
    """Hybrid mesh around ``profile`` (a :class:`geometry.Profile`, m) as specified by ``spec``.

    Raises
    ------
    MeshingError if a step fails. Quality is not checked here: see :func:`meshing.check_quality`.
    """
    spec = spec or MeshSpec()
    chord = profile.chord
    t0 = time.perf_counter()
    gmsh, owner = _gmsh_start()
    try:
        o = o_layer(profile, spec, gmsh)
        t1 = time.perf_counter()
        ring = o["points"][o["ring"]]
        far = far_field(gmsh, ring, domain_box(profile, spec), spec, chord)
    except MeshingError:
        raise
    except Exception as exc:  # gmsh raises plain Exceptions
        raise MeshingError(f"meshing failed: {exc}") from exc
    finally:
        if owner:
            gmsh.finalize()
    t2 = time.perf_counter()

    n_o = len(o["points"])
    fxy = far["points"]
    new = np.ones(len(fxy), dtype=bool)
    new[far["ring_rows"]] = False
    rows_to_global = np.empty(len(fxy), dtype=np.int64)
    rows_to_global[far["ring_rows"]] = o["ring"]
    rows_to_global[new] = n_o + np.arange(np.count_nonzero(new))
    points = np.vstack([o["points"], fxy[new]])
    tri_far = rows_to_global[far["triangles"]]
    if np.sum(polygon_areas(points, tri_far)) < 0:
        tri_far = tri_far[:, ::-1]
    triangles = np.vstack([o["triangles"], tri_far])
    boundary = {name: rows_to_global[e] for name, e in far["edges"].items()}
    boundary["blade"] = o["blade"]
    info = dict(o["info"], level=spec.level, time_o_layer=t1 - t0, time_far_field=t2 - t1,
                time_total=time.perf_counter() - t0, hull_area=float(o["hull"].area))
    return Mesh2D(points=points, cells={"quad": o["quads"].astype(np.int64),
                                        "triangle": triangles.astype(np.int64)},
                  boundary={k: boundary[k].astype(np.int64)
                            for k in ("inlet", "outlet", "top", "bottom", "blade")},
                  info=info)
