"""Structured C-mesh of quads around the NASA TMR NACA 0012 (closed trailing edge, chord 1): numpy only,
deterministic.

Geometry (TMR "2D NACA 0012 Airfoil Validation Case", sharp trailing edge at x = 1)::

    y = ±0.594689181 (0.298222773 √x − 0.127125232 x − 0.357907906 x² + 0.291984971 x³ − 0.105174606 x⁴)

Topology (index ``i`` along the C, ``j`` away from the wall)::

    i = 0 .. n_wake                      wake cut, lower side (x = x_out -> 1, y = 0)
    i = n_wake .. n_wake + n_side        lower surface, trailing edge -> leading edge
    i = .. n_wake + 2 n_side             upper surface, leading edge -> trailing edge
    i = .. 2 n_wake + 2 n_side = N       wake cut, upper side (x = 1 -> x_out)

The nodes of the two wake-cut sides are the same nodes (no internal boundary). Construction (algebraic):

* surface nodes exactly on the polynomial, spaced by arc length with Vinokur's two-sided tanh stretching
  (``ds_le`` at the leading edge, ``ds_te`` at the trailing edge); wake-cut nodes geometric from ``ds_te``
  to the outflow plane x_out = 1 + radius;
* far-field nodes on the C line made of the half circle of radius ``radius + 1`` centred at the trailing
  edge and the two lines y = ±(radius + 1) (:func:`_outer_boundary`), so every far-field point is at
  least ``radius`` from the airfoil;
* wall-normal stations: first layer ``first_cell``, geometric growth ``growth`` (<= 1.2) up to a layer
  thickness ``switch``, then ``far_growth``, rescaled smoothly (``(s/L)²`` term, negligible near the wall)
  to end on the far-field point;
* each ``i`` line leaves its wall node along the wall normal (normals smoothed by ``normal_smoothing``
  Jacobi passes, which fans out the trailing-edge kink over a few cells: the only place where the first
  cell is not normal to the wall, by <= 4.4°) and turns, between arc lengths ``blend`` (0.02 and 0.2
  chords), to the straight line towards its far-field point;
* the lower half is the exact mirror of the upper half (symmetric mesh: C_L = 0 at α = 0 up to round-off
  and solver ordering).

Quality (:func:`quality`, checked in ``tests/test_solver_naca0012.py``): all cell areas > 0 and no folded
faces (``build_fvmesh`` checks both), wall orthogonality <= 4.4° (trailing-edge cells; <= 1.6° elsewhere),
first cell = ``first_cell`` along the wall, wall-normal growth <= ``growth``, far field >= ``radius``,
max non-orthogonality ~54° (in the far wake and at the blend zone), aspect ratio up to ~2e7 (first layers
of the far wake cut: thin like the wall layers, 10-20 chords long).

Boundary groups: ``wall`` (airfoil), and the far field split by the sign of ``U∞·n`` (n outward) for the
freestream direction ``alpha_deg``: ``farfield_in`` where ``U∞·n < -inflow_tol |U∞|`` (inflow: velocity
inlet), ``farfield_out`` elsewhere (the outflow plane, the downstream part of the C line and, at α = 0, the
two lines y = ±(radius + 1) where the flow is tangential: pressure outlet).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...fvmesh import FVMesh, build_fvmesh

#: TMR NACA 0012 coefficients (closed trailing edge at x = 1).
SCALE = 0.594689181
COEFFS = (0.298222773, -0.127125232, -0.357907906, 0.291984971, -0.105174606)


def naca0012_half_thickness(x) -> np.ndarray:
    """Upper-surface y of the TMR NACA 0012 at ``x`` in [0, 1] (exactly 0 at both ends up to round-off)."""
    x = np.clip(np.asarray(x, float), 0.0, 1.0)
    a0, a1, a2, a3, a4 = COEFFS
    return SCALE * (a0 * np.sqrt(x) + x * (a1 + x * (a2 + x * (a3 + x * a4))))


def _surface_xy(t: np.ndarray) -> np.ndarray:
    """Upper surface points at parameter ``t`` in [0, 1] with ``x = t²`` (smooth at the leading edge)."""
    x = t * t
    a0, a1, a2, a3, a4 = COEFFS
    y = SCALE * (a0 * t + x * (a1 + x * (a2 + x * (a3 + x * a4))))
    return np.column_stack([x, y])


def _arc_length_table(n: int = 200_001) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    p = _surface_xy(t)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    return t, s


def vinokur(n: int, ds_start: float, ds_end: float) -> np.ndarray:
    """``n + 1`` points on [0, 1] with first and last spacings ``ds_start``, ``ds_end`` (fractions of the
    length): Vinokur's (1983) two-sided tanh stretching."""
    a = np.sqrt(ds_end / ds_start)
    b = 1.0 / (n * np.sqrt(ds_start * ds_end))
    xi = np.arange(n + 1) / n
    if abs(b - 1.0) < 1e-9:
        u = xi
    else:
        from scipy.optimize import brentq

        if b > 1.0:
            d = brentq(lambda d: np.sinh(d) / d - b, 1e-9, 50.0)
            u = 0.5 * (1.0 + np.tanh(d * (xi - 0.5)) / np.tanh(0.5 * d))
        else:
            d = brentq(lambda d: np.sin(d) / d - b, 1e-9, np.pi - 1e-9)
            u = 0.5 * (1.0 + np.tan(d * (xi - 0.5)) / np.tan(0.5 * d))
    s = u / (a + (1.0 - a) * u)
    s[0], s[-1] = 0.0, 1.0
    return s


def surface_points(n_side: int, ds_le: float, ds_te: float) -> np.ndarray:
    """``n_side + 1`` upper-surface points from the leading edge (0, 0) to the trailing edge (1, 0), exactly on
    the TMR curve, spaced by arc length with leading/trailing-edge spacings ``ds_le``, ``ds_te`` (chords)."""
    t, s = _arc_length_table()
    total = s[-1]
    target = vinokur(n_side, ds_le / total, ds_te / total) * total
    p = _surface_xy(np.interp(target, s, t))
    p[0] = (0.0, 0.0)
    p[-1] = (1.0, 0.0)
    return p


def geometric_count(first: float, length: float, ratio: float) -> int:
    """Number of geometric cells (first ``first``, ratio ``ratio``) needed to cover ``length``."""
    return int(np.ceil(np.log1p(length * (ratio - 1.0) / first) / np.log(ratio)))


def geometric_points(first: float, length: float, n: int) -> np.ndarray:
    """``n + 1`` points on [0, length] with first spacing ``first`` and a constant growth ratio."""
    from scipy.optimize import brentq

    if first * n >= length:
        return np.linspace(0.0, length, n + 1)
    r = brentq(lambda r: first * (r**n - 1.0) / (r - 1.0) - length, 1.0 + 1e-12, 10.0)
    x = np.concatenate([[0.0], np.cumsum(first * r ** np.arange(n))])
    return x * (length / x[-1])


def layer_thicknesses(first: float, growth: float, switch: float, far_growth: float, radius: float) -> np.ndarray:
    """Wall-normal layer thicknesses: ``first``, growing by ``growth`` up to ``switch``, then by ``far_growth``
    until their sum reaches ``radius``."""
    h, out = first, []
    while sum(out) < radius:
        out.append(h)
        h *= growth if h < switch else far_growth
    return np.array(out)


@dataclass(frozen=True)
class CMeshSpec:
    """Parameters of :func:`naca0012_cmesh` (lengths in chords)."""

    n_side: int = 64            # cells along each surface (leading edge -> trailing edge)
    n_wake: int = 32            # cells along the wake cut (trailing edge -> outflow plane)
    ds_le: float = 1.5e-3       # surface spacing at the leading edge
    ds_te: float = 3e-3         # surface spacing at the trailing edge (= first wake cell)
    first_cell: float = 1e-6    # wall-normal thickness of the first cell
    growth: float = 1.15        # layer growth near the wall (<= 1.2)
    switch: float = 0.01        # layer thickness from which far_growth applies
    far_growth: float = 1.3     # layer growth away from the wall
    radius: float = 100.0       # far-field distance (from the airfoil; outflow plane at x = 1 + radius)
    blend: tuple = (0.02, 0.2)  # arc lengths between which the lines turn from the wall normal to straight
    normal_smoothing: int = 20  # Jacobi passes smoothing the wall normals (the trailing-edge kink)


#: Resolution levels (cells: coarse 10 800 = 144 x 75, medium 21 728 = 224 x 97, fine 41 184 = 352 x 117).
LEVELS: dict[str, CMeshSpec] = {
    "coarse": CMeshSpec(n_side=48, n_wake=24, ds_le=2e-3, ds_te=4e-3, first_cell=2e-6, growth=1.2,
                        far_growth=1.35),
    "medium": CMeshSpec(n_side=80, n_wake=32, ds_le=1e-3, ds_te=2.5e-3, first_cell=1e-6, growth=1.15,
                        far_growth=1.3),
    "fine": CMeshSpec(n_side=128, n_wake=48, ds_le=5e-4, ds_te=1.5e-3, first_cell=1e-6, growth=1.12,
                      far_growth=1.25),
}


def _normals(p: np.ndarray, smooth_passes: int = 0) -> np.ndarray:
    """Unit normals to the left of the polyline ``p`` (outward, away from the wall), optionally smoothed by
    ``smooth_passes`` Jacobi averaging passes (end normals kept)."""
    t = np.empty_like(p)
    t[1:-1] = p[2:] - p[:-2]
    t[0] = p[1] - p[0]
    t[-1] = p[-1] - p[-2]
    n = np.column_stack([-t[:, 1], t[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    for _ in range(smooth_passes):
        n[1:-1] = 0.5 * n[1:-1] + 0.25 * (n[:-2] + n[2:])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n


def _outer_boundary(front0: np.ndarray, n_wake: int, n_side: int, radius: float) -> np.ndarray:
    """Far-field point for each inner point on the C line made of the two lines y = ∓(radius + 1),
    1 <= x <= x_out, and the half circle of radius ``radius + 1`` centred at the trailing edge (1, 0).
    Wake nodes map to the lines and airfoil nodes to the half circle (trailing edge at ∓90°, leading edge at
    180°), each at the mean of its fraction of the segment (x or arc length) and its index fraction, so that
    the far-field spacing is not clustered like the wall spacing."""
    big = radius + 1.0
    out = np.empty_like(front0)
    n = front0.shape[0] - 1
    xw = front0[n - n_wake:, 0]                                       # upper wake: 1 -> x_out
    frac = 0.5 * (xw - 1.0) / (xw[-1] - 1.0) + 0.5 * np.arange(n_wake + 1) / n_wake
    x_far = 1.0 + frac * (xw[-1] - 1.0)
    out[n - n_wake:] = np.column_stack([x_far, np.full(n_wake + 1, big)])
    out[:n_wake + 1] = out[n - n_wake:][::-1] * (1.0, -1.0)
    side = front0[n_wake + n_side:n - n_wake + 1]                     # upper: leading edge -> trailing edge
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(side, axis=0), axis=1))])
    frac = 0.5 * s / s[-1] + 0.5 * np.arange(n_side + 1) / n_side
    theta = np.pi - 0.5 * np.pi * frac
    up = np.column_stack([1.0 + big * np.cos(theta), big * np.sin(theta)])
    up[0, 1], up[-1, 0] = 0.0, 1.0
    out[n_wake + n_side:n - n_wake + 1] = up
    out[n_wake:n_wake + n_side + 1] = up[::-1] * (1.0, -1.0)
    return out


def _blend_lines(front0, outer, s, s_blend, smooth_passes):
    """Node coordinates ``(N + 1, J + 1, 2)``: from each inner point a curve that leaves along the (smoothed)
    wall normal and turns, between arc lengths ``s_blend = (s_a, s_b)``, towards the straight line to its
    far-field point; ``s (N + 1, J + 1)`` are the arc-length stations. The end mismatch is removed by a
    correction growing like ``(s / L)²`` (negligible near the wall)."""
    nrm = _normals(front0, smooth_passes)
    nrm[0], nrm[-1] = (0.0, -1.0), (0.0, 1.0)
    chord = outer - front0
    length = np.linalg.norm(chord, axis=1)
    e = chord / length[:, None]
    s_a, s_b = s_blend
    sm = 0.5 * (s[:, 1:] + s[:, :-1])
    z = np.clip((np.log(np.maximum(sm, 1e-300)) - np.log(s_a)) / (np.log(s_b) - np.log(s_a)), 0.0, 1.0)
    w = (z * z * (3.0 - 2.0 * z))[..., None]
    d = (1.0 - w) * nrm[:, None, :] + w * e[:, None, :]
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    ds = np.diff(s, axis=1)[..., None]
    xy = np.concatenate([front0[:, None, :], front0[:, None, :] + np.cumsum(d * ds, axis=1)], axis=1)
    phi = (s / s[:, -1:]) ** 2
    xy += phi[..., None] * (outer - xy[:, -1])[:, None, :]
    return xy


@dataclass(frozen=True)
class CMesh:
    """A structured C-mesh: node coordinates ``xy (N + 1, J + 1, 2)``, node ids ``nid`` (wake cut merged),
    the spec, and the built :class:`FVMesh`."""

    xy: np.ndarray
    nid: np.ndarray
    spec: CMeshSpec
    mesh: FVMesh

    @property
    def wall_range(self) -> tuple[int, int]:
        """First and last node ``i`` of the airfoil (trailing edge, lower -> upper)."""
        nw, ns = self.spec.n_wake, self.spec.n_side
        return nw, nw + 2 * ns


def naca0012_cmesh(spec: CMeshSpec | str = "medium", alpha_deg: float = 0.0, inflow_tol: float = 1e-3) -> CMesh:
    """Build the C-mesh of ``spec`` (a :class:`CMeshSpec` or a level name of :data:`LEVELS`) with the far
    field split into ``farfield_in`` / ``farfield_out`` for a freestream at ``alpha_deg``
    (``U∞·n / |U∞| < -inflow_tol`` is inflow)."""
    if isinstance(spec, str):
        if spec not in LEVELS:
            raise ValueError(f"unknown level {spec!r}; choose from {sorted(LEVELS)}")
        spec = LEVELS[spec]
    ns, nw = spec.n_side, spec.n_wake
    upper = surface_points(ns, spec.ds_le, spec.ds_te)
    lower = upper[::-1] * (1.0, -1.0)                       # trailing edge -> leading edge
    xw = 1.0 + geometric_points(spec.ds_te, spec.radius, nw)
    wake_up = np.column_stack([xw, np.zeros_like(xw)])
    front0 = np.concatenate([wake_up[::-1], lower[1:], upper[1:], wake_up[1:]])
    n_i = front0.shape[0] - 1                               # = 2 nw + 2 ns
    layers = layer_thicknesses(spec.first_cell, spec.growth, spec.switch, spec.far_growth, spec.radius)
    s = np.broadcast_to(np.concatenate([[0.0], np.cumsum(layers)]), (n_i + 1, layers.size + 1))
    outer = _outer_boundary(front0, nw, ns, spec.radius)
    length = np.linalg.norm(outer - front0, axis=1)[:, None]
    s = s + (length - s[:, -1:]) * (s / s[:, -1:]) ** 2        # end at the far-field point, smoothly
    xy = _blend_lines(front0, outer, s, spec.blend, spec.normal_smoothing)
    n_j = xy.shape[1] - 1
    # node ids: (i, j) row-major; the lower wake-cut nodes (i <= nw, j = 0) are the upper ones (N - i, 0)
    nid = np.arange((n_i + 1) * (n_j + 1)).reshape(n_i + 1, n_j + 1)
    i_low = np.arange(nw + 1)
    nid[i_low, 0] = nid[n_i - i_low, 0]
    used = np.unique(nid)
    remap = np.full(nid.max() + 1, -1)
    remap[used] = np.arange(used.size)
    nid = remap[nid]
    pts = np.empty((used.size, 2))
    pts[nid.ravel()] = xy.reshape(-1, 2)
    pts[nid[n_i - i_low, 0]] = xy[n_i - i_low, 0]            # upper-side coordinates for merged nodes
    i, j = np.meshgrid(np.arange(n_i), np.arange(n_j), indexing="ij")
    i, j = i.ravel(), j.ravel()
    quads = np.column_stack([nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]])
    iw = np.arange(nw, nw + 2 * ns)
    wall = np.column_stack([nid[iw, 0], nid[iw + 1, 0]])
    # far-field edges with outward normals, oriented along the CCW traversal of their cell
    jj = np.arange(n_j)
    outer_i = np.arange(n_i)
    edges = np.concatenate([
        np.column_stack([nid[outer_i + 1, n_j], nid[outer_i, n_j]]),     # outer C line
        np.column_stack([nid[0, jj + 1], nid[0, jj]]),                    # outflow plane, lower (i = 0)
        np.column_stack([nid[n_i, jj], nid[n_i, jj + 1]]),                # outflow plane, upper (i = N)
    ])
    e = pts[edges[:, 1]] - pts[edges[:, 0]]
    normal = np.column_stack([e[:, 1], -e[:, 0]]) / np.hypot(e[:, 0], e[:, 1])[:, None]
    a = np.radians(alpha_deg)
    un = normal @ np.array([np.cos(a), np.sin(a)])
    inflow = un < -inflow_tol
    boundary = {"wall": wall, "farfield_in": edges[inflow], "farfield_out": edges[~inflow]}
    mesh = build_fvmesh(pts, {"quad": quads}, boundary)
    mesh.info.update(kind="naca0012_cmesh", n_i=n_i, n_j=n_j, first_cell=spec.first_cell,
                     radius=spec.radius, alpha_deg=float(alpha_deg))
    return CMesh(xy, nid, spec, mesh)


def quality(cm: CMesh) -> dict:
    """Mesh checks: cells, smallest cell area, wall orthogonality (max angle between the first ``j`` line and
    the wall normal, degrees), first-cell height range (wall-normal distance of the first node off the
    wall), largest wall-normal growth ratio in the first 30 layers over the airfoil, far-field distance
    (smallest distance of a far-field node from the chord line), max aspect ratio, max non-orthogonality
    (degrees, angle between the face normal and the owner -> neighbour vector)."""
    m, xy = cm.mesh, cm.xy
    i0, i1 = cm.wall_range
    w = xy[i0:i1 + 1]
    t = np.empty((w.shape[0], 2))
    t[1:-1] = w[2:, 0] - w[:-2, 0]
    t[0], t[-1] = w[1, 0] - w[0, 0], w[-1, 0] - w[-2, 0]
    nrm = np.column_stack([-t[:, 1], t[:, 0]])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    d1 = w[:, 1] - w[:, 0]
    h1 = np.einsum("ij,ij->i", d1, nrm)
    cosang = np.clip(h1 / np.linalg.norm(d1, axis=1), -1.0, 1.0)
    inner = slice(1, -1)                          # the trailing-edge nodes have no single normal
    dj = np.linalg.norm(np.diff(w, axis=1), axis=2)
    ratio = dj[:, 1:31] / dj[:, :30]
    ff = np.concatenate([xy[:, -1], xy[0], xy[-1]])
    dist = np.hypot(ff[:, 0] - np.clip(ff[:, 0], 0.0, 1.0), ff[:, 1])
    ni = m.n_internal
    dn = m.d[:ni] / np.linalg.norm(m.d[:ni], axis=1, keepdims=True)
    nonorth = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", dn, m.normal[:ni]), -1, 1)))
    q = xy[:, :, :]
    di = np.linalg.norm(np.diff(q, axis=0), axis=2)[:, :-1]
    dj_all = np.linalg.norm(np.diff(q, axis=1), axis=2)[:-1, :]
    ar = np.maximum(di / dj_all, dj_all / di)
    return dict(cells=m.n_cells, min_area=float(m.volume.min()),
                wall_orthogonality_max_deg=float(np.degrees(np.arccos(cosang[inner])).max()),
                first_cell_min=float(h1[inner].min()), first_cell_max=float(h1[inner].max()),
                wall_growth_max=float(ratio[inner].max()), farfield_distance_min=float(dist.min()),
                aspect_ratio_max=float(ar.max()), non_orthogonality_max_deg=float(nonorth.max()),
                non_orthogonality_mean_deg=float(nonorth.mean()))
