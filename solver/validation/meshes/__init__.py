"""Mesh generators of the validation cases: structured squares (:mod:`.square`, numpy only), unstructured gmsh
meshes of the square and of the DFG 2D-1 channel (:mod:`.gmsh_meshes`, gmsh imported on use) and the NACA 0012
C-mesh (:mod:`.naca_mesh`). The blade meshes of the optimiser come from the ``meshing`` package instead."""

from .gmsh_meshes import dfg_cylinder, gmsh_square
from .naca_mesh import LEVELS as NACA_LEVELS
from .naca_mesh import CMeshSpec, naca0012_cmesh
from .square import clustered, square_mesh

__all__ = ["CMeshSpec", "NACA_LEVELS", "clustered", "dfg_cylinder", "gmsh_square", "naca0012_cmesh", "square_mesh"]
