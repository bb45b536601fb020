"""Unstructured meshes from the gmsh Python API (optional dependency ``gmsh``)."""

from __future__ import annotations

import contextlib

import numpy as np

from ...fvmesh import FVMesh, build_fvmesh


def gmsh_square(h: float, *, quads: str | bool = False, size: float = 1.0, algorithm: int = 6,
                refine: int = 0) -> FVMesh:
    """Unstructured mesh of ``[0, size]²`` with target cell size ``h`` (m), groups ``bottom, right, top,
    left``.

    quads: ``False``/``"none"``: triangles only; ``True``/``"all"``: recombined into quads;
    ``"left_half"``: quads (recombined) for x < size/2 and triangles for x > size/2 (a mixed mesh with a
    conforming quad/triangle interface). ``algorithm``: gmsh 2D algorithm (6 = Frontal-Delaunay).
    ``refine``: number of uniform refinements of the generated mesh (each splits every triangle into four
    similar ones, every quad into four): a systematically refined sequence for order-of-accuracy studies.
    Deterministic for given arguments (single-threaded gmsh).
    """
    quads = {False: "none", True: "all"}.get(quads, quads)
    with _gmsh_model("square") as gmsh:
        g = gmsh.model.geo
        c = 0.5 * size
        p = [g.addPoint(x, y, 0, h) for x, y in
             ((0, 0), (c, 0), (size, 0), (size, size), (c, size), (0, size))]
        b1, b2 = g.addLine(p[0], p[1]), g.addLine(p[1], p[2])
        r = g.addLine(p[2], p[3])
        t1, t2 = g.addLine(p[3], p[4]), g.addLine(p[4], p[5])
        lf = g.addLine(p[5], p[0])
        mid = g.addLine(p[1], p[4])
        s_left = g.addPlaneSurface([g.addCurveLoop([b1, mid, t2, lf])])
        s_right = g.addPlaneSurface([g.addCurveLoop([b2, r, t1, -mid])])
        g.synchronize()
        for name, lines in (("bottom", [b1, b2]), ("right", [r]), ("top", [t1, t2]), ("left", [lf])):
            gmsh.model.addPhysicalGroup(1, lines, name=name)
        gmsh.model.addPhysicalGroup(2, [s_left, s_right], name="fluid")
        gmsh.option.setNumber("Mesh.Algorithm", algorithm)
        for s, on in ((s_left, quads in ("all", "left_half")), (s_right, quads == "all")):
            if on:
                gmsh.model.mesh.setRecombine(2, s)
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        return _extract(gmsh)


@contextlib.contextmanager
def _gmsh_model(name: str):
    """A quiet, single-threaded (hence deterministic) gmsh session with one model; always finalised."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add(name)
        yield gmsh
    finally:
        gmsh.finalize()


def _extract(gmsh) -> FVMesh:
    """FVMesh from the current gmsh model (first-order triangles/quads, named physical lines)."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(tags.size)
    pts = xyz.reshape(-1, 3)[:, :2]
    cells = {}
    for etype, name, k in ((2, "triangle", 3), (3, "quad", 4)):
        _, nodes = gmsh.model.mesh.getElementsByType(etype)
        if len(nodes):
            cells[name] = index[nodes.astype(np.int64)].reshape(-1, k)
    boundary = {}
    for dim, tag in gmsh.model.getPhysicalGroups(1):
        name = gmsh.model.getPhysicalName(dim, tag)
        edges = []
        for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
            _, _, nodes = gmsh.model.mesh.getElements(1, ent)
            edges.append(index[nodes[0].astype(np.int64)].reshape(-1, 2))
        boundary[name] = np.concatenate(edges)
    from ...fvmesh import _ccw
    cells = {k: _ccw(pts, v) for k, v in cells.items()}
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    new = np.full(len(pts), -1, dtype=np.int64)
    new[used] = np.arange(used.size)
    return build_fvmesh(pts[used], {k: new[v] for k, v in cells.items()},
                        {k: new[v] for k, v in boundary.items()})


#: Schäfer–Turek DFG 2D geometry (m): channel length and height, cylinder centre and radius.
DFG_CHANNEL = (2.2, 0.41)
DFG_CENTRE = (0.2, 0.2)
DFG_RADIUS = 0.05


def _ring_layers(h_wall: float, h_outer: float, thickness: float) -> tuple[int, float]:
    """Number of radial layers and geometric growth ratio of a ring of ``thickness`` (m) whose first
    cell is ``h_wall`` (m) high and whose last cell is about ``h_outer`` (m) high."""
    from scipy.optimize import brentq

    best = None
    for n in range(2, 200):
        def excess(q, n=n):
            return h_wall * (n if abs(q - 1) < 1e-12 else (q**n - 1) / (q - 1)) - thickness
        if excess(1.0) > 0:          # even uniform layers of h_wall overfill: fewer layers than n
            break
        if excess(3.0) < 0:          # would need more than 3x growth per layer
            continue
        q = brentq(excess, 1.0, 3.0)
        last = h_wall * q ** (n - 1)
        if best is None or abs(np.log(last / h_outer)) < abs(np.log(best[2] / h_outer)):
            best = (n, q, last)
    if best is None:
        raise ValueError("boundary-layer ring: first cell height exceeds the ring thickness")
    return best[0], best[1]


def dfg_cylinder(n_quarter: int = 16, *, h_far: float = 0.02, ring: float = 0.06, wall_ratio: float = 0.08,
                 growth: float = 0.05) -> FVMesh:
    """Schäfer–Turek DFG 2D channel with a cylinder: quad boundary-layer ring + unstructured triangles.

    Channel ``[0, 2.2] x [0, 0.41]`` m, cylinder of radius 0.05 m at (0.2, 0.2). Groups ``inlet``
    (x = 0), ``outlet`` (x = 2.2), ``walls`` (y = 0 and y = 0.41), ``cylinder``.

    n_quarter: quad cells per quarter of the cylinder (even: mesh nodes lie at the front and rear
        stagnation points 0.15 and 0.25, the Δp points); ``4 n_quarter`` cells around the cylinder.
    ring: thickness of the structured quad ring around the cylinder, m; its first cell is
        ``wall_ratio`` times the arc spacing on the cylinder high, growing geometrically to about the
        arc spacing at its outer radius.
    h_far: largest triangle size, m; triangles grow from the ring's outer spacing at ``growth`` m per m
        of distance from the ring (``h = min(h_far, h_ring + growth d)``).
    Deterministic (single-threaded gmsh, Frontal-Delaunay).
    """
    if n_quarter % 2:
        raise ValueError(f"n_quarter must be even, got {n_quarter}")
    L, H = DFG_CHANNEL
    cx, cy = DFG_CENTRE
    r_in, r_out = DFG_RADIUS, DFG_RADIUS + ring
    h_in = 0.5 * np.pi * r_in / n_quarter
    h_out = 0.5 * np.pi * r_out / n_quarter
    n_r, q = _ring_layers(wall_ratio * h_in, h_out, ring)
    with _gmsh_model("dfg") as gmsh:
        g = gmsh.model.geo
        c = g.addPoint(cx, cy, 0)
        ang = np.pi / 4 + 0.5 * np.pi * np.arange(4)
        pin = [g.addPoint(cx + r_in * np.cos(a), cy + r_in * np.sin(a), 0) for a in ang]
        pout = [g.addPoint(cx + r_out * np.cos(a), cy + r_out * np.sin(a), 0) for a in ang]
        arc_in = [g.addCircleArc(pin[i], c, pin[(i + 1) % 4]) for i in range(4)]
        arc_out = [g.addCircleArc(pout[i], c, pout[(i + 1) % 4]) for i in range(4)]
        radial = [g.addLine(pin[i], pout[i]) for i in range(4)]
        ring_s = [g.addPlaneSurface([g.addCurveLoop([arc_in[i], radial[(i + 1) % 4], -arc_out[i], -radial[i]])])
                  for i in range(4)]
        corners = [g.addPoint(x, y, 0) for x, y in ((0, 0), (L, 0), (L, H), (0, H))]
        bottom, outlet = g.addLine(corners[0], corners[1]), g.addLine(corners[1], corners[2])
        top, inlet = g.addLine(corners[2], corners[3]), g.addLine(corners[3], corners[0])
        outer = g.addPlaneSurface([g.addCurveLoop([bottom, outlet, top, inlet]), g.addCurveLoop(arc_out)])
        for a in arc_in + arc_out:
            g.mesh.setTransfiniteCurve(a, n_quarter + 1)
        for r in radial:
            g.mesh.setTransfiniteCurve(r, n_r + 1, "Progression", q)
        for s in ring_s:
            g.mesh.setTransfiniteSurface(s)
            g.mesh.setRecombine(2, s)
        g.synchronize()
        for name, lines in (("inlet", [inlet]), ("outlet", [outlet]), ("walls", [bottom, top]),
                            ("cylinder", arc_in)):
            gmsh.model.addPhysicalGroup(1, lines, name=name)
        gmsh.model.addPhysicalGroup(2, ring_s + [outer], name="fluid")
        f = gmsh.model.mesh.field
        fid = f.add("MathEval")
        f.setString(fid, "F", f"min({h_far}, {h_out} + {growth} * "
                              f"max(0, sqrt((x - {cx})^2 + (y - {cy})^2) - {r_out}))")
        f.setAsBackgroundMesh(fid)
        for opt in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{opt}", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        return _extract(gmsh)
