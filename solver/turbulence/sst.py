"""The SST model: its configuration (:class:`SST`), per-mesh data (:class:`SSTSetup`) and one k-omega step
per outer iteration (:func:`turbulence_step`), with the face diffusivities and the momentum viscosity.
See :mod:`solver.turbulence` for the equations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Self

import numpy as np

from ..assembly import CONVECTION_SCHEMES, convection_gradient
from ..boundary import FIXED, BoundaryData
from ..fvmesh import FVMesh
from ..gradient import green_gauss_gradient, interpolate_linear, ls_gradient
from ..kernels import log_mean_faces, sst_blending_arguments, sst_f2_argument, sst_omega_coefficients
from ..linalg import SolverSettings
from ..settings import _opt
from ..transport import scalar_system
from ..walldistance import WALL_TYPES, wall_distance, wall_faces
from .closures import (
    SSTConstants,
    eddy_viscosity,
    inlet_turbulence,
    omega_flux_factor,
    production,
    velocity_invariants,
)
from .walls import WALL_TREATMENTS, with_wall_law_gradient


@dataclass(frozen=True)
class SST:
    """Menter k-omega SST (SST-2003) configuration: ``Problem.create(..., turbulence=SST())``.

    Each field's ``metadata["doc"]`` says what it does (:func:`solver.settings.setting_doc`); the choices
    of a text field are the keys of its registry. :meth:`for_blades` gives the blade evaluations' model.
    """

    wall_treatment: str = _opt("automatic", "SST wall treatment, solver.turbulence.WALL_TREATMENTS: automatic "
                               "(y+-insensitive: Spalding's law of the wall blended with the sublayer) or low_re "
                               "(resolved to the wall, first cell at y+ ~ 1) "
                               "(docs/decisions/0009-sst-wall-treatment.md)")
    constants: SSTConstants = _opt(SSTConstants(), "model constants (SST-2003)")
    production_measure: str = _opt("strain", "S_P of the production terms, PRODUCTION_MEASURES: strain "
                                   "(SST-2003) or vorticity (SST-V)")
    omega_production: str = _opt("unlimited", "omega-equation production, OMEGA_PRODUCTIONS: unlimited (gamma "
                                 "S_P²) or limited (gamma P~/nu_t, the k equation's production limiter carried "
                                 "into the omega equation, as OpenFOAM's kOmegaSST) "
                                 "(docs/decisions/0004-limited-omega-production.md)")
    alpha_k: float = _opt(0.9, "implicit under-relaxation of the k equation, in (0, 1]")
    alpha_omega: float = _opt(0.9, "implicit under-relaxation of the omega equation, in (0, 1]")
    convection: str = _opt("upwind", "k and omega convection scheme, solver.assembly.CONVECTION_SCHEMES: upwind "
                           "or linear_upwind (deferred correction, limited gradient)")
    limiter: str = _opt("venkatakrishnan", "gradient limiter of linear_upwind, solver.gradient.LIMITERS")
    limiter_k: float = _opt(5.0, "the limiter's K (Venkatakrishnan's eps² = (K h)³, h in m)")
    solver: SolverSettings = _opt(doc="linear solver of the k and omega systems: symmetric Gauss-Seidel sweeps "
                                  "until the residual falls by 0.1, at most 8",
                                  factory=lambda: SolverSettings("gauss_seidel_to_tol", 0.1, 8))
    k_floor: float = _opt(1e-10, "positivity floor of k, relative to the inlet k")
    omega_floor: float = _opt(1e-6, "positivity floor of omega, relative to the inlet omega")
    face_interpolation: str = _opt("log_mean", "face values of the diffusivities mu + sigma mu_t, "
                                   "FACE_DIFFUSIVITIES: log_mean or linear")
    omega_wall_flux: str = _opt("analytic", "omega flux between a wall cell (omega fixed) and the next cells, "
                                "OMEGA_WALL_FLUXES: analytic (scaled by omega_flux_factor to carry the flux of the "
                                "analytic near-wall omega) or two_point (unscaled, as OpenFOAM's "
                                "omegaWallFunction) (docs/decisions/0009-sst-wall-treatment.md)")
    velocity_gradient: str = _opt("green_gauss_bounded", "velocity gradient of the SST step's strain and vorticity, "
                                  "VELOCITY_GRADIENTS: green_gauss_bounded (Green–Gauss on reconstructed faces, "
                                  "each within its two cells' values), green_gauss or least_squares (the momentum "
                                  "step's own) (docs/decisions/0005-sst-velocity-gradient.md)")

    @classmethod
    def for_blades(cls, **changes) -> Self:
        """The blade evaluations' model (with ``changes``): the defaults with the limited omega production
        (docs/decisions/0004-limited-omega-production.md)."""
        return cls(**{**BLADE_DEFAULTS, **changes})

    def __post_init__(self):
        if self.wall_treatment not in WALL_TREATMENTS:
            raise ValueError(f"unknown wall_treatment {self.wall_treatment!r}; choose from "
                             f"{sorted(WALL_TREATMENTS)}")
        for name, value, registry in (("production_measure", self.production_measure, PRODUCTION_MEASURES),
                                      ("omega_production", self.omega_production, OMEGA_PRODUCTIONS),
                                      ("convection", self.convection, CONVECTION_SCHEMES),
                                      ("face_interpolation", self.face_interpolation, FACE_DIFFUSIVITIES),
                                      ("omega_wall_flux", self.omega_wall_flux, OMEGA_WALL_FLUXES),
                                      ("velocity_gradient", self.velocity_gradient, VELOCITY_GRADIENTS)):
            if value not in registry:
                raise ValueError(f"unknown {name} {value!r}; choose from {sorted(registry)}")

    def setup(self, mesh: FVMesh, bnd: BoundaryData, rho: float, mu: float) -> SSTSetup:
        """Geometry and boundary data fixed for a mesh (wall distance, inlet k and omega)."""
        return build_setup(mesh, bnd, rho, mu, self.constants)


#: The fields in which :meth:`SST.for_blades` differs from the defaults.
BLADE_DEFAULTS = {"omega_production": "limited"}


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


def _log_mean_faces(mesh: FVMesh, gamma: np.ndarray) -> np.ndarray:
    """Logarithmic mean of the two cells of each internal face (:func:`solver.turbulence.log_mean`), in one
    compiled loop (:func:`solver.kernels.log_mean_faces`)."""
    ni = mesh.n_internal
    return log_mean_faces(np.ascontiguousarray(gamma, dtype=float), mesh.owner[:ni], mesh.neighbour[:ni])


#: Internal-face diffusivities by name: ``f(mesh, gamma (nc,)) -> (ni,)`` (:func:`face_diffusivity`).
FACE_DIFFUSIVITIES: dict[str, Callable] = {"log_mean": _log_mean_faces, "linear": interpolate_linear}

#: Production measures ``S_P²`` by name: ``f(S², Omega²)`` (strain: SST-2003, vorticity: SST-V).
PRODUCTION_MEASURES: dict[str, Callable] = {"strain": lambda s2, w2: s2, "vorticity": lambda s2, w2: w2}


def face_diffusivity(mesh: FVMesh, gamma: np.ndarray, gamma_b: np.ndarray, how: str = "log_mean") -> np.ndarray:
    """Face diffusivities ``(nf,)`` from cell values ``gamma (nc,) > 0`` and boundary values ``(nb,)``.

    ``"log_mean"``: the logarithmic mean of the two cells, which makes the orthogonal flux
    ``gamma_f (phi_N - phi_P) / |d|`` exact for a diffusivity varying linearly between the centroids, as
    ``mu + mu_t`` does (``mu_t = rho kappa u_tau y``) across the first cells of a wall-function mesh;
    linear interpolation there over-estimates the face diffusivity (10 % for a 1:3 cell pair in the log
    layer). ``"linear"``: distance-weighted interpolation (:func:`solver.gradient.interpolate_linear`).
    Equal on smooth fine meshes. Choices: :data:`FACE_DIFFUSIVITIES`.
    """
    try:
        inside = FACE_DIFFUSIVITIES[how]
    except KeyError:
        raise ValueError(f"unknown face interpolation {how!r}; choose from {sorted(FACE_DIFFUSIVITIES)}") from None
    return np.concatenate([inside(mesh, gamma), gamma_b])


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


def _limited_omega_production(sp2, nu_t, k, omega, c):
    """``P~ / nu_t = min(S_P², 10 beta* k omega / nu_t)`` (1/s²): the k production limiter in the omega
    source too (OpenFOAM v1912 ``kOmegaSSTBase``: ``min(GbyNu, (c1/a1) beta* omega max(a1 omega, b1 F2
    S))``, the same quantity, since ``k / nu_t = max(a1 omega, F2 S) / a1``)."""
    return np.minimum(sp2, c.production_limit * c.beta_star * k * omega / np.maximum(nu_t, 1e-300))


#: omega-equation production ``/ gamma`` by name: ``f(S_P² (nc,), nu_t, k, omega, constants) -> (nc,)``, 1/s².
OMEGA_PRODUCTIONS: dict[str, Callable] = {
    "unlimited": lambda sp2, nu_t, k, omega, c: sp2,
    "limited": _limited_omega_production,
}


#: Factor on the omega diffusivity of the faces next to the wall cells by name: ``f(y1, y2, yf, weight_log)
#: -> (nn,)`` (:func:`omega_flux_factor`'s arguments); ``"two_point"`` leaves the plain two-point flux.
OMEGA_WALL_FLUXES: dict[str, Callable] = {
    "analytic": omega_flux_factor,
    "two_point": lambda y1, y2, yf, weight_log: np.ones_like(y1),
}


def _green_gauss_velocity(mesh: FVMesh, bnd: BoundaryData, u: np.ndarray, grad_u: np.ndarray,
                          bounded: bool = False) -> np.ndarray:
    """Green–Gauss gradient ``(nc, 2, 2)`` of the velocity, on faces reconstructed with ``grad_u`` (each face
    value within its two cells' values when ``bounded``)."""
    return green_gauss_gradient(mesh, u, bnd.velocity(mesh, u, grad_u), grad_u, bounded)


#: The SST step's velocity gradient by name: ``f(mesh, bnd, u, grad_u_ls, grad_faces) -> (nc, 2, 2)``, 1/s;
#: ``grad_faces`` reconstructs the Green–Gauss forms' faces (the least-squares gradient, with the law of the
#: wall's normal derivative in the wall cells under the ``automatic`` treatment).
VELOCITY_GRADIENTS: dict[str, Callable] = {
    "least_squares": lambda mesh, bnd, u, grad_u, grad_faces: grad_u,
    "green_gauss": lambda mesh, bnd, u, grad_u, grad_faces: _green_gauss_velocity(mesh, bnd, u, grad_faces),
    "green_gauss_bounded": lambda mesh, bnd, u, grad_u, grad_faces: _green_gauss_velocity(mesh, bnd, u, grad_faces,
                                                                                         True),
}


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
    wall = WALL_TREATMENTS[model.wall_treatment](mesh, setup, u, k, nu, rho, c)
    # a wall cell's least-squares gradient holds the wall value (U_P/y-like, 5x the log law's at y+ = 30): the
    # faces it reconstructs toward the log layer overshoot, so the Green–Gauss forms take the wall law's
    grad_faces = grad_u if wall.wall_law_dudn is None else with_wall_law_gradient(mesh, setup, u, grad_u,
                                                                                  wall.wall_law_dudn)
    grad_u = VELOCITY_GRADIENTS[model.velocity_gradient](mesh, bnd, u, grad_u, grad_faces)
    s2, w2 = velocity_invariants(grad_u)
    sp2 = PRODUCTION_MEASURES[model.production_measure](s2, w2)
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
    # the closures per cell (F1, F2, nu_t, the coefficients blended by F1) in compiled loops, bitwise those of
    # f1, f2, cross_diffusion, blend (tanh and the powers stay numpy's)
    arg1, arg2, kw = sst_blending_arguments(k, omega, d, grad_k, grad_w, nu, c.sigma_w2, c.beta_star, c.cd_floor)
    F1 = np.tanh(arg1**4)
    strain = np.sqrt(s2)
    nu_t = eddy_viscosity(k, omega, strain, np.tanh(arg2**2), c)
    res = {}
    # omega: gamma S² - beta w² (Newton-linearised: 2 beta w implicit, + beta w² explicit) + cross diffusion
    p_w = OMEGA_PRODUCTIONS[model.omega_production](sp2, nu_t, k, omega, c)
    su, sp, gam_w_cell, gam_k_cell = sst_omega_coefficients(
        F1, omega, kw, p_w, nu_t, rho, mu, c.beta1, c.beta2, c.gamma1, c.gamma2, c.sigma_w1, c.sigma_w2,
        c.sigma_k1, c.sigma_k2)
    gam = face_diffusivity(mesh, gam_w_cell, gam_w_cell[ob], model.face_interpolation)
    if setup.near_faces is not None and len(setup.near_faces):     # omega flux out of the fixed wall cells
        y = setup.near_y
        gam[setup.near_faces] *= OMEGA_WALL_FLUXES[model.omega_wall_flux](
            y[:, 0], y[:, 1], y[:, 2], wall.production_weight[setup.near_wall_cell])
    gho = convection_gradient(mesh, omega, w_b, grad_w, model.convection, model.limiter, model.limiter_k)
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
    gam_k = face_diffusivity(mesh, gam_k_cell, gam_k_cell[ob], model.face_interpolation)
    gam_k[ni + wl] = mu                              # nu_t = 0 on the wall (k = 0 there with low_re)
    ghk = convection_gradient(mesh, k, k_b, grad_k, model.convection, model.limiter, model.limiter_k)
    sys_k = scalar_system(mesh, pattern, k, k_b, k_dir, flux, gam_k, grad_k, ghk, rho * c.beta_star * omega_new,
                          rho * pk, model.alpha_k)
    res["k"] = _scaled_residual(sys_k)
    k_new, _ = model.solver.solve(sys_k, solver_state.setdefault("k", {}))
    k_new = np.maximum(k_new, model.k_floor * setup.k_ref)
    # eddy viscosity from the new k and omega
    F2 = np.tanh(sst_f2_argument(k_new, omega_new, d, nu, c.beta_star)**2)
    nu_t = eddy_viscosity(k_new, omega_new, strain, F2, c)
    return res, k_new, omega_new, nu_t, wall.mu_wall


def _scaled_residual(system) -> float:
    r, n = system.residual_norms()
    return r / (n + 1e-300)
