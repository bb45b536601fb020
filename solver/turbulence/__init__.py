"""Menter k-omega SST turbulence model, SST-2003 variant, for the steady incompressible solver.

Layout: :mod:`.closures` (constants and pure formulas), :mod:`.walls` (wall treatments by name),
:mod:`.sst` (the model, its per-mesh set-up and the k-omega step).

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

from .closures import (
    DEFAULT_INTENSITY,
    DEFAULT_VISCOSITY_RATIO,
    TMR_FREESTREAM,
    SSTConstants,
    blend,
    cross_diffusion,
    eddy_viscosity,
    f1,
    f2,
    inlet_turbulence,
    log_mean,
    omega_flux_factor,
    omega_log,
    omega_viscous,
    production,
    spalding_u_tau,
    spalding_velocity_gradient,
    velocity_invariants,
)
from .sst import (
    FACE_DIFFUSIVITIES,
    OMEGA_PRODUCTIONS,
    OMEGA_WALL_FLUXES,
    PRODUCTION_MEASURES,
    SST,
    VELOCITY_GRADIENTS,
    SSTSetup,
    build_setup,
    face_diffusivity,
    initial_fields,
    momentum_viscosity,
    turbulence_step,
)
from .walls import WALL_TREATMENTS, WallValues, automatic_wall, low_re_wall

#: Flow models by name: the turbulence model's configuration class, or None for laminar flow (``Problem.create(...,
#: turbulence=MODELS[name]())`` when not None).
MODELS: dict[str, type | None] = {"sst": SST, "laminar": None}

__all__ = [
    "DEFAULT_INTENSITY", "DEFAULT_VISCOSITY_RATIO", "FACE_DIFFUSIVITIES", "MODELS", "OMEGA_PRODUCTIONS",
    "OMEGA_WALL_FLUXES", "PRODUCTION_MEASURES", "SST", "SSTConstants", "SSTSetup", "TMR_FREESTREAM",
    "VELOCITY_GRADIENTS", "WALL_TREATMENTS", "WallValues", "automatic_wall", "blend", "build_setup",
    "cross_diffusion", "eddy_viscosity", "f1", "f2", "face_diffusivity", "inlet_turbulence", "initial_fields",
    "log_mean", "low_re_wall", "momentum_viscosity", "omega_flux_factor", "omega_log", "omega_viscous",
    "production", "spalding_u_tau", "spalding_velocity_gradient", "turbulence_step", "velocity_invariants",
]
