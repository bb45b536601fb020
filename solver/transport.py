"""Steady transport of a cell scalar ``phi`` (k, omega): ``(mesh, fields, coefficients) -> linear system``.

Per cell ``P`` (steady, per unit depth)::

    sum_f F_f phi_f - sum_f Gamma_f grad(phi)_f·S_f = (su - sp phi_P) V_P

Internal faces use the shared convection–diffusion stencil of :mod:`solver.assembly`:

* implicit (matrix): first-order upwind convection, orthogonal diffusion ``Gamma_f diff_coeff (phi_N -
  phi_P)``, the implicit source ``sp >= 0`` on the diagonal (destruction, OpenFOAM's ``fvm::Sp``);
* explicit (right-hand side): linear-upwind deferred correction ``-F_f psi grad(phi)_U·(x_f - x_U)`` (the
  limited gradient; zeros give pure upwind), non-orthogonal diffusion ``Gamma_f grad(phi)_f·T_f`` and
  ``su`` (production);
* boundary faces: ``dirichlet`` faces (``phi_b`` prescribed) add ``Gamma_b diff_coeff (phi_b - phi_P)`` and
  inflow ``-F_b phi_b``; the other faces are zero-gradient (no diffusion; outflow ``F_b phi_P``
  implicit, backflow ``F_b phi_P`` lagged);
* implicit under-relaxation ``a_P / alpha`` and ``(1 - alpha)/alpha a_P phi_old``;
* ``fixed``: cells whose value is imposed (``omega`` next to walls): identity rows.

The matrix is an M-matrix (upwind, ``sp >= 0``), so Gauss–Seidel converges and, up to the explicit
deferred correction, the solution stays positive; callers clip to a floor afterwards.
"""

from __future__ import annotations

import numpy as np

from .assembly import deferred_correction, non_orthogonal_diffusion, scatter_face_sources, upwind_stencil
from .fvmesh import FVMesh
from .kernels import decouple_fixed_cells, scalar_boundary_terms
from .linalg import FVPattern, LinearSystem


def scalar_system(mesh: FVMesh, pattern: FVPattern, phi: np.ndarray, phi_b: np.ndarray, dirichlet: np.ndarray,
                  flux: np.ndarray, gamma: np.ndarray, grad: np.ndarray, grad_ho: np.ndarray, sp: np.ndarray,
                  su: np.ndarray, alpha: float, fixed_cells: np.ndarray | None = None,
                  fixed_values: np.ndarray | None = None) -> LinearSystem:
    """Assemble the relaxed system of one scalar.

    phi: ``(nc,)`` current values; phi_b: ``(nb,)`` boundary-face values (used on ``dirichlet`` faces and
    inflow); dirichlet: ``(nb,)`` bool; flux: ``(nf,)`` mass flux, kg/(s m); gamma: ``(nf,)`` face
    diffusivity ``rho (nu + sigma nu_t)``, kg/(m s); grad: ``(nc, 2)`` gradient (diffusion); grad_ho: the
    limited gradient for convection; sp: ``(nc,)`` implicit sink per unit volume (>= 0), kg/(m³ s);
    su: ``(nc,)`` explicit source per unit volume (units of ``rho phi / s``); alpha: relaxation factor;
    fixed_cells / fixed_values: cells whose value is imposed.
    """
    ni, nc = mesh.n_internal, mesh.n_cells
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    st = upwind_stencil(mesh, flux, gamma[:ni])
    diag, upper, lower = st.diag, st.upper, st.lower
    src = su * mesh.volume
    diag += sp * mesh.volume
    face = deferred_correction(mesh, flux, grad_ho)
    face -= non_orthogonal_diffusion(mesh, gamma[:ni], grad)
    src = scatter_face_sources(mesh, src, face)
    # boundary faces (one compiled loop, :func:`solver.kernels.scalar_boundary_terms`)
    scalar_boundary_terms(diag, src, np.ascontiguousarray(phi, dtype=float), np.ascontiguousarray(phi_b, dtype=float),
                          dirichlet, np.ascontiguousarray(flux[ni:], dtype=float),
                          np.ascontiguousarray(gamma[ni:], dtype=float), mesh.diff_coeff[ni:],
                          np.ascontiguousarray(grad, dtype=float), _t_vec_boundary(mesh), mesh.owner[ni:])
    # under-relaxation
    d = diag / alpha
    b = src + (1.0 - alpha) * d * phi
    if fixed_cells is not None and len(fixed_cells):
        is_fixed = np.zeros(nc, bool)
        is_fixed[fixed_cells] = True
        decouple_fixed_cells(upper, lower, o, n, is_fixed)
        d[fixed_cells] = 1.0
        b[fixed_cells] = fixed_values
    return LinearSystem(pattern.matrix(d, upper, lower), b, phi.copy(), pattern)


def _t_vec_boundary(mesh: FVMesh) -> np.ndarray:
    """``T_f`` ``(nb, 2)`` of the boundary faces, contiguous (cached in ``mesh.info``)."""
    cached = mesh.info.get("t_vec_boundary")
    if cached is None:
        cached = mesh.info["t_vec_boundary"] = np.ascontiguousarray(mesh.t_vec[mesh.n_internal:], dtype=float)
    return cached
