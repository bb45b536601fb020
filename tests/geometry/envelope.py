"""Independent reference for the N-buffer: the exact machined region from a polygon-offset library.

The machined part is {x inside the path : dist(x, path) >= R}, which is shapely's inward buffer of the
polygon enclosed by the path. The path is sampled so densely (20 000 points per curved piece, chord error below
1e-9 m) and the buffer's arcs so finely that the reference itself is exact to well below the 1 µm checked.
"""

import numpy as np
import shapely

SAMPLES_PER_PIECE = 20_000


def exact_machined(pieces, radius):
    path = np.vstack([piece.points(np.linspace(0.0, 1.0, _samples(piece) + 1)[:-1]) for piece in pieces])
    return shapely.Polygon(path).buffer(-radius, quad_segs=512)


def _samples(piece):
    return 1 if piece.degree == 1 else SAMPLES_PER_PIECE  # a straight segment is exact with its ends


def densify(points, per_segment):
    loop = np.vstack([points, points[:1]])
    t = np.linspace(0.0, 1.0, per_segment, endpoint=False)[None, :, None]
    return (loop[:-1, None] * (1 - t) + loop[1:, None] * t).reshape(-1, 2)


def hausdorff(points, exact):
    """Symmetric Hausdorff distance (m) between a closed polyline and a polygon's exterior, each side
    sampled densely and measured exactly to the other's segments (via an R-tree of segments)."""
    boundary = np.asarray(exact.exterior.coords)[:-1]
    there = _distance_to_loop(densify(points, 16), boundary).max()
    back = _distance_to_loop(densify(boundary, 4), points).max()
    return max(there, back)


def _distance_to_loop(points, loop):
    ends = np.stack([loop, np.roll(loop, -1, axis=0)], axis=1)
    tree = shapely.STRtree(shapely.linestrings(ends))
    _, distance = tree.query_nearest(shapely.points(points), return_distance=True, all_matches=False)
    return distance
