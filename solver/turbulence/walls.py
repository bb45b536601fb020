"""Wall treatments of the SST model, by name (:data:`WALL_TREATMENTS`): what each imposes at the walls for
one outer iteration (:class:`WallValues`). See :mod:`solver.turbulence` for the formulas.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..fvmesh import FVMesh
from .closures import SSTConstants, omega_log, omega_viscous, spalding_u_tau, spalding_velocity_gradient


@dataclass(frozen=True)
class WallValues:
    """What a wall treatment imposes for one outer iteration.

    omega_cells: ``(nwc,)`` omega fixed in the wall-adjacent cells :attr:`SSTSetup.wall_cells`, 1/s.
    mu_wall: ``(nw,)`` effective viscosity of each wall face (wall shear = mu_wall du_t/dn), Pa s.
    k_dirichlet: k = 0 on the wall (True) or zero flux (False).
    production_weight, production_log: ``(nwc,)`` the k production of wall cells is
        ``(1 - w) P + w P_log`` (``w = 0``: unchanged), m²/s³.
    u_tau_cells: ``(nwc,)`` friction velocity of the wall cells (m/s); when given, P of the wall cells uses
        the constant-stress strain ``u_tau² / (nu + nu_t)`` instead of the cell velocity gradient.
    wall_law_dudn: ``(nw,)`` wall-normal derivative of the tangential speed at each wall face's owner centroid
        from the law of the wall (1/s), or None; :func:`with_wall_law_gradient` puts it into a cell gradient.
    """

    omega_cells: np.ndarray
    mu_wall: np.ndarray
    k_dirichlet: bool
    production_weight: np.ndarray
    production_log: np.ndarray
    u_tau_cells: np.ndarray | None = None
    wall_law_dudn: np.ndarray | None = None


def _wall_tangential_velocity(mesh, setup, u):
    """``u_t (nw, 2)``: the owner cell's velocity relative to the (stationary or moving) wall, less its
    wall-normal part, per wall face (m/s)."""
    f = mesh.n_internal + setup.wall_local
    du = u[mesh.owner[f]] - setup.wall_velocity
    n = mesh.normal[f]
    return du - np.einsum("ij,ij->i", du, n)[:, None] * n


def _wall_tangential_speed(mesh, setup, u):
    """``|u_t|`` of the owner cell relative to the (stationary or moving) wall, per wall face, and dn."""
    return np.sqrt((_wall_tangential_velocity(mesh, setup, u)**2).sum(axis=1)), setup.wall_dn


def with_wall_law_gradient(mesh: FVMesh, setup, u: np.ndarray, grad_u: np.ndarray, dudn: np.ndarray) -> np.ndarray:
    """``grad_u (nc, 2, 2)`` with, in each cell that has exactly one wall face, the derivative of the
    tangential velocity along the inward wall normal set to ``dudn (nw,)`` (1/s, the law of the wall's); the
    other components are kept (a rank-one change ``(dudn - t·G·m) t m^T``, t the flow's tangent, m the inward
    normal). A corner cell's profile is neither wall's law, so it keeps its gradient."""
    cell = mesh.owner[mesh.n_internal + setup.wall_local]
    single = np.bincount(setup.wall_face_cell, minlength=len(setup.wall_cells))[setup.wall_face_cell] == 1
    u_t = _wall_tangential_velocity(mesh, setup, u)[single]
    speed = np.sqrt((u_t**2).sum(axis=1))
    moving = speed > 1e-300
    t = u_t[moving] / speed[moving, None]
    m = -mesh.normal[mesh.n_internal + setup.wall_local][single][moving]
    c = cell[single][moving]
    out = grad_u.copy()
    now = np.einsum("fi,fij,fj->f", t, grad_u[c], m)
    out[c] += (dudn[single][moving] - now)[:, None, None] * t[:, :, None] * m[:, None, :]
    return out


def _per_cell_max(setup, values):
    out = np.zeros(len(setup.wall_cells))
    np.maximum.at(out, setup.wall_face_cell, values)
    return out


def low_re_wall(mesh: FVMesh, setup, u: np.ndarray, k: np.ndarray, nu: float, rho: float,
                c: SSTConstants) -> WallValues:
    """Low-Reynolds treatment (resolved sublayer, y+ ~ 1): k = 0 on walls, omega = 6 nu/(beta1 d²) in
    the wall cells, wall shear from the molecular viscosity."""
    zeros = np.zeros(len(setup.wall_cells))
    return WallValues(omega_viscous(setup.distance[setup.wall_cells], nu, c),
                      np.full(len(setup.wall_local), rho * nu), True, zeros, zeros)


def automatic_wall(mesh: FVMesh, setup, u: np.ndarray, k: np.ndarray, nu: float, rho: float,
                   c: SSTConstants) -> WallValues:
    """Automatic (y+-insensitive) treatment: Spalding friction velocity, blended omega and production."""
    ut, y = _wall_tangential_speed(mesh, setup, u)
    u_tau = spalding_u_tau(ut, y, nu, c)
    mu_wall = np.where(ut > 1e-300, rho * u_tau**2 * y / np.maximum(ut, 1e-300), rho * nu)
    mu_wall = np.maximum(mu_wall, rho * nu)
    yc = setup.distance[setup.wall_cells]
    w_vis = omega_viscous(yc, nu, c)
    utc = _per_cell_max(setup, u_tau)
    w_log = omega_log(utc, yc, c)
    weight = w_log**2 / (w_vis**2 + w_log**2)
    # log-layer production tau_w/rho * dU/dy with dU/dy = u*/(kappa y), u* = beta*^(1/4) sqrt(k) (OpenFOAM's
    # omegaWallFunction G): sub-linear in k, so the wall-cell k equation has a stable fixed point
    p_log = utc**2 * c.beta_star**0.25 * np.sqrt(k[setup.wall_cells]) / (c.kappa * yc)
    return WallValues(np.sqrt(w_vis**2 + w_log**2), mu_wall, False, weight, p_log, utc,
                      spalding_velocity_gradient(ut, u_tau, nu, c))


#: Wall treatments by name: ``f(mesh, setup, u, k, nu, rho, constants) -> WallValues``.
WALL_TREATMENTS: dict[str, Callable] = {"automatic": automatic_wall, "low_re": low_re_wall}
