"""The in-memory 2D mesh handed to the solver: points, mixed quad/triangle cells, named boundary edges."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Boundary group names, in the order of their integer ids (1-based) in written files.
BOUNDARY_GROUPS: tuple[str, ...] = ("inlet", "outlet", "top", "bottom", "blade")
#: Cell types in their canonical order (global cell numbering: all quads, then all triangles).
CELL_TYPES: tuple[str, ...] = ("quad", "triangle")


@dataclass(frozen=True)
class Mesh2D:
    """A 2D hybrid mesh in metres.

    Attributes
    ----------
    points: ``(n, 2)`` node coordinates, m.
    cells: ``{"quad": (nq, 4), "triangle": (nt, 3)}`` node indices, counter-clockwise.
    boundary: ``{"inlet" | "outlet" | "top" | "bottom" | "blade": (k, 2)}`` boundary edges as node-index
        pairs, oriented with the fluid on the left (outer rectangle counter-clockwise, blade clockwise).
    info: free-form diagnostics (first-cell height, number of layers, timings...).
    """

    points: np.ndarray
    cells: dict[str, np.ndarray]
    boundary: dict[str, np.ndarray]
    info: dict = field(default_factory=dict, compare=False)

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_cells(self) -> int:
        return int(sum(c.shape[0] for c in self.cells.values()))

    def cell_counts(self) -> dict[str, int]:
        """Number of cells per type."""
        return {k: int(v.shape[0]) for k, v in self.cells.items()}

    def cell_areas(self) -> dict[str, np.ndarray]:
        """Signed area (m², shoelace formula; positive when counter-clockwise) of every cell, per type."""
        return {k: polygon_areas(self.points, conn) for k, conn in self.cells.items()}

    def total_area(self) -> float:
        """Sum of all cell areas, m²."""
        return float(sum(a.sum() for a in self.cell_areas().values()))

    def boundary_area(self, group: str) -> float:
        """Signed area (m²) enclosed by the closed edge loop(s) of ``group``, counter-clockwise positive."""
        e = self.boundary[group]
        p, q = self.points[e[:, 0]], self.points[e[:, 1]]
        return float(0.5 * np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))

    def to_meshio(self):
        """The mesh as a ``meshio.Mesh`` with 3D points (z = 0), line cells for the boundary groups and
        gmsh physical/geometrical tags (1-based group ids of :data:`BOUNDARY_GROUPS`, 0 for 2D cells)."""
        import meshio

        pts = np.column_stack([self.points, np.zeros(self.n_points)])
        blocks, phys = [], []
        for name in CELL_TYPES:
            conn = self.cells.get(name)
            if conn is not None and len(conn):
                blocks.append((name, conn))
                phys.append(np.full(len(conn), len(BOUNDARY_GROUPS) + 1, dtype=int))
        for gid, name in enumerate(BOUNDARY_GROUPS, start=1):
            edges = self.boundary.get(name)
            if edges is not None and len(edges):
                blocks.append(("line", edges))
                phys.append(np.full(len(edges), gid, dtype=int))
        field_data = {name: np.array([gid, 1]) for gid, name in enumerate(BOUNDARY_GROUPS, start=1)}
        field_data["fluid"] = np.array([len(BOUNDARY_GROUPS) + 1, 2])
        return meshio.Mesh(pts, blocks, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys},
                           field_data=field_data)

    def write(self, path: str | Path) -> None:
        """Write the mesh with meshio; ``.msh`` is written as gmsh 2.2 ASCII, anything else (``.vtu``...)
        in the format meshio infers from the suffix."""
        path = Path(path)
        mesh = self.to_meshio()
        if path.suffix == ".msh":
            mesh.write(path, file_format="gmsh22", binary=False)
        else:
            mesh.write(path)


def polygon_areas(points: np.ndarray, conn: np.ndarray) -> np.ndarray:
    """Signed areas (m²) of the polygons ``points[conn]`` (``conn``: (n, k) node indices)."""
    p = points[conn]
    q = np.roll(p, -1, axis=1)
    return 0.5 * np.sum(p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1], axis=1)
