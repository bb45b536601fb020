"""Menter k-omega SST-2003 closures: the model constants and small pure functions of the local fields.

Each function is one formula of https://turbmodels.larc.nasa.gov/sst.html (SST-2003), vectorised over
cells, kinematic (rho constant), in the notation of :mod:`solver.turbulence`; the blending functions
(:func:`f1`, :func:`f2`) have unit tests of their limits. The wall treatments (:mod:`.walls`) and the
model (:mod:`.sst`) are built from these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import kernels
from ..kernels import dot_last

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


def blend(f1: np.ndarray, inner: float, outer: float) -> np.ndarray:
    """``F1 inner + (1 - F1) outer`` (an SST coefficient from its k-omega and k-epsilon values)."""
    return f1 * inner + (1.0 - f1) * outer


def cross_diffusion(grad_k: np.ndarray, grad_w: np.ndarray, omega: np.ndarray,
                    c: SSTConstants = SSTConstants()) -> np.ndarray:
    """``CD_kw = max(2 sigma_w2 / omega grad k · grad omega, cd_floor)`` ``(nc,)``, 1/s² (kinematic)."""
    return np.maximum(2.0 * c.sigma_w2 / omega * dot_last(grad_k, grad_w), c.cd_floor)


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
    cell, which under-predicts c_f by 5 % on a flat plate with first-cell y+ ~ 3 (docs/explanation/turbulence.md)."""
    phi_vis = 2.0 * y1**2 * y2**2 / (yf**3 * (y1 + y2))
    phi_log = y1 * y2 / yf**2
    return np.clip((1.0 - weight_log) * phi_vis + weight_log * phi_log, 0.1, 1.0)


def spalding_u_tau(u_t: np.ndarray, y: np.ndarray, nu: float, c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Friction velocity (m/s) from Spalding's law of the wall given the tangential speed ``u_t`` (m/s) at
    distance ``y`` (m): ``y+ = u+ + e^(-kappa B) (e^(kappa u+) - 1 - kappa u+ - (kappa u+)²/2 -
    (kappa u+)³/6)``. Solved for u+ by bisection (60 halvings): ``Re_y/u+ = y+(u+)`` with
    ``Re_y = u_t y / nu``, bracketed by (0, sqrt(Re_y)]. Viscous limit ``sqrt(nu u_t / y)``. One compiled
    loop per face (:func:`solver.kernels.spalding_u_tau`; the vectorised numpy bisection took 60 x 12 array
    operations on the few hundred wall faces, ~2 % of an outer iteration)."""
    from ..kernels import spalding_u_tau as kernel

    u_t, y = np.broadcast_arrays(np.asarray(u_t, float), np.asarray(y, float))
    shape = u_t.shape
    out = kernel(np.ascontiguousarray(u_t).ravel(), np.ascontiguousarray(y).ravel(), float(nu), c.kappa,
                 float(np.exp(-c.kappa * c.spalding_b)), 60)
    return out.reshape(shape)


def spalding_velocity_gradient(u_t: np.ndarray, u_tau: np.ndarray, nu: float,
                                c: SSTConstants = SSTConstants()) -> np.ndarray:
    """Wall-normal derivative ``dU/dy`` (1/s) of Spalding's profile at the point where the tangential speed is
    ``u_t`` (m/s), given its friction velocity ``u_tau`` (m/s, :func:`spalding_u_tau`): ``(u_tau² / nu) /
    (dy+/du+)`` with ``dy+/du+ = 1 + kappa e^(-kappa B) (e^(kappa u+) - 1 - kappa u+ - (kappa u+)²/2)``;
    ``u_tau² / nu`` in the sublayer, ``u_tau / (kappa y)`` in the log layer."""
    kup = c.kappa * np.asarray(u_t, float) / np.maximum(u_tau, 1e-300)
    dyp_dup = 1.0 + c.kappa * np.exp(-c.kappa * c.spalding_b) * (np.expm1(kup) - kup - 0.5 * kup**2)
    return u_tau**2 / nu / dyp_dup


def velocity_invariants(grad_u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(S², Omega²)`` per cell: ``S² = 2 S_ij S_ij`` and ``Omega² = 2 W_ij W_ij`` from ``grad_u
    (nc, 2, 2)`` ``[cell, component, direction]``, 1/s²; one compiled loop
    (:func:`solver.kernels.velocity_invariants`)."""
    return kernels.velocity_invariants(np.ascontiguousarray(grad_u, dtype=float))


def log_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Logarithmic mean ``(b - a) / ln(b / a)`` of positive arrays (``a`` where ``a = b``)."""
    r = b / a
    close = np.abs(r - 1.0) < 1e-6
    return np.where(close, 0.5 * (a + b), (b - a) / np.log(np.where(close, 2.0, r)))
