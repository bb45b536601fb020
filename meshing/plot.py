"""Pictures of a mesh: the whole O-layer region and zooms on the leading and trailing edges."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from meshing.mesh import CELL_TYPES, Mesh2D


def _windows(mesh: Mesh2D, profile=None) -> list[tuple[str, np.ndarray, float]]:
    """(title, centre (m), half-width (m)) of the three views."""
    wall = mesh.points[np.unique(mesh.boundary["blade"])]
    lo, hi = wall.min(axis=0), wall.max(axis=0)
    size = float(np.max(hi - lo))
    if profile is not None:
        le = np.asarray(profile.leading_edge, dtype=float)
        te = 0.5 * (profile.points[0] + profile.points[profile.te_index])
    else:  # the wall points farthest apart along the chord-wise extent
        le = wall[np.argmin(wall[:, 0])]
        te = wall[np.argmax(wall[:, 0])]
    return [("blade and O-layer", 0.5 * (lo + hi), 0.75 * size),
            ("leading edge", le, 0.04 * size),
            ("trailing edge", te, 0.06 * size)]


def plot_mesh(mesh: Mesh2D, path: str | Path, profile=None, dpi: int = 110) -> None:
    """Save a three-panel PNG of ``mesh``: the blade with its O-layer, a leading-edge and a trailing-edge
    zoom (centred on ``profile``'s leading edge and trailing-edge midpoint when given)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    polys = [mesh.points[c] for name in CELL_TYPES for c in mesh.cells.get(name, [])]
    wall = mesh.points[mesh.boundary["blade"]]
    fig = Figure(figsize=(15, 5.2))
    for k, (title, centre, half) in enumerate(_windows(mesh, profile)):
        ax = fig.add_subplot(1, 3, k + 1)
        ax.add_collection(PolyCollection(polys, facecolors="none", edgecolors="k", linewidths=0.2))
        for edge in wall:
            ax.plot(edge[:, 0], edge[:, 1], "r-", lw=0.8)
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("x (m)")
    counts = ", ".join(f"{n} {k}s" for k, n in mesh.cell_counts().items())
    fig.suptitle(f"{mesh.info.get('level', '')} mesh: {counts}")
    fig.savefig(path, dpi=dpi)
