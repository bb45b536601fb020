"""Rhie–Chow face fluxes and the pressure-correction equation (SIMPLE / SIMPLEC).

Face mass flux (kg/(s m), owner -> neighbour), Rhie & Chow (1983) with the relaxation-independent
correction of Majumdar (1988)::

    F_f = rho [ ū_f·S - D̄_f (diff_coeff (p_N - p_P) - grad(p)‾_f·E) ] + (1 - alpha) (F_old - rho ū_old·S)

with ``D = V / a_P`` (relaxed momentum diagonal), ``E = S - T`` and ``ū_f`` the capped quadratic face
mean of :func:`face_velocity`. The correction ``p'`` solves
``sum_f rho D̃_f diff_coeff (p'_P - p'_N) = -sum_f F*_f`` with ``D̃ = V / a_P`` (SIMPLE) or
``V / (a_P - H1)`` (SIMPLEC); non-orthogonal parts of ``p'`` are neglected (they vanish at convergence).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .boundary import FIXED, ZERO_GRADIENT, BoundaryData
from .fvmesh import FVMesh
from .gradient import (
    bound_to_cells,
    boundary_face_curvature,
    face_average,
    face_operators,
    interpolate_corrected,
    interpolate_linear,
    linear_weights,
)
from .kernels import cap_quadratic_correction, dot_last, rhie_chow_faces
from .linalg import FVPattern, LinearSystem

#: Face velocities of the mass flux by name (:attr:`solver.SimpleSettings.face_velocity`): True where the
#: skewness-corrected reconstruction is kept within its two cells' values (:func:`face_velocity`).
FACE_VELOCITIES: dict[str, bool] = {"corrected": False, "bounded": True}

#: Cap of the quadratic correction of the face velocity, as a fraction of the linear variation
#: ``|d| |grad u|`` across the face (:func:`face_velocity`).
QUADRATIC_CAP = 0.5


def face_velocity(mesh: FVMesh, u: np.ndarray, u_b: np.ndarray, grad_u: np.ndarray,
                  bounded: bool = False) -> np.ndarray:
    """Velocity ``(ni, 2)`` that carries the mass flux through each internal face, m/s.

    The linear reconstruction from both sides (:func:`solver.gradient.interpolate_corrected`; ``bounded``:
    each component clipped to the range of the face's two cell values, see below) plus the
    correction to the face mean of the quadratic reconstructions (:func:`solver.gradient.face_average`),
    each component's correction capped at ``QUADRATIC_CAP |d| (|grad u_P| + |grad u_N|) / 2``, on faces
    of triangles only (:func:`_triangles`).

    Why: with the linear face value alone the O(h²) face error does not cancel between the three faces of
    a triangle, the continuity truncation error is O(h) and alternates between neighbouring triangles,
    and only the Rhie–Chow term (coefficient ~ h²/mu) controls pressure at that scale: the pressure error
    is O(h) (MMS pressure order 1.35, and no convergence at all under uniform refinement). The quadratic
    face mean makes the truncation O(h²). In smooth flow the correction (~ h² u'') stays far below the cap
    (~ h u'); the cap acts where the quadratic fit overshoots: the impulsive start of DFG 2D-1 diverges in
    9 iterations without it. A cap on the jump ``|u_N - u_P|`` instead would switch the correction off
    across faces along which the flow is developed (zero jump, non-zero curvature across the face):
    Poiseuille flow then gets worse than with no correction at all.

    Why ``bounded``: where the boundary-layer cells end at a trailing edge and meet the wake's, and along a
    stagnation line, a cell's gradient extrapolated to the face centre overshoots both cells' velocities (on the
    NACA 0012 coarse C-mesh by up to 0.10 U∞ across the boundary-layer rows at the trailing edge and 0.16 U∞ at
    the nose); at the trailing edge this removes the loading and raised the lift 1.1-1.75 % above OpenFOAM's
    at 2°-8° on the same mesh (bounded: 0.8-1.0 %; docs/decisions/0002-bounded-face-velocity.md).
    Clipping keeps the correction wherever it does not overshoot, so the leading edge keeps the pressure drag of the
    published reference, which OpenFOAM's plain linear face velocity does not (TMR 10° C_D +13 %).
    """
    lin = interpolate_corrected(mesh, u, grad_u)
    if bounded:
        lin = bound_to_cells(mesh, lin, u)
    faces = _quadratic_faces(mesh)
    if not faces.size:                    # all quads: nothing to correct, no quadratic operators built
        return lin
    cap_quadratic_correction(lin, face_average(mesh, u, u_b, faces), faces, mesh.owner, mesh.neighbour,
                             np.ascontiguousarray(grad_u, dtype=float), face_operators(mesh)["d_length"],
                             QUADRATIC_CAP)
    return lin


def _quadratic_faces(mesh: FVMesh) -> np.ndarray:
    """Internal faces with a triangle on either side (:func:`_triangles`), where :func:`face_velocity`
    applies the quadratic correction (cached in ``mesh.info``; a quarter of the faces of a blade mesh)."""
    faces = mesh.info.get("quadratic_faces")
    if faces is None:
        ni = mesh.n_internal
        tri = _triangles(mesh)
        faces = mesh.info["quadratic_faces"] = np.flatnonzero(tri[mesh.owner[:ni]] | tri[mesh.neighbour[:ni]])
    return faces


def _triangles(mesh: FVMesh) -> np.ndarray:
    """``(nc,)`` True for triangles: the quadratic correction applies to faces of triangles only. On
    quadrilaterals the linear face errors of opposite faces cancel, and on the stretched boundary-layer
    quads of an airfoil C-mesh (aspect ratios to 1e7) the quadratic fit is not trustworthy: with it the
    NACA 0012 at 10° separated (C_D 0.034 instead of 0.0128)."""
    return mesh.cell_faces[:, 3] < 0


def outflow_face_velocity(mesh: FVMesh, bnd: BoundaryData, u: np.ndarray, u_b: np.ndarray,
                          grad_u: np.ndarray) -> np.ndarray:
    """Velocity ``(nb, 2)`` that carries the mass flux through the boundary faces, m/s: ``u_b`` plus, on
    zero-gradient (outflow) faces, the owner's quadratic variation along the face
    (:func:`solver.gradient.boundary_face_curvature`), capped as in :func:`face_velocity` — so that
    outflow faces carry face means like the internal faces (a developed profile leaves the domain with
    the flux it carries inside). Prescribed-velocity faces keep ``u_b``."""
    outflow, o, cap_length = _outflow_faces(mesh, bnd)
    if outflow is None:
        return u_b
    cap = cap_length * np.linalg.norm(grad_u[o], axis=-1)
    out = u_b.copy()
    out[outflow] += np.clip(boundary_face_curvature(mesh, u, u_b, outflow), -cap, cap)
    return out


def _outflow_faces(mesh: FVMesh, bnd: BoundaryData) -> tuple:
    """``(outflow faces (local), their owners, QUADRATIC_CAP |d| (0 where the owner is not a triangle) (k, 1))``
    of :func:`outflow_face_velocity`, or ``(None, None, None)`` where it has nothing to add (no triangles or no
    zero-gradient faces); cached in ``mesh.info`` per velocity-kind pattern."""
    key = ("outflow_faces", bnd.velocity_kind.tobytes())
    cached = mesh.info.get(key)
    if cached is None:
        tri = _triangles(mesh)
        outflow = np.flatnonzero(bnd.velocity_kind == ZERO_GRADIENT)
        if not tri.any() or not outflow.size:
            cached = (None, None, None)
        else:
            ni = mesh.n_internal
            o = mesh.owner[ni + outflow]
            d_length = face_operators(mesh)["d_length"][ni + outflow, None]
            cached = (outflow, o, QUADRATIC_CAP * d_length * tri[o][:, None])
        mesh.info[key] = cached
    return cached


def predicted_velocity_flux(mesh: FVMesh, bnd: BoundaryData, u: np.ndarray, u_b: np.ndarray,
                            grad_u: np.ndarray, rho: float, bounded: bool = False) -> np.ndarray:
    """``rho ū_f·S`` on all faces (boundary: ``rho u_b·S``), kg/(s m); ``ū_f`` from :func:`face_velocity`
    (``bounded`` as there) with the velocity gradient ``grad_u (nc, 2, 2)``."""
    ni = mesh.n_internal
    fi = rho * dot_last(face_velocity(mesh, u, u_b, grad_u, bounded), mesh.sf[:ni])
    fb = rho * dot_last(outflow_face_velocity(mesh, bnd, u, u_b, grad_u), mesh.sf[ni:])
    return np.concatenate([fi, fb])


def rhie_chow_flux(mesh: FVMesh, bnd: BoundaryData, u: np.ndarray, u_b: np.ndarray, grad_u: np.ndarray,
                   p: np.ndarray, p_b: np.ndarray, grad_p: np.ndarray, r_au: np.ndarray, rho: float,
                   relax_term: np.ndarray | None = None, bounded: bool = False) -> np.ndarray:
    """Face mass fluxes ``(nf,)`` from the predicted velocity ``u (nc, 2)`` with gradient ``grad_u``.

    r_au: ``V / a_P`` per cell, m² s/kg · m² (so that ``r_au * grad p`` is a velocity);
    relax_term: ``(1 - alpha)(F_old - rho ū_old·S)`` or None; ``bounded``: :func:`face_velocity`'s.
    Fixed-velocity faces carry ``rho u_b·S``, symmetry faces zero, zero-gradient (outlet) faces the face mean of
    :func:`outflow_face_velocity` with the pressure-smoothing term against the prescribed face pressure.
    """
    ni = mesh.n_internal
    e = _non_orthogonal_vectors(mesh)
    fi = rhie_chow_faces(*linear_weights(mesh), face_velocity(mesh, u, u_b, grad_u, bounded), mesh.sf[:ni], e[:ni],
                         mesh.diff_coeff[:ni], np.ascontiguousarray(p, dtype=float),
                         np.ascontiguousarray(r_au, dtype=float), np.ascontiguousarray(grad_p, dtype=float), rho)
    ob = mesh.owner[ni:]
    kind = bnd.velocity_kind
    fb_out = rho * (np.einsum("ij,ij->i", outflow_face_velocity(mesh, bnd, u, u_b, grad_u), mesh.sf[ni:])
                    - r_au[ob] * (mesh.diff_coeff[ni:] * (p_b - p[ob])
                                  - np.einsum("ij,ij->i", grad_p[ob], e[ni:])))
    fb = np.where(kind == FIXED, rho * np.einsum("ij,ij->i", u_b, mesh.sf[ni:]),
                  np.where(kind == ZERO_GRADIENT, fb_out, 0.0))
    flux = np.concatenate([fi, fb])
    if relax_term is not None:
        flux += relax_term
    return flux


def _non_orthogonal_vectors(mesh: FVMesh) -> np.ndarray:
    """``e = S - T`` ``(nf, 2)`` of every face, m (the orthogonal part of the face vector; cached in
    ``mesh.info``)."""
    e = mesh.info.get("sf_minus_t")
    if e is None:
        e = mesh.info["sf_minus_t"] = mesh.sf - mesh.t_vec
    return e


def mass_imbalance(mesh: FVMesh, flux: np.ndarray) -> np.ndarray:
    """Net mass outflow of each cell ``(nc,)``, kg/(s m)."""
    ni, nc = mesh.n_internal, mesh.n_cells
    return np.bincount(mesh.owner, flux, nc) - np.bincount(mesh.neighbour[:ni], flux[:ni], nc)


@dataclass
class PressureCorrection:
    """The p' system and the face coefficients used to correct the fluxes.

    coef: ``(nf,)`` ``rho D̃_f diff_coeff_f`` (boundary: non-zero only where p is fixed), kg/(s m Pa).
    """

    system: LinearSystem
    coef: np.ndarray
    pinned: bool


def pressure_correction_system(mesh: FVMesh, pattern: FVPattern, bnd: BoundaryData, flux: np.ndarray,
                               r_atu: np.ndarray, rho: float,
                               imbalance: np.ndarray | None = None) -> PressureCorrection:
    """Assemble the SPD p' system for the fluxes ``flux``; ``r_atu``: ``D̃`` per cell; ``imbalance``:
    :func:`mass_imbalance` of ``flux`` where the caller has it already (computed here otherwise).

    Without a fixed-pressure boundary the system is singular: the right-hand side is projected onto
    zero mean and cell 0 is pinned (its diagonal doubled), which selects the solution with p'_0 = 0.
    """
    ni, nc = mesh.n_internal, mesh.n_cells
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    ci = rho * interpolate_linear(mesh, r_atu) * mesh.diff_coeff[:ni]
    ob = mesh.owner[ni:]
    cb = np.where(bnd.p_fixed, rho * r_atu[ob] * mesh.diff_coeff[ni:], 0.0)
    diag = np.bincount(o, ci, nc) + np.bincount(n, ci, nc) + np.bincount(ob, cb, nc)
    rhs = -(mass_imbalance(mesh, flux) if imbalance is None else imbalance)
    pinned = not bnd.has_fixed_pressure
    if pinned:
        rhs = rhs - rhs.mean()
        diag[0] *= 2.0
    A = pattern.matrix(diag, -ci, -ci)
    return PressureCorrection(LinearSystem(A, rhs, np.zeros(nc), pattern), np.concatenate([ci, cb]), pinned)


def correct_flux(mesh: FVMesh, flux: np.ndarray, coef: np.ndarray, p_corr: np.ndarray) -> np.ndarray:
    """``F + F'`` with ``F' = -coef (p'_N - p'_P)`` (boundary ``p'_b = 0`` where p is fixed)."""
    ni = mesh.n_internal
    o, n = mesh.owner, mesh.neighbour
    dp = np.concatenate([p_corr[n[:ni]], np.zeros(mesh.n_boundary)]) - p_corr[o]
    return flux - coef * dp
