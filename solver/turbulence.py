"""Menter k-omega SST turbulence model, SST-2003 variant, for the steady incompressible solver.

Variant: **SST-2003** of Menter, Kuntz & Langtry (2003), "Ten years of industrial experience with the SST
turbulence model", Turbulence, Heat and Mass Transfer 4, pp. 625-632, as written on the NASA Turbulence
Modeling Resource page https://turbmodels.larc.nasa.gov/sst.html ("SST-2003"), incompressible and in
kinematic form (rho constant)::

    div(u k) = P~ - beta* omega k + div((nu + sigma_k nu_t) grad k)
    div(u omega) = gamma S_P² - beta omega² + div((nu + sigma_w nu_t) grad omega)
                   + 2 (1 - F1) sigma_w2 / omega grad k · grad omega
    P~ = min(nu_t S_P², 10 beta* k omega)                (production limiter, 10 in SST-2003)
    nu_t = a1 k / max(a1 omega, S F2)                    (S = sqrt(2 S_ij S_ij), the strain invariant)
    phi = F1 phi_1 + (1 - F1) phi_2                      (sigma_k, sigma_w, beta, gamma)
    F1 = tanh(arg1⁴), arg1 = min(max(sqrt(k)/(beta* omega d), 500 nu/(d² omega)), 4 sigma_w2 k/(CD_kw d²))
    CD_kw = max(2 sigma_w2 / omega grad k · grad omega, 1e-10)
    F2 = tanh(arg2²), arg2 = max(2 sqrt(k)/(beta* omega d), 500 nu/(d² omega))

``S_P`` (the production measure) is the strain invariant ``S`` (SST-2003, :attr:`SST.production_measure`
``"strain"``, the default) or the vorticity magnitude (``"vorticity"``: SST-V, what the TMR flat-plate data
were computed with; identical in a thin shear layer). The ``2/3 rho k delta_ij`` part of the Reynolds
stress is absorbed into the pressure (``p`` is ``p + 2/3 rho k``; k = 0 on walls, so surface pressures are
unchanged with ``low_re``). The omega production ``gamma S_P²`` is ``gamma P/nu_t`` with the unlimited P.

Wall treatments (:data:`WALL_TREATMENTS`, chosen by name):

* ``low_re``: k = 0 on the wall; omega in each wall-adjacent cell is fixed to the exact near-wall
  solution ``6 nu / (beta1 d²)`` at its centroid (``d`` the exact wall distance; Menter's
  ``omega_w = 60 nu / (beta1 Δy1²)`` is the same asymptote evaluated at the wall face with a tenfold
  margin). Needs first-cell y+ of about 1; wall shear ``mu du_t/dn``.
* ``automatic``: y+-insensitive. The friction velocity of each wall face comes from Spalding's (1961)
  law of the wall, which covers the viscous sublayer, buffer and log layer, given the tangential velocity
  of the wall cell and its distance; the wall shear is ``rho u_tau²`` (through an effective wall viscosity
  in the momentum equations and in the forces). omega in the wall cell is the blend
  ``sqrt(omega_vis² + omega_log²)`` with ``omega_vis = 6 nu/(beta1 y²)``, ``omega_log = u_tau/(sqrt(beta*)
  kappa y)`` (Menter & Esch / CFX, OpenFOAM's ``omegaWallFunction`` blending); k has zero flux at the wall
  and its production in the wall cell is ``(1 - w) nu_t S_w² + w u_tau² beta*^(1/4) sqrt(k)/(kappa y)``
  with ``w = omega_log² / (omega_vis² + omega_log²)``: the second term is the wall shear times the log-law
  velocity gradient (OpenFOAM's form), the first uses the strain of the constant-stress layer
  ``S_w = u_tau² / (nu + nu_t)`` (exact in the sublayer and in the log layer) rather than the cell gradient,
  whose stencil holds the wall value. At y+ ~ 1 it reduces to ``low_re``.

Both treatments fix omega in the wall cells; the omega diffusivity of the faces between a wall cell and the
next cells is scaled by :func:`omega_flux_factor` so that the two-point difference carries the exact flux
of the analytic near-wall omega (1/y² in the sublayer, 1/y in the log layer).

Inlet turbulence (``velocity_inlet`` parameters ``intensity`` I and ``viscosity_ratio`` r = nu_t/nu, or
``length_scale`` L): ``k = 1.5 (I |U|)²``, ``omega = k / (nu r)`` (or ``sqrt(k) / (beta*^0.25 L)``).
Product defaults (blades): I = 5 %, r = 10 (:data:`DEFAULT_INTENSITY`, :data:`DEFAULT_VISCOSITY_RATIO`).
TMR freestream (flat plate, M = 0.2): ``k = 9e-9 a²``, ``omega = 1e-6 rho a²/mu``, i.e. r = 0.009 and
I = sqrt(k/1.5)/U = 3.873e-4 (:data:`TMR_FREESTREAM`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .boundary import FIXED, BoundaryData
from .fvmesh import FVMesh
from .gradient import face_gradient, limited_gradient, ls_gradient
from .linalg import SolverSettings
from .transport import scalar_system
from .walldistance import WALL_TYPES, wall_distance, wall_faces

#: Product default inlet turbulence intensity (5 %) and eddy-to-molecular viscosity ratio (blades).
DEFAULT_INTENSITY = 0.05
DEFAULT_VISCOSITY_RATIO = 10.0
#: NASA TMR freestream values (2DZP flat plate, M = 0.2): k = 9e-9 a², nu_t/nu = 0.009.
TMR_FREESTREAM = {"intensity": float(np.sqrt(9e-9 / 0.2**2 / 1.5)), "viscosity_ratio": 0.009}


@dataclass(frozen=True)
class SSTConstants:
    """SST-2003 model constants.

    Source: Menter, Kuntz & Langtry (2003), Turbulence, Heat and Mass Transfer 4, 625-632, as tabulated on
    https://turbmodels.larc.nasa.gov/sst.html (SST-2003): inner (1, k-omega) and outer (2, k-epsilon)
    sets blended by F1, gamma1 = 5/9 and gamma2 = 0.44 (the 2003 values; SST-1994 derives them from
    beta/beta* - sigma_w kappa²/sqrt(beta*)), production limiter 10 beta* k omega, CD_kw floor 1e-10.
    ``kappa`` and ``spalding_b`` are the law-of-the-wall constants of the ``automatic`` wall treatment
    (Spalding 1961). B = 5.2 is fitted to this model's own resolved near-wall profile: the ``low_re`` SST
    solution of the TMR flat plate (fine level, x = 0.97) follows Spalding's law with kappa = 0.41,
    B = 5.2 within 0.05 u+ (rms) for 5 < y+ < 60; B = 5.0 would put the wall-function shear 4-6 % high
    at y+ 10-30.
    """

    sigma_k1: float = 0.85
    sigma_w1: float = 0.5
    beta1: float = 0.075
    gamma1: float = 5.0 / 9.0
    sigma_k2: float = 1.0
    sigma_w2: float = 0.856
    beta2: float = 0.0828
    gamma2: float = 0.44
    beta_star: float = 0.09
    a1: float = 0.31
    production_limit: float = 10.0
    cd_floor: float = 1e-10
    kappa: float = 0.41
    spalding_b: float = 5.2


# ---------------------------------------------------------------------------------------------- closures
def blend(f1: np.ndarray, inner: float, outer: float) -> np.ndarray:
    """``F1 inner + (1 - F1) outer`` (an SST coefficient from its k-omega and k-epsilon values)."""
    return f1 * inner + (1.0 - f1) * outer


def cross_diffusion(grad_k: np.ndarray, grad_w: np.ndarray, omega: np.ndarray,
                    c: SSTConstants = SSTConstants()) -> np.ndarray:
    """``CD_kw = max(2 sigma_w2 / omega grad k · grad omega, cd_floor)`` ``(nc,)``, 1/s² (kinematic)."""
    return np.maximum(2.0 * c.sigma_w2 / omega * np.einsum("ij,ij->i", grad_k, grad_w), c.cd_floor)


def f1(k: np.ndarray, omega: np.ndarray, d: np.ndarray, nu: float, cd_kw: np.ndarray,
       c: SSTConstants = SSTConstants()) -> np.ndarray:
    """First blending function ``tanh(arg1⁴)``: 1 near walls (k-omega), 0 in the freestream (k-epsilon).

    k (m²/s²), omega (1/s), d: wall distance (m), nu (m²/s), cd_kw: :func:`cross_diffusion`.
    """
    arg = np.minimum(np.maximum(np.sqrt(k) / (c.beta_star * omega * d), 500.0 * nu / (d * d * omega)),
                     4.0 * c.sigma_w2 * k / (cd_kw * d * d))
    return np.tanh(arg**4)


def f2(k: np.ndarray, omega: np.ndarray, d: np.ndarray, nu: float, c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Second blending function ``tanh(arg2²)`` (activates the shear-stress limiter in boundary layers):
    1 near walls, 0 in the freestream."""
    arg = np.maximum(2.0 * np.sqrt(k) / (c.beta_star * omega * d), 500.0 * nu / (d * d * omega))
    return np.tanh(arg**2)


def eddy_viscosity(k: np.ndarray, omega: np.ndarray, strain: np.ndarray, f2_: np.ndarray,
                   c: SSTConstants = SSTConstants()) -> np.ndarray:
    """``nu_t = a1 k / max(a1 omega, S F2)`` (m²/s); ``strain`` S = sqrt(2 S_ij S_ij), 1/s. Equals k/omega
    unless the Bradshaw limiter (S F2 > a1 omega) is active."""
    return c.a1 * k / np.maximum(c.a1 * omega, strain * f2_)


def production(nu_t: np.ndarray, s2: np.ndarray, k: np.ndarray, omega: np.ndarray,
               c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Limited production of k, ``min(nu_t S_P², 10 beta* k omega)`` (m²/s³)."""
    return np.minimum(nu_t * s2, c.production_limit * c.beta_star * k * omega)


def inlet_turbulence(speed, intensity=DEFAULT_INTENSITY, viscosity_ratio=DEFAULT_VISCOSITY_RATIO, nu=1e-6,
                     length_scale=None, c: SSTConstants = SSTConstants()):
    """Inlet ``(k, omega)`` from the speed |U| (m/s), intensity I and the viscosity ratio nu_t/nu (or a
    turbulence length scale L, m): ``k = 1.5 (I |U|)²``, ``omega = k/(nu r)`` or ``sqrt(k)/(beta*^0.25 L)``."""
    k = 1.5 * (np.asarray(intensity, float) * np.asarray(speed, float)) ** 2
    if length_scale is not None:
        omega = np.sqrt(k) / (c.beta_star**0.25 * np.asarray(length_scale, float))
    else:
        omega = k / (nu * np.asarray(viscosity_ratio, float))
    return k, omega


def omega_viscous(y: np.ndarray, nu: float, c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Viscous-sublayer solution ``6 nu / (beta1 y²)`` (1/s) at distance y (m) from the wall."""
    return 6.0 * nu / (c.beta1 * y * y)


def omega_log(u_tau: np.ndarray, y: np.ndarray, c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Log-layer solution ``u_tau / (sqrt(beta*) kappa y)`` (1/s)."""
    return u_tau / (np.sqrt(c.beta_star) * c.kappa * y)


def omega_flux_factor(y1: np.ndarray, y2: np.ndarray, yf: np.ndarray, weight_log: np.ndarray) -> np.ndarray:
    """Factor on the omega diffusivity of a face between a wall cell (centroid at wall distance ``y1``) and
    a cell further out (``y2``), face centre at ``yf`` (m): the ratio of the exact diffusive flux of the
    analytic near-wall omega to the two-point difference ``(omega_2 - omega_1)/(y2 - y1)``, for
    ``omega ~ 1/y²`` (viscous sublayer) ``2 y1² y2² / (yf³ (y1 + y2))`` and for ``omega ~ 1/y`` (log layer)
    ``y1 y2 / yf²``, blended with ``weight_log`` in [0, 1]; clipped to [0.1, 1]. It is about 0.63 for the
    usual first two cells (y2 ~ 3 y1): the plain difference puts 1.6 times too much omega into the second
    cell, which under-predicts c_f by 5 % on a flat plate with first-cell y+ ~ 3 (docs/turbulence.md)."""
    phi_vis = 2.0 * y1**2 * y2**2 / (yf**3 * (y1 + y2))
    phi_log = y1 * y2 / yf**2
    return np.clip((1.0 - weight_log) * phi_vis + weight_log * phi_log, 0.1, 1.0)


def spalding_u_tau(u_t: np.ndarray, y: np.ndarray, nu: float, c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Friction velocity (m/s) from Spalding's law of the wall given the tangential speed ``u_t`` (m/s) at
    distance ``y`` (m): ``y+ = u+ + e^(-kappa B) (e^(kappa u+) - 1 - kappa u+ - (kappa u+)²/2 -
    (kappa u+)³/6)``. Solved for u+ by bisection (vectorised, 60 halvings): ``Re_y/u+ = y+(u+)`` with
    ``Re_y = u_t y / nu``, bracketed by (0, sqrt(Re_y)]. Viscous limit ``sqrt(nu u_t / y)``."""
    re_y = np.maximum(np.asarray(u_t, float) * y / nu, 1e-300)
    kap, eb = c.kappa, np.exp(-c.kappa * c.spalding_b)

    def g(up):
        ku = kap * up
        return re_y / up - (up + eb * (np.exp(ku) - 1.0 - ku - ku**2 / 2.0 - ku**3 / 6.0))

    lo = np.zeros_like(re_y)
    hi = np.sqrt(re_y) * (1.0 + 1e-12)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        pos = g(np.maximum(mid, 1e-300)) > 0
        lo = np.where(pos, mid, lo)
        hi = np.where(pos, hi, mid)
    u_plus = 0.5 * (lo + hi)
    return np.where(re_y > 1e-200, np.asarray(u_t, float) / np.maximum(u_plus, 1e-300), 0.0)


# ------------------------------------------------------------------------------------------ wall treatment
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
    """

    omega_cells: np.ndarray
    mu_wall: np.ndarray
    k_dirichlet: bool
    production_weight: np.ndarray
    production_log: np.ndarray
    u_tau_cells: np.ndarray | None = None


def _wall_tangential_speed(mesh, setup, u):
    """``|u_t|`` of the owner cell relative to the (stationary or moving) wall, per wall face, and dn."""
    f = mesh.n_internal + setup.wall_local
    du = u[mesh.owner[f]] - setup.wall_velocity
    n = mesh.normal[f]
    du_t = du - np.einsum("ij,ij->i", du, n)[:, None] * n
    return np.sqrt((du_t**2).sum(axis=1)), setup.wall_dn


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
    return WallValues(np.sqrt(w_vis**2 + w_log**2), mu_wall, False, weight, p_log, utc)


#: Wall treatments by name: ``f(mesh, setup, u, k, nu, rho, constants) -> WallValues``.
WALL_TREATMENTS: dict[str, Callable] = {"low_re": low_re_wall, "automatic": automatic_wall}


# ------------------------------------------------------------------------------------------------ model
@dataclass(frozen=True)
class SST:
    """Menter k-omega SST (SST-2003) configuration: ``Problem.create(..., turbulence=SST())``.

    wall_treatment: ``"automatic"`` (y+-insensitive) or ``"low_re"`` (y+ ~ 1), :data:`WALL_TREATMENTS`.
    constants: :class:`SSTConstants`.
    production_measure: ``"strain"`` (SST-2003) or ``"vorticity"`` (SST-V) in the production terms.
    alpha_k, alpha_omega: implicit under-relaxation of the k and omega equations.
    convection: ``"upwind"`` (default) or ``"linear_upwind"`` (deferred correction, limited gradient) for
        k and omega. Upwind by default: k and omega are source-dominated in boundary layers (production
        ~ dissipation), and with the limited linear-upwind correction the limiter chatters and stalls the
        k residual at 1e-6..1e-5 (flat plate, measured), above the default convergence tolerance; on the
        flat plate first-order k/omega convection changed c_f(0.97) by +0.3 % (medium mesh: -1.41 % vs
        -1.70 % from TMR).
    solver: linear solver of the k and omega systems.
    k_floor, omega_floor: positivity floors relative to the inlet k and omega (values are clipped).
    face_interpolation: face values of the diffusivities ``mu + sigma mu_t``: ``"log_mean"`` (default) or
        ``"linear"`` (:func:`face_diffusivity`).
    """

    wall_treatment: str = "automatic"
    constants: SSTConstants = SSTConstants()
    production_measure: str = "strain"
    alpha_k: float = 0.8
    alpha_omega: float = 0.8
    convection: str = "upwind"
    limiter: str = "venkatakrishnan"
    solver: SolverSettings = field(default_factory=lambda: SolverSettings("gauss_seidel", 0.1, 8))
    k_floor: float = 1e-10
    omega_floor: float = 1e-6
    face_interpolation: str = "log_mean"

    def __post_init__(self):
        if self.wall_treatment not in WALL_TREATMENTS:
            raise ValueError(f"unknown wall_treatment {self.wall_treatment!r}; choose from "
                             f"{sorted(WALL_TREATMENTS)}")
        if self.production_measure not in ("strain", "vorticity"):
            raise ValueError(f"unknown production_measure {self.production_measure!r}: 'strain' or 'vorticity'")
        if self.convection not in ("linear_upwind", "upwind"):
            raise ValueError(f"unknown convection {self.convection!r}: 'linear_upwind' or 'upwind'")

    def setup(self, mesh: FVMesh, bnd: BoundaryData, rho: float, mu: float) -> SSTSetup:
        """Geometry and boundary data fixed for a mesh (wall distance, inlet k and omega)."""
        return build_setup(mesh, bnd, rho, mu, self.constants)


@dataclass(frozen=True, eq=False)
class SSTSetup:
    """Per-mesh data of the SST model, built once by :meth:`SST.setup`.

    distance: ``(nc,)`` exact wall distance of the cell centroids, m.
    wall_local: ``(nw,)`` wall faces (local boundary indices); wall_dn: ``(nw,)`` owner-centroid normal
        distance, m; wall_velocity: ``(nw, 2)`` wall velocity, m/s.
    wall_cells: ``(nwc,)`` unique wall-adjacent cells; wall_face_cell: ``(nw,)`` index into wall_cells.
    k_b, omega_b: ``(nb,)`` inlet values (NaN on other faces); inlet: ``(nb,)`` bool.
    k_ref, omega_ref: the largest inlet values (initial field, floors).
    near_faces: ``(nn,)`` internal faces with a wall cell on exactly one side; near_wall_cell: ``(nn,)``
        that cell's index into wall_cells; near_y: ``(nn, 3)`` wall distances of the wall cell's centroid,
        the other centroid and the face centre, m (:func:`omega_flux_factor`).
    """

    distance: np.ndarray
    wall_local: np.ndarray
    wall_dn: np.ndarray
    wall_velocity: np.ndarray
    wall_cells: np.ndarray
    wall_face_cell: np.ndarray
    k_b: np.ndarray
    omega_b: np.ndarray
    inlet: np.ndarray
    k_ref: float
    omega_ref: float
    near_faces: np.ndarray | None = None
    near_wall_cell: np.ndarray | None = None
    near_y: np.ndarray | None = None


def build_setup(mesh: FVMesh, bnd: BoundaryData, rho: float, mu: float, c: SSTConstants) -> SSTSetup:
    """See :meth:`SST.setup`."""
    ni = mesh.n_internal
    wf = wall_faces(mesh, bnd.types)
    distance = wall_distance(mesh, wf)
    if not np.all(np.isfinite(distance)):
        raise ValueError(f"SST needs at least one wall boundary (a group of type {WALL_TYPES})")
    wl = wf - ni
    dn = np.einsum("ij,ij->i", mesh.d[wf], mesh.normal[wf])
    cells, inv = np.unique(mesh.owner[wf], return_inverse=True)
    nu = mu / rho
    nan = np.full(mesh.n_boundary, np.nan)
    ti, tr, ls = (nan if a is None else a for a in (bnd.turb_intensity, bnd.turb_ratio, bnd.turb_length))
    inlet = (bnd.velocity_kind == FIXED) & np.isfinite(ti)
    speed = np.sqrt((bnd.u_fixed**2).sum(axis=1))
    k_b, w_b = nan.copy(), nan.copy()
    if inlet.any():
        k_in, w_in = inlet_turbulence(speed[inlet], ti[inlet], tr[inlet], nu, None, c)
        has_l = np.isfinite(ls[inlet])
        if has_l.any():
            w_in = np.where(has_l, np.sqrt(k_in) / (c.beta_star**0.25 * np.where(has_l, ls[inlet], 1.0)), w_in)
        k_b[inlet], w_b[inlet] = k_in, w_in
        k_ref, w_ref = float(k_b[inlet].max()), float(w_b[inlet].max())
    else:      # closed domains: product defaults with the largest wall speed (or 1 m/s)
        uref = float(max(speed.max(), 1.0))
        k_ref, w_ref = (float(v) for v in inlet_turbulence(uref, nu=nu, c=c))
    is_wall = np.zeros(mesh.n_cells, bool)
    is_wall[cells] = True
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    near = np.flatnonzero(is_wall[o] ^ is_wall[n])
    c_in = np.where(is_wall[o[near]], o[near], n[near])
    c_out = np.where(is_wall[o[near]], n[near], o[near])
    yf = wall_distance(mesh, wf, mesh.face_centre[near])
    near_y = np.column_stack([distance[c_in], distance[c_out], yf])
    return SSTSetup(distance, wl, dn, bnd.u_fixed[wl], cells, inv, k_b, w_b, inlet, max(k_ref, 1e-300),
                    max(w_ref, 1e-300), near, np.searchsorted(cells, c_in), near_y)


# -------------------------------------------------------------------------------------------- iteration
def velocity_invariants(grad_u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(S², Omega²)`` per cell: ``S² = 2 S_ij S_ij`` and ``Omega² = 2 W_ij W_ij`` from ``grad_u
    (nc, 2, 2)`` ``[cell, component, direction]``, 1/s²."""
    s = 0.5 * (grad_u + np.swapaxes(grad_u, 1, 2))
    w = 0.5 * (grad_u - np.swapaxes(grad_u, 1, 2))
    return 2.0 * np.einsum("cij,cij->c", s, s), 2.0 * np.einsum("cij,cij->c", w, w)


def face_values(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """Linear interpolation of cell values to internal faces, then the boundary values: ``(nf,)``."""
    return np.concatenate([face_gradient(mesh, phi), phi_b])


def log_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Logarithmic mean ``(b - a) / ln(b / a)`` of positive arrays (``a`` where ``a = b``)."""
    r = b / a
    close = np.abs(r - 1.0) < 1e-6
    return np.where(close, 0.5 * (a + b), (b - a) / np.log(np.where(close, 2.0, r)))


def face_diffusivity(mesh: FVMesh, gamma: np.ndarray, gamma_b: np.ndarray, how: str = "log_mean") -> np.ndarray:
    """Face diffusivities ``(nf,)`` from cell values ``gamma (nc,) > 0`` and boundary values ``(nb,)``.

    ``"log_mean"``: the logarithmic mean of the two cells, which makes the orthogonal flux
    ``gamma_f (phi_N - phi_P) / |d|`` exact for a diffusivity varying linearly between the centroids, as
    ``mu + mu_t`` does (``mu_t = rho kappa u_tau y``) across the first cells of a wall-function mesh;
    linear interpolation there over-estimates the face diffusivity (10 % for a 1:3 cell pair in the log
    layer). ``"linear"``: distance-weighted interpolation. Equal on smooth fine meshes.
    """
    if how == "linear":
        return face_values(mesh, gamma, gamma_b)
    if how != "log_mean":
        raise ValueError(f"unknown face interpolation {how!r}: 'log_mean' or 'linear'")
    ni = mesh.n_internal
    return np.concatenate([log_mean(gamma[mesh.owner[:ni]], gamma[mesh.neighbour[:ni]]), gamma_b])


def initial_fields(setup: SSTSetup, n_cells: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform inlet (freestream) k and omega, and nu_t = k/omega."""
    k = np.full(n_cells, setup.k_ref)
    w = np.full(n_cells, setup.omega_ref)
    return k, w, k / w


def momentum_viscosity(mesh: FVMesh, setup: SSTSetup, nu_t: np.ndarray, mu_wall: np.ndarray | None,
                       rho: float, mu: float, how: str = "log_mean") -> np.ndarray:
    """Effective dynamic viscosity ``mu + rho nu_t`` on every face ``(nf,)``, Pa s: :func:`face_diffusivity`
    (``how``) inside, the inlet's ``nu_t = k/omega`` on inlet faces, the wall treatment's ``mu_wall`` on walls, the
    owner value elsewhere."""
    ni = mesh.n_internal
    nut_b = nu_t[mesh.owner[ni:]].copy()
    nut_b[setup.inlet] = setup.k_b[setup.inlet] / setup.omega_b[setup.inlet]
    mu_f = face_diffusivity(mesh, mu + rho * nu_t, mu + rho * nut_b, how)
    mu_f[ni + setup.wall_local] = mu if mu_wall is None else mu_wall
    return mu_f


def turbulence_step(model: SST, setup: SSTSetup, mesh: FVMesh, pattern, bnd: BoundaryData, u: np.ndarray,
                    grad_u: np.ndarray, flux: np.ndarray, k: np.ndarray, omega: np.ndarray, rho: float,
                    mu: float, solver_state: dict) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Solve the omega and then the k equation once (after the pressure correction).

    u, grad_u: corrected velocity ``(nc, 2)`` and its gradient ``(nc, 2, 2)``; flux: corrected face mass
    fluxes. Returns ``(residuals {"k", "omega"}, k, omega, nu_t, mu_wall)`` (new arrays).
    """
    c = model.constants
    nu = mu / rho
    ni = mesh.n_internal
    ob = mesh.owner[ni:]
    d = setup.distance
    s2, w2 = velocity_invariants(grad_u)
    sp2 = s2 if model.production_measure == "strain" else w2
    wall = WALL_TREATMENTS[model.wall_treatment](mesh, setup, u, k, nu, rho, c)
    wl, wc = setup.wall_local, setup.wall_cells
    # boundary values: inlet Dirichlet, k = 0 on walls (low_re), zero gradient elsewhere
    k_dir = setup.inlet.copy()
    if wall.k_dirichlet:
        k_dir[wl] = True
    k_b = np.where(setup.inlet, setup.k_b, k[ob])
    k_b[wl] = 0.0 if wall.k_dirichlet else k[ob[wl]]
    w_b = np.where(setup.inlet, setup.omega_b, omega[ob])
    grad_k = ls_gradient(mesh, k, k_b)
    grad_w = ls_gradient(mesh, omega, w_b)
    cd = cross_diffusion(grad_k, grad_w, omega, c)
    F1 = f1(k, omega, d, nu, cd, c)
    F2 = f2(k, omega, d, nu, c)
    nu_t = eddy_viscosity(k, omega, np.sqrt(s2), F2, c)
    res = {}
    # omega: gamma S² - beta w² (Newton-linearised: 2 beta w implicit, + beta w² explicit) + cross diffusion
    beta, gamma = blend(F1, c.beta1, c.beta2), blend(F1, c.gamma1, c.gamma2)
    sig_w = blend(F1, c.sigma_w1, c.sigma_w2)
    cdw = 2.0 * (1.0 - F1) * c.sigma_w2 / omega * np.einsum("ij,ij->i", grad_k, grad_w)
    su = rho * (gamma * sp2 + beta * omega**2 + np.maximum(cdw, 0.0))
    sp = rho * (2.0 * beta * omega + np.maximum(-cdw, 0.0) / omega)
    gam = face_diffusivity(mesh, mu + rho * sig_w * nu_t, (mu + rho * sig_w * nu_t)[ob], model.face_interpolation)
    if setup.near_faces is not None and len(setup.near_faces):     # omega flux out of the fixed wall cells
        y = setup.near_y
        gam[setup.near_faces] *= omega_flux_factor(y[:, 0], y[:, 1], y[:, 2],
                                                   wall.production_weight[setup.near_wall_cell])
    gho = _convection_gradient(mesh, omega, w_b, grad_w, model)
    sys_w = scalar_system(mesh, pattern, omega, w_b, setup.inlet, flux, gam, grad_w, gho, sp, su,
                          model.alpha_omega, wc, wall.omega_cells)
    res["omega"] = _scaled_residual(sys_w)
    omega_new, _ = model.solver.solve(sys_w, solver_state.setdefault("omega", {}))
    omega_new = np.maximum(omega_new, model.omega_floor * setup.omega_ref)
    # k: P~ - beta* w k (implicit)
    pk = production(nu_t, sp2, k, omega, c)
    if wall.u_tau_cells is not None:
        # wall cells: the strain of the constant-stress layer, (nu + nu_t) dU/dy = u_tau², instead of the cell
        # gradient, whose stencil holds the wall value (U_P/y-like: 5x too large at y+ = 30)
        s_w2 = (wall.u_tau_cells**2 / (nu + nu_t[wc]))**2
        pk[wc] = production(nu_t[wc], s_w2, k[wc], omega[wc], c)
    if np.any(wall.production_weight > 0):
        wgt = wall.production_weight
        pk[wc] = (1.0 - wgt) * pk[wc] + wgt * wall.production_log
    sig_k = blend(F1, c.sigma_k1, c.sigma_k2)
    gam_k = face_diffusivity(mesh, mu + rho * sig_k * nu_t, (mu + rho * sig_k * nu_t)[ob],
                             model.face_interpolation)
    gam_k[ni + wl] = mu                              # nu_t = 0 on the wall (k = 0 there with low_re)
    ghk = _convection_gradient(mesh, k, k_b, grad_k, model)
    sys_k = scalar_system(mesh, pattern, k, k_b, k_dir, flux, gam_k, grad_k, ghk, rho * c.beta_star * omega_new,
                          rho * pk, model.alpha_k)
    res["k"] = _scaled_residual(sys_k)
    k_new, _ = model.solver.solve(sys_k, solver_state.setdefault("k", {}))
    k_new = np.maximum(k_new, model.k_floor * setup.k_ref)
    # eddy viscosity from the new k and omega
    F2 = f2(k_new, omega_new, d, nu, c)
    nu_t = eddy_viscosity(k_new, omega_new, np.sqrt(s2), F2, c)
    return res, k_new, omega_new, nu_t, wall.mu_wall


def _convection_gradient(mesh, phi, phi_b, grad, model):
    if model.convection == "upwind":
        return np.zeros_like(grad)
    return limited_gradient(mesh, phi, phi_b, grad, model.limiter, 5.0)


def _scaled_residual(system) -> float:
    r, n = system.residual_norms()
    return r / (n + 1e-300)
