"""Meshing: a hybrid mesh (structured O-layer + unstructured far field) around a blade profile.

``build_mesh(profile, MeshSpec.for_level("coarse"))`` returns a :class:`Mesh2D`;
:func:`check_quality` raises :class:`MeshQualityError` below the paper's thresholds.
Imports :mod:`geometry` only (never the solver or the optimiser).

What meshing reads from a profile (a :class:`geometry.Profile`; any object with these attributes will do):

* ``points``: ``(n, 2)`` closed counter-clockwise blade outline, m, first point not repeated, starting at
  the pressure-side trailing-edge corner (a forced corner node of the wall);
* ``te_index``: index of the suction-side trailing-edge corner (the other forced corner node);
* ``trailing_edge``: the trailing-edge polyline from ``points[te_index]`` to ``points[0]`` (the O-layer
  hull is extended downstream of it);
* ``chord``: chord length, m (sizes, domain and first-cell height scale with it);
* ``leading_edge``: the leading-edge point, m (only :func:`plot_mesh`, to centre its zoom).

Nothing else (no blade parameters, mode or curves) is read.
"""

from meshing.hybrid import MeshingError, build_mesh, domain_box, offset_hull, resample_wall
from meshing.mesh import BOUNDARY_GROUPS, CELL_TYPES, Mesh2D
from meshing.plot import plot_mesh
from meshing.quality import (
    MeshQualityError,
    QualityReport,
    cell_quality,
    check_quality,
    interior_faces,
)
from meshing.spec import (
    BOUNDS,
    CELL_BUDGET,
    LEVELS,
    REYNOLDS_RANGE,
    MeshSpec,
    MeshSpecError,
    first_cell_height,
    skin_friction,
)

__all__ = [
    "BOUNDARY_GROUPS",
    "BOUNDS",
    "CELL_BUDGET",
    "CELL_TYPES",
    "LEVELS",
    "Mesh2D",
    "MeshQualityError",
    "MeshSpec",
    "MeshSpecError",
    "MeshingError",
    "QualityReport",
    "REYNOLDS_RANGE",
    "build_mesh",
    "cell_quality",
    "check_quality",
    "domain_box",
    "first_cell_height",
    "interior_faces",
    "offset_hull",
    "plot_mesh",
    "resample_wall",
    "skin_friction",
]
