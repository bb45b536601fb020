"""Unstructured meshes from the gmsh Python API (optional dependency ``gmsh``)."""

from __future__ import annotations

import numpy as np

from .fvmesh import FVMesh, build_fvmesh


def gmsh_square(h: float, *, quads: str | bool = False, size: float = 1.0, algorithm: int = 6) -> FVMesh:
    """Unstructured mesh of ``[0, size]²`` with target cell size ``h`` (m), groups ``bottom, right, top,
    left``.

    quads: ``False``/``"none"``: triangles only; ``True``/``"all"``: recombined into quads;
    ``"left_half"``: quads (recombined) for x < size/2 and triangles for x > size/2 (a mixed mesh with a
    conforming quad/triangle interface). ``algorithm``: gmsh 2D algorithm (6 = Frontal-Delaunay).
    Deterministic for given arguments (single-threaded gmsh).
    """
    import gmsh

    quads = {False: "none", True: "all"}.get(quads, quads)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("square")
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
        return _extract(gmsh)
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
    from .fvmesh import _ccw
    cells = {k: _ccw(pts, v) for k, v in cells.items()}
    used = np.unique(np.concatenate([c.ravel() for c in cells.values()]))
    new = np.full(len(pts), -1, dtype=np.int64)
    new[used] = np.arange(used.size)
    return build_fvmesh(pts[used], {k: new[v] for k, v in cells.items()},
                        {k: new[v] for k, v in boundary.items()})
