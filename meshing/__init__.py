"""Meshing: a hybrid mesh (structured O-layer + unstructured far field) around a blade profile.

``build_mesh(profile, MeshSpec.for_level("coarse"))`` returns a :class:`Mesh2D`;
:func:`check_quality` raises :class:`MeshQualityError` below the paper's thresholds.
Imports :mod:`geometry` only (never the solver or the optimiser).
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
from meshing.spec import LEVELS, MeshSpec, first_cell_height, skin_friction

__all__ = [
    "BOUNDARY_GROUPS",
    "CELL_TYPES",
    "LEVELS",
    "Mesh2D",
    "MeshQualityError",
    "MeshSpec",
    "MeshingError",
    "QualityReport",
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
