"""Momentum equations: ``(mesh, fields, coefficients) -> two linear systems`` (u and v).

Discretisation per cell ``P`` (steady, per unit depth, SI units):
``sum_f F_f u_f - sum_f mu grad(u)_f·S_f = -grad(p)_P V_P``, with

The internal-face convection–diffusion terms are the shared stencil of :mod:`solver.assembly`:

* implicit (matrix): first-order upwind convection and the orthogonal part of diffusion
  ``mu diff_coeff (u_N - u_P)``;
* explicit (source): deferred correction ``-F_f (u_f^HO - u_f^UD)`` with the linear-upwind face value
  ``u_f^HO = u_U + psi grad(u)_U·(x_f - x_U)`` (limited gradient), the non-orthogonal diffusion
  ``mu grad(u)_f·T_f`` and the pressure gradient;
* under-relaxation ``a_P / alpha`` with ``(1 - alpha)/alpha a_P u_old`` in the source.

Variable (turbulent) viscosity: ``mu`` may be a per-face array ``mu + mu_t`` ``(nf,)``; the stress is then
``mu_eff (grad u + grad u^T)`` and the transpose part ``sum_f mu_f (grad u)_f^T·S_f`` (zero for constant
``mu`` in incompressible flow, ``grad mu_t · grad u^T`` otherwise) is added explicitly on internal faces.
On boundary faces it is dropped: on a no-slip wall ``(grad u)^T n`` is ``grad(u·n) = 0``, and inlets,
outlets and symmetry planes carry negligible normal stress gradients. A scalar ``mu`` (laminar) takes
exactly the constant-viscosity path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .assembly import deferred_correction, non_orthogonal_diffusion, scatter_face_sources, upwind_stencil
from .boundary import FIXED, SYMMETRY, ZERO_GRADIENT, BoundaryData
from .fvmesh import FVMesh
from .gradient import linear_weights
from .kernels import momentum_boundary_terms, symmetric_gauss_seidel_pair, viscous_face_stress
from .linalg import FVPattern, LinearSystem, SolverSettings, reciprocal


@dataclass
class MomentumSystem:
    """The u and v systems (sharing off-diagonals) and the relaxed diagonal coefficients.

    a_p: ``(nc,)`` mean relaxed diagonal of the two systems, kg/s per unit depth.
    h1: ``(nc,)`` ``-sum`` of the off-diagonal coefficients of each row (for SIMPLEC), kg/s.
    alpha: the under-relaxation factor that divides ``a_p``.
    """

    u: LinearSystem
    v: LinearSystem
    a_p: np.ndarray
    h1: np.ndarray
    alpha: float = 1.0
    shared: tuple | None = None

    def solve(self, solver: SolverSettings) -> np.ndarray:
        """The predicted velocity ``(nc, 2)``: both systems solved by ``solver``. Gauss–Seidel sweeps both
        in one pass over their shared off-diagonal coefficients (:attr:`shared`: ``(pattern, upper,
        lower, diag_u, diag_v)``; :func:`solver.kernels.symmetric_gauss_seidel_pair`: the two separate
        solves to round-off, in the time of one)."""
        if solver.name != "gauss_seidel" or self.shared is None or solver.options:
            return np.column_stack([solver.solve(self.u)[0], solver.solve(self.v)[0]])
        pattern, upper, lower, diag_u, diag_v = self.shared
        indptr, indices, _ = pattern.off_diagonal
        x, y = np.array(self.u.x0, dtype=float), np.array(self.v.x0, dtype=float)
        off = self.u.A.data[pattern.slots[1]] if pattern.built(self.u.A) else pattern.off_diagonal_values(upper, lower)
        symmetric_gauss_seidel_pair(indptr, indices, off, reciprocal(diag_u),
                                    reciprocal(diag_v), x, y, np.ascontiguousarray(self.u.b, dtype=float),
                                    np.ascontiguousarray(self.v.b, dtype=float), solver.maxiter)
        return np.column_stack([x, y])


def momentum_system(mesh: FVMesh, pattern: FVPattern, bnd: BoundaryData, u: np.ndarray, u_b: np.ndarray,
                    flux: np.ndarray, grad_u: np.ndarray, grad_u_ho: np.ndarray, grad_p: np.ndarray,
                    mu: float, alpha: float, body_force: np.ndarray | None = None) -> MomentumSystem:
    """Assemble the relaxed momentum systems.

    u: ``(nc, 2)`` current velocity, m/s; u_b: ``(nb, 2)`` boundary-face velocity;
    flux: ``(nf,)`` face mass flux owner -> neighbour, kg/(s m);
    grad_u: ``(nc, 2, 2)`` velocity gradient ``[cell, component, direction]``, 1/s (diffusion);
    grad_u_ho: the (limited) gradient used for the convective face values (zeros: pure upwind);
    grad_p: ``(nc, 2)`` pressure gradient, Pa/m; mu: dynamic viscosity, Pa s: a float, or ``(nf,)`` face
    values ``mu + mu_t`` (adds the explicit transpose stress); alpha: relaxation factor;
    body_force: ``(nc, 2)`` force per unit volume, N/m³ (explicit source), or None.
    """
    ni = mesh.n_internal
    variable = np.ndim(mu) > 0
    mu_i, mu_b = (mu[:ni], mu[ni:]) if variable else (mu, mu)
    # implicit: upwind convection + orthogonal diffusion (internal faces)
    st = upwind_stencil(mesh, flux, mu_i)
    diag, upper, lower = st.diag, st.upper, st.lower
    # explicit: pressure gradient, deferred correction, non-orthogonal diffusion (internal faces)
    src = -grad_p * mesh.volume[:, None]
    if body_force is not None:
        src = src + body_force * mesh.volume[:, None]
    face = deferred_correction(mesh, flux, grad_u_ho)            # F (u_HO - u_UD)
    if variable:                                                 # mu_f ((grad u)_f·T + (grad u)_f^T·S)
        face -= viscous_face_stress(*linear_weights(mesh), np.ascontiguousarray(grad_u, dtype=float),
                                    mesh.t_vec[:ni], mesh.sf[:ni], np.ascontiguousarray(mu_i, dtype=float))
    else:
        face -= non_orthogonal_diffusion(mesh, mu, grad_u)
    src = scatter_face_sources(mesh, src, face)
    # boundary faces
    diag_b, src_b, sym_diag = _boundary(mesh, bnd, u, u_b, flux[ni:], grad_u, mu_b)
    diag = diag + diag_b
    src += src_b
    h1 = -pattern.off_diagonal_row_sum(upper, lower)
    # under-relaxation
    sys = []
    for c in range(2):
        d = (diag + sym_diag[:, c]) / alpha
        b = src[:, c] + (1.0 - alpha) * d * u[:, c]
        A = pattern.matrix(d, upper, lower) if c == 0 else pattern.with_diagonal(sys[0][0].A, d)
        sys.append((LinearSystem(A, b, u[:, c].copy(), pattern), d))
    a_p = 0.5 * (sys[0][1] + sys[1][1])
    return MomentumSystem(sys[0][0], sys[1][0], a_p, h1, alpha, (pattern, upper, lower, sys[0][1], sys[1][1]))


def _boundary(mesh, bnd, u, u_b, Fb, grad_u, mu):
    """Boundary-face contributions: diagonal ``(nc,)``, source ``(nc, 2)``, symmetry diagonal ``(nc, 2)``.

    Fixed velocity: convection ``F u_b`` (explicit, known), diffusion ``D_b (u_b - u_P) + mu grad_P·T``;
    zero-gradient outflow: ``F u_b`` with ``u_b`` reconstructed along the face, implicit part ``max(F, 0) u_P``;
    symmetry: the wall-normal shear from the normal velocity component only. One compiled loop over the
    boundary faces (:func:`solver.kernels.momentum_boundary_terms`)."""
    ni, nb = mesh.n_internal, mesh.n_boundary
    mu_b = np.ascontiguousarray(np.broadcast_to(np.asarray(mu, dtype=float), (nb,)))
    return momentum_boundary_terms(np.ascontiguousarray(u, dtype=float), np.ascontiguousarray(u_b, dtype=float),
                                   np.ascontiguousarray(Fb, dtype=float), np.ascontiguousarray(grad_u, dtype=float),
                                   mu_b, bnd.velocity_kind, mesh.owner[ni:], mesh.diff_coeff[ni:],
                                   *_boundary_geometry(mesh), mesh.n_cells, FIXED, ZERO_GRADIENT, SYMMETRY)


def _boundary_geometry(mesh):
    """``(T, n, d, |S|)`` of the boundary faces, contiguous (cached in ``mesh.info``)."""
    cached = mesh.info.get("momentum_boundary_geometry")
    if cached is None:
        ni = mesh.n_internal
        cached = mesh.info["momentum_boundary_geometry"] = tuple(
            np.ascontiguousarray(a[ni:], dtype=float) for a in (mesh.t_vec, mesh.normal, mesh.d, mesh.length))
    return cached
