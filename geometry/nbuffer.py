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
   closer than the tolerance, then the corner where the two envelope branches intersect is solved for
   exactly (the bisection alone can miss a sharp tip by (ε/4)/sin θ, θ the angle of the branches).
4. *Linking*: runs of uncut needles are linked end to start at their corners into closed outlines. Where
   the two ends of a cut stretch do not meet, material vanished between them, and a second closed
   outline is a second piece: the part split. A run left over is dropped only as the tail of an offset
   loop (cut by denser cutter positions, or outside the stock); any other is reported as unlinked.

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

    def tip_derivative(self, u: Array, radius: float) -> Array:
        """d(tip)/du of the tips centre + R (cos θ, sin θ), m per unit parameter."""
        theta = self.theta0 + (self.theta1 - self.theta0) * u
        return radius * (self.theta1 - self.theta0) * np.stack([-np.sin(theta), np.cos(theta)], 1)


@dataclass(frozen=True)
class _Segment:
    """A piece of the tool path seen by the needles: base point on the curve, inward (left) normal."""

    curve: BezierCurve

    def frame(self, u: Array) -> tuple[Array, Array]:
        return self.curve.points(u), rotate_left(self.curve.unit_tangent(u))

    def needle_parameters(self, radius: float, tolerance: float, max_spacing: float) -> Array:
        u = np.linspace(0.0, 1.0, DENSE)
        return equidistribute(u, chord_density(self.curve, u, tolerance, max_spacing, offset=radius))

    def tip_derivative(self, u: Array, radius: float) -> Array:
        """d(tip)/du of the offset Q + R ν: Q' (1 − R κ), since dν/du = −κ |Q'| t (κ signed, left > 0)."""
        return self.curve.derivative(u, 1) * (1.0 - radius * self.curve.curvature(u))[:, None]


@dataclass(frozen=True)
class MachinedBoundary:
    """Result of :func:`machine`.

    Attributes
    ----------
    points: ``(n, 2)`` counter-clockwise machined boundary, metres, first point not repeated. It starts at
        the point where the path's first piece begins (σ = 0; for a blade, the pressure-side trailing-edge
        corner) or, if the cutter removed that point, the first machined point after it.
    piece: ``(n,)`` index of the tool-path piece whose cutter left each point (a corner arc counts for
        the piece it follows).
    sigma: ``(n,)`` position along the path: piece index + parameter of the piece, in [0, len(pieces)];
        points on a corner arc take the junction's value. A corner shared by two envelope branches takes
        the label nearest a piece junction (so the blade's corners read σ = 0, 1, 2).
    gouged_fraction: share of needles whose own tip was removed by another cutter position.
    split: True if the material left is not one piece: two ends of a removed stretch do not meet, or
        uncut needles form a second closed outline.
    pieces: number of closed outlines found (1 for an intact part).
    other_outlines: the closed outlines of the further pieces of a split part, each ``(k, 2)``
        counter-clockwise, metres, first point not repeated.
    gaps: ``(k, 2, 2)`` end points of the removed stretches that do not close, or a point of each further
        outline twice (empty unless ``split``).
    unlinked: ``(k, 2)`` a point of each stretch of machined surface that could not be linked into any
        closed outline (empty for a sound result; otherwise the boundary is undetermined).
    spurious_runs: uncut stretches dropped as tails of an offset loop (path tighter than R): they survive
        only in the scallop between two discrete cutter positions and are cut by 16 times denser ones.
    cutter_positions: number of discrete cutter positions used.
    """

    points: Array
    piece: np.ndarray
    sigma: Array
    gouged_fraction: float
    split: bool
    pieces: int
    other_outlines: tuple[Array, ...]
    gaps: Array
    unlinked: Array
    spurious_runs: int
    cutter_positions: int

    @property
    def intact(self) -> bool:
        """One closed outline, nothing left over: the machined part is a single piece."""
        return self.points.shape[0] >= 3 and not self.split and self.unlinked.shape[0] == 0


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
        return MachinedBoundary(np.empty((0, 2)), np.empty(0, int), np.empty(0), 1.0, True, 0,
                                (), np.empty((0, 2, 2)), np.empty((0, 2)), 0, len(cutters))
    runs = _uncut_runs(needles, tree, piece_id, u, kept, radius, tolerance)
    chain, closed, extra = _chain(runs, _Corners(needles, tree, radius, tolerance))
    linked = set(chain.runs).union(*(loop.runs for loop in extra))
    leftover = [k for k in range(len(runs)) if k not in linked]
    unlinked = _machined_leftovers(runs, leftover, pieces, radius, tolerance)

    ids, loc, points = chain.joined(runs)
    keep, owner = _deduplicate(points, tolerance / 100)
    is_fan = np.array([isinstance(n, _Fan) for n in needles])[ids]
    sigma = np.mod(source[ids] + np.where(is_fan, 1.0, loc), len(pieces))
    label = _corner_labels(sigma, owner, keep.size)
    points, ids, sigma = points[keep], ids[label], sigma[label]
    first = int(np.argmin(np.minimum(sigma, len(pieces) - sigma)))  # nearest σ = 0, cyclically
    points, ids, sigma = (np.roll(a, -first, axis=0) for a in (points, ids, sigma))

    gaps = [] if closed else [np.stack([runs[chain.runs[-1]].end, runs[chain.runs[0]].start])]
    gaps += [np.stack([runs[loop.runs[0]].start] * 2) for loop in extra]
    return MachinedBoundary(points, source[ids], sigma, float(1.0 - kept.mean()), bool(gaps),
                            int(closed) + len(extra), tuple(_outline(loop, runs, tolerance) for loop in extra),
                            np.array(gaps).reshape(-1, 2, 2),
                            np.array([runs[k].points[runs[k].size // 2] for k in unlinked]).reshape(-1, 2),
                            len(leftover) - len(unlinked), len(cutters))


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


def _outline(chain: _Chain, runs: list[_Run], tolerance: float) -> Array:
    points = chain.joined(runs)[2]
    return points[_deduplicate(points, tolerance / 100)[0]]


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


@dataclass(frozen=True)
class _Corner:
    """Where a run ends and the next one starts: the point and the parameters of both needles there."""

    point: Array
    u_end: float  # on the last needle piece of the run that ends here
    u_start: float  # on the first needle piece of the run that starts here


_CORNER_REACH = 64.0  # tolerances: how far a bisected run end may lie from the exact corner it belongs to
_NEWTON_STEPS = 30


@dataclass(frozen=True)
class _Corners:
    """Finds the run that follows a run's end, and the exact corner where the two meet.

    The bisection pins a run end to within tolerance/8 of where its needles' status changes, but that
    status comes from discrete cutter positions whose scallop is tolerance/4 deep: where two envelope
    branches meet at an angle θ, the change can lie (tolerance/4)/sin θ along the branch from the true
    corner, several micrometres at a sharp tip. The corner is therefore solved for exactly, as the
    intersection of the two branches (the tip curves of the run's last and the next run's first needle
    piece), by Newton's method from the bisected parameters.
    """

    needles: list
    tree: cKDTree
    radius: float
    tolerance: float

    def successor(self, runs: list[_Run], k: int, candidates: list[int]) -> tuple[int, _Corner] | None:
        """The first candidate, in path order after ``k``, whose start is the end of run ``k``.

        First choice: a start within the tolerance of the end (its corner refined when the branches
        intersect there). Otherwise: a start within reach of an exact corner of the two branches (a sharp
        tip). ``None`` if no run starts there: the part is split or the boundary undetermined.
        """
        m = len(runs)
        order = [j % m for j in range(k + 1, k + m + 1) if j % m in candidates]
        gap = {j: float(np.linalg.norm(runs[j].start - runs[k].end)) for j in order}
        for j in order:
            if gap[j] <= self.tolerance:
                exact = self.exact(runs[k], runs[j])
                return j, exact or _Corner(0.5 * (runs[k].end + runs[j].start), runs[k].params[-1], runs[j].params[0])
        for j in order:
            if gap[j] <= _CORNER_REACH * self.tolerance and (exact := self.exact(runs[k], runs[j])) is not None:
                return j, exact
        return None

    def exact(self, a: _Run, b: _Run) -> _Corner | None:
        """The intersection of the branches of a's last and b's first needle, or ``None`` if Newton's
        method does not find one on both needle pieces, within reach of both ends and left uncut."""
        na, nb = self.needles[a.ids[-1]], self.needles[b.ids[0]]
        ua, ub = float(a.params[-1]), float(b.params[0])
        for _ in range(_NEWTON_STEPS):
            f = self._tip(na, ua) - self._tip(nb, ub)
            if np.linalg.norm(f) <= 1e-3 * self.tolerance:
                break
            da = na.tip_derivative(np.array([ua]), self.radius)[0]
            db = nb.tip_derivative(np.array([ub]), self.radius)[0]
            det = cross(da, -db)
            if not abs(det) > 1e-9 * np.linalg.norm(da) * np.linalg.norm(db):
                return None  # tangent branches (or a degenerate tip curve): no isolated corner
            ua, ub = ua + cross(-f, -db) / det, ub + cross(da, -f) / det
            if not (-1.0 < ua < 2.0 and -1.0 < ub < 2.0):
                return None
        else:
            return None
        if not (-1e-9 <= ua <= 1.0 + 1e-9 and -1e-9 <= ub <= 1.0 + 1e-9):
            return None  # the branches meet beyond a needle piece: not this corner
        ua, ub = min(max(ua, 0.0), 1.0), min(max(ub, 0.0), 1.0)
        point = 0.5 * (self._tip(na, ua) + self._tip(nb, ub))
        reach = _CORNER_REACH * self.tolerance
        if max(np.linalg.norm(point - a.end), np.linalg.norm(point - b.start)) > reach:
            return None
        if not _uncut(self.tree, point[None], self.radius, self.tolerance)[0]:
            return None  # a third branch cuts the crossing: the corner lies elsewhere
        return _Corner(point, ua, ub)

    def _tip(self, needle, u: float) -> Array:
        base, normal = needle.frame(np.array([u]))
        return base[0] + self.radius * normal[0]


@dataclass(frozen=True)
class _Chain:
    """Runs linked end to start, with the corner after each (the last one only if ``closed``)."""

    runs: list[int]
    corners: list[_Corner]
    closed: bool

    def joined(self, runs: list[_Run]) -> tuple[np.ndarray, Array, Array]:
        """Needle pieces, parameters and points of the chained runs, each run's end and its successor's
        start put on their common corner (both labels kept: the corner belongs to both branches)."""
        parts = [(runs[k].ids, runs[k].params.copy(), runs[k].points.copy()) for k in self.runs]
        for i, corner in enumerate(self.corners):
            (_, u_end, end), (_, u_start, start) = parts[i], parts[(i + 1) % len(parts)]
            u_end[-1], u_start[0] = corner.u_end, corner.u_start
            end[-1] = corner.point
            start[0] = corner.point
        return tuple(np.concatenate(column) for column in zip(*parts, strict=True))

    def area(self, runs: list[_Run]) -> float:
        points = np.vstack([runs[k].points for k in self.runs])
        return abs(0.5 * np.sum(cross(points, np.roll(points, -1, axis=0))))


def _chain(runs: list[_Run], corners: _Corners) -> tuple[_Chain, bool, list[_Chain]]:
    """Link runs end-to-start into the boundary of the machined part.

    Starting from the longest run, each run is followed by the next one in path order whose start is
    its end (the corner where two envelope branches meet). Returns the chain, whether it closes, and any
    further closed chains among the remaining runs with an area above tolerance² (separate pieces of
    material: the part split). Runs on none of them are left for :func:`_machined_leftovers` to judge.
    """
    main = _follow(runs, max(range(len(runs)), key=lambda k: runs[k].size), set(), corners)
    used = set(main.runs)
    extra = []
    for k in sorted(set(range(len(runs))) - used, key=lambda k: -runs[k].size):
        if k in used:
            continue
        loop = _follow(runs, k, used, corners)
        if loop.closed and loop.area(runs) > corners.tolerance**2:
            extra.append(loop)
            used.update(loop.runs)
    return main, main.closed, extra


def _follow(runs: list[_Run], first: int, used: set[int], corners: _Corners) -> _Chain:
    chain, links, k = [first], [], first
    while True:
        candidates = [j for j in range(len(runs)) if j not in used and (j == first or j not in chain)]
        found = corners.successor(runs, k, candidates)
        if found is None:
            return _Chain(chain, links, False)
        successor, corner = found
        links.append(corner)
        if successor == first:
            return _Chain(chain, links, True)
        chain.append(successor)
        k = successor


def _machined_leftovers(runs: list[_Run], leftover: list[int], pieces: list[BezierCurve], radius: float,
                        tolerance: float) -> list[int]:
    """The leftover runs that are machined surface, not tails of an offset loop.

    A needle of real surface is inside the stock (the region the path encloses) and R from the whole
    continuous path, so no cutter position cuts it, however dense. A tail is not: either it survives only
    in the scallop between two discrete cutter positions (cutter positions 16 times denser, with a scallop
    256 times shallower, cut it), or it lies outside the stock, where a path that is tighter than R, or
    has a cusp, turns its offset. A run with a needle of real surface is a piece of the part that the
    chaining could not place, and must not be dropped.
    """
    if not leftover:
        return []
    # Inside or outside the stock needs the path only to well within R: the tips are R from it.
    stock = np.vstack([piece.points(np.linspace(0.0, 1.0, DENSE))[:-1] for piece in pieces])
    inside = [_inside(stock, runs[k].points[1:-1]) for k in leftover]
    if not any(len(tips) for tips in inside):
        return []
    fine = cKDTree(_cutter_positions(pieces, radius, tolerance / 4 / 256))
    return [k for k, tips in zip(leftover, inside, strict=True) if _uncut(fine, tips, radius, tolerance).any()]


def _inside(loop: Array, points: Array, chunk: int = 64) -> Array:
    """The ``points`` around which the closed polyline ``loop`` winds counter-clockwise (chunked: bounded
    memory for long runs and finely sampled paths)."""
    winding = np.concatenate([_winding_number(loop, points[i : i + chunk]) for i in range(0, len(points), chunk)]
                             or [np.empty(0, int)])
    return points[winding > 0]


def _winding_number(loop: Array, points: Array) -> np.ndarray:
    """How many times the closed polyline ``loop`` (``(m, 2)``) winds counter-clockwise around each point."""
    a, b = loop[None, :, :], np.roll(loop, -1, axis=0)[None, :, :]
    p = points[:, None, :]
    left = cross(b - a, p - a)
    up = (a[..., 1] <= p[..., 1]) & (b[..., 1] > p[..., 1]) & (left > 0)
    down = (b[..., 1] <= p[..., 1]) & (a[..., 1] > p[..., 1]) & (left < 0)
    return up.sum(axis=1) - down.sum(axis=1)


def _corner_labels(sigma: Array, owner: np.ndarray, count: int) -> np.ndarray:
    """For each of ``count`` merged points, the index of the member whose σ lies nearest a piece junction.

    A corner point is the end of one branch and the start of another (and, at a smooth junction, the
    last needle of one piece and the first of the next); the member nearest an integer σ says which
    junction it is, e.g. the pressure-side trailing-edge corner is σ = 0 although the trailing-edge face
    reaches it first.
    """
    offset = np.abs(sigma - np.round(sigma))
    order = np.lexsort((offset, owner))  # by owner, then by distance to a junction
    firsts = np.flatnonzero(np.r_[True, np.diff(owner[order]) != 0])
    label = np.empty(count, int)
    label[owner[order[firsts]]] = order[firsts]
    return label


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


def _deduplicate(points: Array, distance: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the points that remain after dropping those closer than ``distance`` to the point
    before them (the first point stays, and a last point that closes onto the first is dropped), and for
    every point the position in that index list of the point it merged into."""
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], step > distance])
    owner = np.cumsum(keep) - 1
    idx = np.flatnonzero(keep)
    if idx.size > 1 and np.linalg.norm(points[idx[-1]] - points[0]) <= distance:
        owner[idx[-1]:] = 0
        idx = idx[:-1]
    return idx, owner
