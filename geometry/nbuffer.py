"""N-buffer machining simulation of a cylindrical cutter moving along a closed planar tool path.

The stock is the region enclosed by the tool path; a cutter of radius R whose centre follows the path
removes every point closer than R to it, so the machined part is ``{x inside : dist(x, path) >= R}``. Its
boundary is computed the N-buffer way (Jerard et al. 1989; Vessaz et al. 2013, §3.1):

1. *Needles*: lines normal to the nominal surface, one per sample of the path. Needle i starts at the
   path point p_i and points along the inward normal ν_i; its *own tip* p_i + R ν_i is where the cutter
   at p_i stops cutting, i.e. the nominal (local-envelope) surface point.
2. *Cutting*: the needles are intersected with the cutter at discrete positions c_k along the whole path
   and the deepest cut is kept. A needle whose deepest cut is its own cutter keeps its own tip: that point
   is on the machined surface. A needle cut deeper by another cutter position lies where that position
   gouges the nominal surface (global interference: a convex corner of the path, another part of the
   blade, a loop of the offset where the path is tighter than R); its own tip is removed material.
   Because the boundary of the swept region consists of own tips only, the machined surface is the
   sequence of uncut tips in path order.
3. *Corners*: where uncut and cut needles meet, the needle parameter is bisected until the tips are
   closer than the tolerance, which puts a vertex on the corner where two envelope branches intersect.
   Where the two ends of a cut stretch do not meet, material vanished between them: the part split.

Resolution comes from the tolerance ε: needles are spread so that the polyline through the tips has a
chord sagitta ≤ ε/2 on the envelope, cutter positions so that the scallop between two of them
(≈ Δ²/8R) is ≤ ε/4, and corners are bisected to ε/8; the machined polyline lies within ε of the exact
envelope. Concave corners of the path (right turns, interior on the left) get a fan of needles around the
corner so that the arc the cutter leaves there is sampled too.

Conventions: the path is closed, counter-clockwise (material on the left of the direction of travel),
given as consecutive pieces (Bezier curves, straight segments as degree-1 curves) in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geometry.bezier import Array, BezierCurve, cross, rotate_left
from geometry.sampling import DENSE, chord_density, equidistribute

_CORNER_ANGLE = 1e-9  # rad: smaller turning angles at a junction are smooth


@dataclass(frozen=True)
class _Fan:
    """The arc of needles at a concave corner: base fixed, normal rotating from theta0 to theta1."""

    centre: Array
    theta0: float
    theta1: float

    def frame(self, u: Array) -> tuple[Array, Array]:
        theta = self.theta0 + (self.theta1 - self.theta0) * u
        return np.broadcast_to(self.centre, (u.size, 2)).copy(), np.stack([np.cos(theta), np.sin(theta)], 1)

    def needle_parameters(self, radius: float, tolerance: float, max_spacing: float) -> Array:
        sweep = abs(self.theta1 - self.theta0)
        n = int(np.ceil(sweep * max(np.sqrt(radius / (8 * tolerance)), radius / max_spacing)))
        return np.linspace(0.0, 1.0, max(n, 1) + 1)


@dataclass(frozen=True)
class _Segment:
    """A piece of the tool path seen by the needles: base point on the curve, inward (left) normal."""

    curve: BezierCurve

    def frame(self, u: Array) -> tuple[Array, Array]:
        return self.curve.points(u), rotate_left(self.curve.unit_tangent(u))

    def needle_parameters(self, radius: float, tolerance: float, max_spacing: float) -> Array:
        u = np.linspace(0.0, 1.0, DENSE)
        return equidistribute(u, chord_density(self.curve, u, tolerance, max_spacing, offset=radius))


@dataclass(frozen=True)
class MachinedBoundary:
    """Result of :func:`machine`.

    Attributes
    ----------
    points: ``(n, 2)`` counter-clockwise machined boundary, metres, first point not repeated.
    piece: ``(n,)`` index of the tool-path piece whose cutter left each point (a corner arc counts for
        the piece it follows).
    sigma: ``(n,)`` position along the path: piece index + parameter of the piece, in [0, len(pieces)];
        points on a corner arc take the junction's value.
    gouged_fraction: share of needles whose own tip was removed by another cutter position.
    split: True if the material left is not one piece: two ends of a removed stretch do not meet, or
        uncut needles form a second closed loop.
    gaps: ``(k, 2, 2)`` end points of the removed stretches that do not close (empty unless ``split``).
    spurious_runs: uncut stretches dropped as tails of an offset loop (path tighter than R).
    cutter_positions: number of discrete cutter positions used.
    """

    points: Array
    piece: np.ndarray
    sigma: Array
    gouged_fraction: float
    split: bool
    gaps: Array
    spurious_runs: int
    cutter_positions: int


def machine(pieces: list[BezierCurve], radius: float, tolerance: float = 1e-6,
            max_spacing: float = 1e-3) -> MachinedBoundary:
    """Simulate the cutter of ``radius`` (m) along the closed path ``pieces`` (counter-clockwise).

    ``tolerance`` (m) bounds the distance between the returned polyline and the exact envelope;
    ``max_spacing`` (m) bounds the distance between consecutive boundary points on smooth stretches.
    Raises ``ValueError`` if the pieces do not join into a closed path.
    """
    _check_closed(pieces, tolerance)
    needles, source = _needle_pieces(pieces)
    cutters = _cutter_positions(pieces, radius, tolerance / 4)
    tree = cKDTree(cutters)

    piece_id, u = _needle_samples(needles, radius, tolerance / 2, max_spacing)
    kept = _uncut(tree, _tips(needles, piece_id, u, radius), radius, tolerance)
    if not kept.any():
        return MachinedBoundary(np.empty((0, 2)), np.empty(0, int), np.empty(0), 1.0, True,
                                np.empty((0, 2, 2)), 0, len(cutters))
    runs = _uncut_runs(needles, tree, piece_id, u, kept, radius, tolerance)
    chain, closed, extra = _chain(runs, tolerance)

    ids = np.concatenate([runs[k].ids for k in chain])
    loc = np.concatenate([runs[k].params for k in chain])
    points = _merge_corners([runs[k].points for k in chain], closed)
    keep = _deduplicate(points, tolerance / 100)
    ids, loc, points = ids[keep], loc[keep], points[keep]

    is_fan = np.array([isinstance(n, _Fan) for n in needles])[ids]
    path_sigma = np.mod(source[ids] + np.where(is_fan, 1.0, loc), len(pieces))
    first = int(np.argmin(path_sigma))
    points, ids, path_sigma = (np.roll(a, -first, axis=0) for a in (points, ids, path_sigma))

    gaps = [] if closed else [np.stack([runs[chain[-1]].end, runs[chain[0]].start])]
    gaps += [np.stack([runs[loop[0]].start, runs[loop[-1]].end]) for loop in extra]
    spurious = len(runs) - len(chain) - sum(len(loop) for loop in extra)
    return MachinedBoundary(points, source[ids], path_sigma, float(1.0 - kept.mean()),
                            bool(gaps), np.array(gaps).reshape(-1, 2, 2), spurious, len(cutters))


@dataclass(frozen=True)
class _Run:
    """A maximal stretch of uncut needles, with its ends refined onto the corners."""

    ids: np.ndarray  # needle piece of each point
    params: Array  # parameter on that piece
    points: Array  # tips: the refined start, the uncut needles, the refined end

    @property
    def start(self) -> Array:
        return self.points[0]

    @property
    def end(self) -> Array:
        return self.points[-1]

    @property
    def size(self) -> int:
        return self.params.size


def _uncut_runs(needles, tree, piece_id, u, kept, radius, tolerance) -> list[_Run]:
    """Split the cyclic sequence of needles into runs of uncut ones, in path order."""
    n = u.size
    if kept.all():
        return [_Run(piece_id, u, _tips(needles, piece_id, u, radius))]
    nxt = np.roll(np.arange(n), -1)
    rising = np.flatnonzero(~kept & kept[nxt])  # cut -> uncut: a run starts at rising + 1
    falling = np.flatnonzero(kept & ~kept[nxt])  # uncut -> cut: a run ends here
    rise_id, rise_u = _bisect(needles, tree, piece_id, u, rising, nxt[rising], False, radius, tolerance)
    fall_id, fall_u = _bisect(needles, tree, piece_id, u, falling, nxt[falling], True, radius, tolerance)
    runs = []
    for k, r in enumerate(rising):
        f = int(np.searchsorted(falling, r) % falling.size)  # first run end after the start
        stop = falling[f] if falling[f] > r else falling[f] + n
        members = np.arange(r + 1, stop + 1) % n
        ids = np.concatenate([[rise_id[k]], piece_id[members], [fall_id[f]]])
        params = np.concatenate([[rise_u[k]], u[members], [fall_u[f]]])
        runs.append(_Run(ids, params, _tips(needles, ids, params, radius)))
    return runs


def _chain(runs: list[_Run], tolerance: float) -> tuple[list[int], bool, list[list[int]]]:
    """Link runs end-to-start into the boundary of the machined part.

    Starting from the longest run, each run is followed by the next one in path order whose start is
    its end (the corner where two envelope branches meet). Runs skipped over are the tails of an offset
    loop where the path is tighter than R: they lie within the scallop of the discrete cutter positions
    but not on the part. Returns the chain, whether it closes, and any further closed chains among the
    remaining runs (separate pieces of material: the part split).
    """
    main, closed = _follow(runs, max(range(len(runs)), key=lambda k: runs[k].size), set(), tolerance)
    used = set(main)
    extra = []
    for k in sorted(set(range(len(runs))) - used, key=lambda k: -runs[k].size):
        if k in used:
            continue
        loop, loop_closed = _follow(runs, k, used, tolerance)
        used.update(loop)
        if loop_closed and _area(runs, loop) > tolerance**2:
            extra.append(loop)
    return main, closed, extra


def _merge_corners(stretches: list[Array], closed: bool) -> Array:
    """Concatenate runs, putting each run's end and the next run's start on their midpoint.

    Both are within the bisection tolerance of the corner but each may lie a scallop past it; the
    midpoint keeps the two envelope branches from crossing there.
    """
    stretches = [s.copy() for s in stretches]
    pairs = len(stretches) if closed else len(stretches) - 1
    for k in range(pairs):
        nxt = stretches[(k + 1) % len(stretches)]
        corner = 0.5 * (stretches[k][-1] + nxt[0])
        stretches[k][-1] = corner
        nxt[0] = corner
    return np.vstack(stretches)


def _follow(runs: list[_Run], first: int, used: set[int], tolerance: float) -> tuple[list[int], bool]:
    chain, k, m = [first], first, len(runs)
    while True:
        successor = next((j % m for j in range(k + 1, k + m + 1)
                          if j % m not in used and (j % m == first or j % m not in chain)
                          and np.linalg.norm(runs[j % m].start - runs[k].end) <= tolerance), None)
        if successor is None:
            return chain, False
        if successor == first:
            return chain, True
        chain.append(successor)
        k = successor


def _area(runs: list[_Run], loop: list[int]) -> float:
    points = np.vstack([runs[k].points for k in loop])
    return abs(0.5 * np.sum(cross(points, np.roll(points, -1, axis=0))))


def _check_closed(pieces: list[BezierCurve], tolerance: float) -> None:
    for i, piece in enumerate(pieces):
        nxt = pieces[(i + 1) % len(pieces)]
        if np.linalg.norm(piece.end - nxt.start) > tolerance / 100:
            raise ValueError(f"tool path is not closed: piece {i} ends at {piece.end} but piece "
                             f"{(i + 1) % len(pieces)} starts at {nxt.start}")


def _needle_pieces(pieces: list[BezierCurve]) -> tuple[list[_Segment | _Fan], np.ndarray]:
    """Path pieces in path order with a fan after every concave (right-turn) junction, and for each
    needle piece the index of the tool-path piece it belongs to (a fan: the piece it follows)."""
    needles: list[_Segment | _Fan] = []
    source: list[int] = []
    for i, piece in enumerate(pieces):
        needles.append(_Segment(piece))
        source.append(i)
        t_in = piece.unit_tangent([1.0])[0]
        t_out = pieces[(i + 1) % len(pieces)].unit_tangent([0.0])[0]
        turn = np.arctan2(cross(t_in, t_out), np.dot(t_in, t_out))
        if turn < -_CORNER_ANGLE:
            n_in = rotate_left(t_in)
            theta0 = float(np.arctan2(n_in[1], n_in[0]))
            needles.append(_Fan(piece.end.copy(), theta0, theta0 + float(turn)))
            source.append(i)
    return needles, np.array(source)


def _cutter_positions(pieces: list[BezierCurve], radius: float, scallop: float) -> Array:
    """Discrete cutter centres along the path, spaced so that the scallop between two is ≤ ``scallop``.

    On the side where the path curves away from the material the envelope is stretched by 1 + R|κ|,
    so the spacing shrinks by the same factor there.
    """
    u = np.linspace(0.0, 1.0, DENSE)
    spacing = np.sqrt(8.0 * radius * scallop)
    centres = []
    for piece in pieces:
        speed = np.linalg.norm(piece.derivative(u, 1), axis=1)
        stretch = np.maximum(1.0, 1.0 - radius * piece.curvature(u)) if piece.degree > 1 else 1.0
        centres.append(piece.points(equidistribute(u, speed * stretch / spacing)))
    return np.concatenate(centres)


def _needle_samples(needles: list[_Segment | _Fan], radius: float, tolerance: float,
                    max_spacing: float) -> tuple[np.ndarray, Array]:
    ids, params = [], []
    for k, needle in enumerate(needles):
        u = needle.needle_parameters(radius, tolerance, max_spacing)
        ids.append(np.full(u.size, k))
        params.append(u)
    return np.concatenate(ids), np.concatenate(params)


def _tips(needles: list[_Segment | _Fan], piece_id: np.ndarray, u: Array, radius: float) -> Array:
    """Own tips p + R ν of the needles (piece_id, u)."""
    tips = np.empty((u.size, 2))
    for k in np.unique(piece_id):
        sel = piece_id == k
        base, normal = needles[k].frame(u[sel])
        tips[sel] = base + radius * normal
    return tips


def _uncut(tree: cKDTree, tips: Array, radius: float, tolerance: float) -> np.ndarray:
    """True where no cutter position lies strictly within R of the tip (the deepest cut is the own one).

    The margin tolerance·1e-3 keeps tips that lie exactly on a neighbouring cutter's circle (straight
    path, corner vertex) from being called cut by round-off.
    """
    distance, _ = tree.query(tips, k=1)
    return distance >= radius - 1e-3 * tolerance


def _bisect(needles, tree, piece_id, u, lo_idx, hi_idx, lo_kept: bool, radius, tolerance):
    """Bisect between needles lo_idx (status lo_kept) and hi_idx, on the same needle piece, until the
    tips are within tolerance/8; returns (piece, parameter) of the kept end. Transitions across a piece
    junction are not refined: the junction is then the corner itself."""
    pid = piece_id[lo_idx].copy()
    same = piece_id[hi_idx] == pid
    a = u[lo_idx].copy()
    b = np.where(same, u[hi_idx], 1.0)
    for _ in range(60):
        mid = 0.5 * (a + b)
        kept = _uncut(tree, _tips(needles, pid, mid, radius), radius, tolerance)
        lo_side = kept if lo_kept else ~kept
        a = np.where(same & lo_side, mid, a)
        b = np.where(same & ~lo_side, mid, b)
        gap = np.linalg.norm(_tips(needles, pid, a, radius) - _tips(needles, pid, b, radius), axis=1)
        if not (same & (gap > tolerance / 8)).any():
            break
    if lo_kept:
        return pid, a
    return np.where(same, pid, piece_id[hi_idx]), np.where(same, b, u[hi_idx])


def _deduplicate(points: Array, distance: float) -> np.ndarray:
    """Indices of the points that remain after dropping those closer than ``distance`` to the point
    before them; the first point stays, and a last point that closes onto the first is dropped."""
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], step > distance])
    idx = np.flatnonzero(keep)
    if idx.size > 1 and np.linalg.norm(points[idx[-1]] - points[0]) <= distance:
        idx = idx[:-1]
    return idx
