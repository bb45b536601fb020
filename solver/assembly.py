"""The convection–diffusion stencil shared by every transport equation (momentum, k, omega).

Per internal face ``f`` between owner ``P`` and neighbour ``N`` with mass flux ``F_f`` (owner -> neighbour,
kg/(s m)) and diffusivity ``Gamma_f`` (kg/(m s))::

    implicit (matrix):  first-order upwind convection and the orthogonal diffusion Gamma_f diff_coeff (phi_N - phi_P)
    explicit (source):  deferred correction F_f (phi_f^HO - phi_f^UD), phi_f^HO = phi_U + grad_HO(phi)_U·(x_f - x_U)
                        non-orthogonal diffusion Gamma_f grad(phi)_f·T_f

``U`` is the upwind cell and ``grad_HO`` the gradient used for the convective face values
(:func:`convection_gradient`: limited for ``linear_upwind``, zero for ``upwind``). ``phi`` may be a scalar
``(nc,)`` or a vector ``(nc, 2)`` field (gradients ``(nc, 2)`` or ``(nc, 2, 2)`` ``[cell, component,
direction]``); the face terms keep the trailing component axis.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import kernels
from .fvmesh import FVMesh
from .gradient import interpolate_linear, limited_gradient, linear_weights
from .kernels import dot_last


@dataclass(frozen=True)
class Stencil:
    """Implicit upwind-convection + orthogonal-diffusion coefficients of the internal faces.

    diag: ``(nc,)`` diagonal; upper, lower: ``(ni,)`` coefficients of row owner / column neighbour and
    row neighbour / column owner (:meth:`solver.linalg.FVPattern.matrix`), kg/s per unit depth.
    """

    diag: np.ndarray
    upper: np.ndarray
    lower: np.ndarray


def upwind_stencil(mesh: FVMesh, flux: np.ndarray, gamma) -> Stencil:
    """:class:`Stencil` from the face mass fluxes ``flux (nf,)`` and the internal-face diffusivities
    ``gamma`` (a float or ``(ni,)``), kg/(m s): ``upper = min(F, 0) - D``, ``lower = -max(F, 0) - D`` with
    ``D = gamma diff_coeff``, the diagonal the sum of ``max(±F, 0) + D`` over the cell's faces (one compiled
    loop, :func:`solver.kernels.upwind_stencil`)."""
    ni = mesh.n_internal
    D = np.ascontiguousarray(gamma * mesh.diff_coeff[:ni], dtype=float)
    return Stencil(*kernels.upwind_stencil(np.ascontiguousarray(flux[:ni], dtype=float), D, mesh.owner,
                                           mesh.neighbour, mesh.n_cells))


def deferred_correction(mesh: FVMesh, flux: np.ndarray, grad_ho: np.ndarray) -> np.ndarray:
    """``F_f (phi_f^HO - phi_f^UD) = F_f grad_HO(phi)_U·(x_f - x_U)`` per internal face ``(ni, ...)``; one
    compiled loop over the faces (:func:`solver.kernels.deferred_correction`)."""
    ni = mesh.n_internal
    if not grad_ho.any():           # upwind (k and omega by default): nothing to correct, skip the gathers
        return np.zeros((ni,) + grad_ho.shape[1:-1])
    from .kernels import deferred_correction as kernel

    r_owner, r_neighbour = _face_offsets(mesh)
    g = np.ascontiguousarray(grad_ho, dtype=float).reshape(mesh.n_cells, -1, 2)
    out = kernel(flux, g, r_owner, r_neighbour, mesh.owner, mesh.neighbour)
    return out.reshape((ni,) + grad_ho.shape[1:-1])


def _face_offsets(mesh: FVMesh) -> tuple[np.ndarray, np.ndarray]:
    """``(x_f - x_P, x_f - x_N)`` ``(ni, 2)`` of the internal faces, m (cached in ``mesh.info``)."""
    cached = mesh.info.get("face_offsets")
    if cached is None:
        ni = mesh.n_internal
        xf = mesh.face_centre[:ni]
        cached = mesh.info["face_offsets"] = (xf - mesh.centroid[mesh.owner[:ni]],
                                              xf - mesh.centroid[mesh.neighbour[:ni]])
    return cached


def non_orthogonal_diffusion(mesh: FVMesh, gamma, grad: np.ndarray) -> np.ndarray:
    """``Gamma_f grad(phi)_f·T_f`` per internal face ``(ni, ...)``, the face gradient interpolated linearly
    from the cell gradients ``grad (nc, ..., 2)`` (:func:`solver.gradient.interpolate_linear`); ``gamma`` a
    float or ``(ni,)``. A scalar's in one compiled loop over the faces
    (:func:`solver.kernels.face_gradient_flux`)."""
    ni = mesh.n_internal
    if grad.ndim == 2 and np.ndim(gamma) == 1:
        return kernels.face_gradient_flux(*linear_weights(mesh), np.ascontiguousarray(grad, dtype=float),
                                          _t_vec(mesh), np.ascontiguousarray(gamma, dtype=float))
    g_t = dot_last(interpolate_linear(mesh, grad), mesh.t_vec[:ni])
    if np.ndim(gamma):
        gamma = np.reshape(gamma, (-1,) + (1,) * (g_t.ndim - 1))
    return gamma * g_t


def _t_vec(mesh: FVMesh) -> np.ndarray:
    """``T_f`` ``(ni, 2)`` of the internal faces, contiguous (cached in ``mesh.info``)."""
    cached = mesh.info.get("t_vec_internal")
    if cached is None:
        cached = mesh.info["t_vec_internal"] = np.ascontiguousarray(mesh.t_vec[:mesh.n_internal], dtype=float)
    return cached


def scatter_face_sources(mesh: FVMesh, src: np.ndarray, face: np.ndarray) -> np.ndarray:
    """``src - sum_{f: P owner} face_f + sum_{f: P neighbour} face_f``: the explicit face terms
    ``face (ni, ...)`` moved to the right-hand side ``src (nc, ...)`` of the owner (outflow sign) and the
    neighbour."""
    nc, ni = mesh.n_cells, mesh.n_internal
    out = kernels.scatter_face_sources(np.ascontiguousarray(src, dtype=float).reshape(nc, -1),
                                       np.ascontiguousarray(face, dtype=float).reshape(ni, -1), mesh.owner,
                                       mesh.neighbour)
    return out.reshape(np.shape(src))


def sum_per_cell(cells: np.ndarray, values: np.ndarray, nc: int) -> np.ndarray:
    """Sum ``values (k,)`` or ``(k, m)`` into ``(nc,)`` or ``(nc, m)`` by cell."""
    if values.ndim == 1:
        return np.bincount(cells, values, nc)
    return np.column_stack([np.bincount(cells, values[:, j], nc) for j in range(values.shape[1])])


# ------------------------------------------------------------------------------------- convection schemes
def _upwind(mesh, phi, phi_b, grad, limiter, limiter_k):
    """First-order upwind: no reconstruction (a zero gradient)."""
    return np.zeros_like(grad)


def _linear_upwind(mesh, phi, phi_b, grad, limiter, limiter_k):
    """Linear upwind: the limited gradient (:func:`solver.gradient.limited_gradient`), per component."""
    return limited_gradient(mesh, phi, phi_b, grad, limiter, limiter_k)


#: Convection schemes by name: ``f(mesh, phi, phi_b, grad, limiter, limiter_k) -> grad_HO`` (the gradient
#: of the convective face values, :func:`deferred_correction`).
CONVECTION_SCHEMES: dict[str, Callable] = {"linear_upwind": _linear_upwind, "upwind": _upwind}


def convection_gradient(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray, grad: np.ndarray, scheme: str,
                        limiter: str = "venkatakrishnan", limiter_k: float = 5.0) -> np.ndarray:
    """Gradient used for the convective face values of ``phi`` by the scheme named ``scheme``
    (:data:`CONVECTION_SCHEMES`); ``phi_b`` boundary-face values, ``grad`` the least-squares gradient."""
    try:
        fn = CONVECTION_SCHEMES[scheme]
    except KeyError:
        raise ValueError(f"unknown convection scheme {scheme!r}; choose from {sorted(CONVECTION_SCHEMES)}") from None
    return fn(mesh, phi, phi_b, grad, limiter, limiter_k)
