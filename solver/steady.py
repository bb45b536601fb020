"""Steady incompressible laminar Navier–Stokes: SIMPLEC (or SIMPLE) on a collocated unstructured mesh.

One outer iteration (:func:`outer_iteration`) reads like the algorithm:

1. boundary values and gradients of u and p (least squares; limited gradient for convection);
2. momentum systems (:func:`solver.momentum.momentum_system`) solved for the predicted velocity u*;
3. Rhie–Chow fluxes F* (:func:`solver.pressure.rhie_chow_flux`);
4. pressure correction p' (:func:`solver.pressure.pressure_correction_system`, AMG-preconditioned CG);
5. corrections ``F = F* + F'``, ``u = u* - D̃ grad p'``, ``p = p + alpha_p p'``;
6. with a turbulence model (:class:`solver.turbulence.SST`): the omega and k equations from the corrected
   velocity and fluxes, then the eddy viscosity ``mu_t`` used by the next momentum step (per face
   ``mu + mu_t``, :func:`solver.turbulence.turbulence_step`).

:func:`solve_steady` loops until the scaled residuals are below ``tol`` and the monitored integral
quantities (C_max and the forces on ``monitor_groups``) have stopped changing, or until ``max_iter``;
non-finite or exploding values stop the loop with status ``diverged``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .boundary import BoundaryData, resolve_boundaries
from .fvmesh import FVMesh
from .gradient import green_gauss_gradient, limited_gradient, ls_gradient
from .linalg import FVPattern, SolverSettings
from .momentum import momentum_system
from .pressure import correct_flux, mass_imbalance, predicted_velocity_flux, pressure_correction_system, rhie_chow_flux
from .results import FlowResults
from .turbulence import SST, SSTSetup, initial_fields, momentum_viscosity, turbulence_step


class DivergenceError(ArithmeticError):
    """Raised inside an iteration when a variable's system or field stops being finite."""

    def __init__(self, variable: str, reason: str):
        super().__init__(f"{variable}: {reason}")
        self.variable = variable


def _check_finite(variable: str, what: str, *arrays) -> None:
    for a in arrays:
        if not np.all(np.isfinite(a)):
            raise DivergenceError(variable, f"{what} not finite")


@dataclass(frozen=True)
class Fluid:
    """Constant-property fluid: density ``rho`` (kg/m³) and dynamic viscosity ``mu`` (Pa s)."""

    rho: float = 1.0
    mu: float = 1e-3


@dataclass(frozen=True)
class SimpleSettings:
    """Settings of the steady pressure-based solver (every option has a default).

    algorithm: ``"simplec"`` or ``"simple"``.
    alpha_u, alpha_p: momentum and pressure under-relaxation (SIMPLEC: alpha_p = 1).
    convection: ``"linear_upwind"`` (second order, deferred correction) or ``"upwind"``.
    limiter, limiter_k: gradient limiter for convection (:data:`solver.gradient.LIMITERS`).
    tol: scaled-residual tolerance for u, v and continuity.
    monitor_tol, monitor_window: integral quantities must vary less than ``monitor_tol`` (relative)
        over the last ``monitor_window`` iterations.
    monitor_groups: boundary groups whose forces are monitored.
    classify_window, classify_tol: a solve that reaches ``max_iter`` is classified from its monitors over
        the last ``classify_window`` iterations (:func:`solver.convergence.classify`): ``converged`` if
        they are stationary within ``classify_tol`` (relative), ``oscillating`` (bounded; use the window
        means in ``FlowResults.classification``) or ``not_converged`` (drifting).
    stall_tol: if set, a solve also stops as ``converged`` once its monitors are stationary in that sense
        and every scaled residual is below ``stall_tol`` — for residuals that stall above ``tol``
        (limiter chatter in RANS runs) while forces and C_max have settled. None (default): off.
    divergence_factor: a residual above 1 and this many times its running minimum means divergence.
    velocity_limit: a cell velocity component above this (m/s) means divergence.
    pressure_gradient: gradient of p in the momentum source: ``"least_squares"`` or ``"green_gauss"``
        (:func:`solver.gradient.green_gauss_gradient` on skewness-corrected face values).
    blas_threads: BLAS threads while iterating (via threadpoolctl when installed; None: leave as is).
        The per-iteration work is many small vector operations, where BLAS threads only contend
        (measured 5x slower with default OpenBLAS threading on a busy 2-core machine).
    """

    algorithm: str = "simplec"
    alpha_u: float = 0.8
    alpha_p: float = 1.0
    convection: str = "linear_upwind"
    limiter: str = "venkatakrishnan"
    limiter_k: float = 5.0
    max_iter: int = 2000
    tol: float = 1e-6
    monitor_tol: float = 1e-5
    monitor_window: int = 20
    monitor_groups: tuple[str, ...] = ()
    classify_window: int = 200
    classify_tol: float = 1e-3
    stall_tol: float | None = None
    pressure_gradient: str = "least_squares"
    blas_threads: int | None = 1
    divergence_factor: float = 1e5
    velocity_limit: float = 1e4
    momentum_solver: SolverSettings = field(default_factory=lambda: SolverSettings("gauss_seidel", 0.1, 8))
    pressure_solver: SolverSettings = field(default_factory=lambda: SolverSettings("amg", 0.05, 50))


@dataclass
class FlowState:
    """Mutable iterate: velocity ``(nc, 2)`` m/s, pressure ``(nc,)`` Pa, face mass flux ``(nf,)`` kg/(s m),
    and the last gradients of p ``(nc, 2)`` and u ``(nc, 2, 2)`` (lagged boundary extrapolation).
    Turbulent runs also carry k ``(nc,)`` m²/s², omega ``(nc,)`` 1/s, nu_t ``(nc,)`` m²/s and the wall
    faces' effective viscosity ``mu_wall`` (Pa s, :class:`solver.turbulence.WallValues`); None if laminar."""

    u: np.ndarray
    p: np.ndarray
    flux: np.ndarray
    grad_p: np.ndarray
    grad_u: np.ndarray
    k: np.ndarray | None = None
    omega: np.ndarray | None = None
    nu_t: np.ndarray | None = None
    mu_wall: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Problem:
    """A mesh with resolved boundary conditions, fluid and the FV sparsity pattern (built once).

    turbulence: None (laminar) or :class:`solver.turbulence.SST`; turbulence_setup: its per-mesh data
    (wall distance, inlet k and omega), built by :meth:`create`.
    """

    mesh: FVMesh
    bnd: BoundaryData
    fluid: Fluid
    pattern: FVPattern
    body_force: np.ndarray | None = None
    turbulence: SST | None = None
    turbulence_setup: SSTSetup | None = None

    @classmethod
    def create(cls, mesh: FVMesh, boundary_conditions: dict, fluid: Fluid = Fluid(),
               body_force: np.ndarray | None = None, turbulence: SST | None = None) -> Problem:
        """``body_force``: optional ``(nc, 2)`` force per unit volume at the cell centroids, N/m³.
        ``turbulence``: None (laminar) or ``solver.turbulence.SST(wall_treatment=..., constants=...)``;
        inlet turbulence from the ``velocity_inlet`` parameters ``intensity`` and ``viscosity_ratio``."""
        bnd = resolve_boundaries(mesh, boundary_conditions)
        setup = None
        if turbulence is not None:
            if not isinstance(turbulence, SST):
                raise TypeError(f"turbulence must be None or solver.turbulence.SST, not {type(turbulence)}")
            setup = turbulence.setup(mesh, bnd, fluid.rho, fluid.mu)
        return cls(mesh, bnd, fluid, FVPattern.from_mesh(mesh), body_force, turbulence, setup)


def initial_state(problem: Problem, u0=(0.0, 0.0)) -> FlowState:
    """Uniform velocity ``u0`` (m/s), zero pressure, fluxes consistent with the boundary values."""
    m, b = problem.mesh, problem.bnd
    u = np.broadcast_to(np.asarray(u0, float), (m.n_cells, 2)).copy()
    flux = predicted_velocity_flux(m, b, u, b.velocity(m, u), np.zeros((m.n_cells, 2, 2)), problem.fluid.rho)
    s = FlowState(u, np.zeros(m.n_cells), flux, np.zeros((m.n_cells, 2)), np.zeros((m.n_cells, 2, 2)))
    if problem.turbulence is not None:
        s.k, s.omega, s.nu_t = initial_fields(problem.turbulence_setup, m.n_cells)
    return s


def outer_iteration(problem: Problem, s: FlowState, cfg: SimpleSettings, solver_state: dict) -> dict:
    """One SIMPLE(C) iteration, updating ``s`` in place; returns the scaled residuals."""
    m, bnd, rho, mu = problem.mesh, problem.bnd, problem.fluid.rho, problem.fluid.mu
    # 1. boundary values and gradients
    u_b = bnd.velocity(m, s.u, s.grad_u)
    grad_u = ls_gradient(m, s.u, u_b)
    u_b = bnd.velocity(m, s.u, grad_u)
    s.grad_u = grad_u
    p_b = bnd.pressure(m, s.p, s.grad_p)
    s.grad_p = ls_gradient(m, s.p, p_b)
    p_b = bnd.pressure(m, s.p, s.grad_p)
    grad_ho = _convection_gradient(m, s.u, u_b, grad_u, cfg)
    # 2. momentum predictor
    grad_p_mom = _pressure_gradient(m, s.p, p_b, s.grad_p, cfg)
    turb = problem.turbulence
    mu_eff = mu if turb is None else momentum_viscosity(m, problem.turbulence_setup, s.nu_t, s.mu_wall, rho, mu,
                                                        turb.face_interpolation)
    mom = momentum_system(m, problem.pattern, bnd, s.u, u_b, s.flux, grad_u, grad_ho, grad_p_mom, mu_eff,
                          cfg.alpha_u, problem.body_force)
    _check_finite("u", "momentum coefficients or source", mom.u.A.data, mom.u.b, mom.v.A.data, mom.v.b)
    (ru, nu), (rv, nv) = mom.u.residual_norms(), mom.v.residual_norms()
    scale = max(nu, nv) + 1e-300        # one normaliser for both components (a zero v field stays 0)
    res = {"u": ru / scale, "v": rv / scale}
    u_star = np.column_stack([cfg.momentum_solver.solve(mom.u)[0], cfg.momentum_solver.solve(mom.v)[0]])
    # 3. Rhie–Chow fluxes (Majumdar's term keeps the converged flux independent of alpha_u)
    relax = (1.0 - cfg.alpha_u) * (s.flux - predicted_velocity_flux(m, bnd, s.u, u_b, grad_u, rho))
    r_au = m.volume / mom.a_p
    u_b_star = bnd.velocity(m, u_star, grad_u)
    grad_u_star = ls_gradient(m, u_star, u_b_star)
    flux = rhie_chow_flux(m, bnd, u_star, u_b_star, grad_u_star, s.p, p_b, s.grad_p, r_au, rho, relax)
    imbalance = mass_imbalance(m, flux)
    res["continuity"] = float(np.abs(imbalance).sum() / (np.abs(flux).sum() + 1e-300))
    # 4. pressure correction
    r_atu = m.volume / (mom.a_p - mom.h1) if cfg.algorithm == "simplec" else r_au
    pc = pressure_correction_system(m, problem.pattern, bnd, flux, r_atu, rho)
    _check_finite("p", "pressure-correction coefficients or source", pc.system.A.data, pc.system.b)
    p_corr, _ = cfg.pressure_solver.solve(pc.system, solver_state.setdefault("pressure", {}))
    # 5. corrections
    s.flux = correct_flux(m, flux, pc.coef, p_corr)
    pcb = np.where(bnd.p_fixed, 0.0, p_corr[m.owner[m.n_internal:]])
    s.u = u_star - r_atu[:, None] * ls_gradient(m, p_corr, pcb)
    s.p = s.p + cfg.alpha_p * p_corr
    if pc.pinned:
        s.p -= s.p.mean()
    # 6. turbulence (omega, k, nu_t) from the corrected velocity and fluxes
    if turb is not None:
        u_b = bnd.velocity(m, s.u, grad_u)
        grad_u_new = ls_gradient(m, s.u, u_b)
        r_t, s.k, s.omega, s.nu_t, s.mu_wall = turbulence_step(
            turb, problem.turbulence_setup, m, problem.pattern, bnd, s.u, grad_u_new, s.flux, s.k, s.omega,
            rho, mu, solver_state)
        _check_finite("k", "k or omega", s.k, s.omega)
        res.update(r_t)
    return res


def _pressure_gradient(m, p, p_b, grad_p, cfg):
    """Pressure gradient of the momentum source (Pa/m) by :attr:`SimpleSettings.pressure_gradient`."""
    if cfg.pressure_gradient == "least_squares":
        return grad_p
    if cfg.pressure_gradient != "green_gauss":
        raise ValueError(f"unknown pressure_gradient {cfg.pressure_gradient!r}: 'least_squares' or 'green_gauss'")
    return green_gauss_gradient(m, p, p_b, grad_p)


def _convection_gradient(m, u, u_b, grad_u, cfg):
    """Gradient used for the convective face values: limited (linear upwind) or zero (upwind)."""
    if cfg.convection == "upwind":
        return np.zeros_like(grad_u)
    if cfg.convection != "linear_upwind":
        raise ValueError(f"unknown convection scheme {cfg.convection!r}: 'linear_upwind' or 'upwind'")
    return np.stack([limited_gradient(m, u[:, c], u_b[:, c], grad_u[:, c], cfg.limiter, cfg.limiter_k)
                     for c in range(2)], axis=1)


def solve_steady(problem: Problem, settings: SimpleSettings = SimpleSettings(), state: FlowState | None = None,
                 callback=None) -> FlowResults:
    """Iterate :func:`outer_iteration` to convergence; never returns NaN fields.

    ``callback(iteration, residuals, state)`` is called after each iteration (for logging).
    Status ``diverged`` (with the iteration and the variable in ``message``) when a residual or field
    becomes non-finite or a residual exceeds ``divergence_factor`` times its running minimum; the fields
    returned are then the last finite iterate.
    """
    with _blas_threads(settings.blas_threads):
        return _solve_steady(problem, settings, state, callback)


def _blas_threads(n):
    """Context limiting BLAS threads to ``n`` (no-op without threadpoolctl or with ``n`` None)."""
    import contextlib

    if n is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=n, user_api="blas")


def _solve_steady(problem, settings, state, callback):
    t0 = time.perf_counter()
    s = initial_state(problem) if state is None else state
    hist = {"u": [], "v": [], "continuity": []}
    if problem.turbulence is not None:
        hist.update(k=[], omega=[])
    monitors: dict[str, list] = {"c_max": []}
    for g in settings.monitor_groups:
        monitors[f"fx:{g}"], monitors[f"fy:{g}"] = [], []
    solver_state: dict = {}
    status, message, last_good = "not_converged", f"reached max_iter = {settings.max_iter}", None
    it = 0
    for it in range(1, settings.max_iter + 1):
        last_good = FlowStateCopy(s)
        try:
            with np.errstate(all="ignore"):
                res = outer_iteration(problem, s, settings, solver_state)
        except (DivergenceError, ValueError, np.linalg.LinAlgError) as exc:
            status, message = "diverged", f"diverged at iteration {it}: {exc}"
            s = last_good.restore()
            break
        for k, v in res.items():
            hist[k].append(v)
        bad = _divergence(res, hist, s, settings)
        if bad:
            status, message = "diverged", f"diverged at iteration {it}: {bad}"
            s = last_good.restore()
            break
        _update_monitors(problem, s, monitors, settings)
        if callback is not None:
            callback(it, res, s)
        if max(res.values()) < settings.tol and _stationary(monitors, settings):
            status, message = "converged", (f"scaled residuals < {settings.tol:g} and monitors stationary "
                                            f"within {settings.monitor_tol:g} over {settings.monitor_window}"
                                            " iterations")
            break
        if _settled(res, monitors, it, settings):
            status, message = "converged", (
                f"monitors stationary within {settings.classify_tol:g} over {settings.classify_window} iterations"
                f" and scaled residuals < {settings.stall_tol:g} (largest {max(res.values()):.2e})")
            break
    monitor_arrays = {k: np.array(v) for k, v in monitors.items()}
    classification = None
    if status == "not_converged":
        status, message, classification = _classify_at_cap(monitor_arrays, hist, settings)
    return FlowResults(problem.mesh, problem.bnd, s.u, s.p, s.flux, {k: np.array(v) for k, v in hist.items()},
                       status, message, it, problem.fluid.rho, problem.fluid.mu,
                       time.perf_counter() - t0, monitor_arrays, classification=classification,
                       **_turbulent_fields(problem, s))


def _settled(res: dict, monitors: dict, it: int, cfg: SimpleSettings) -> bool:
    """Early stop of a solve whose residuals stall above ``tol`` (limiter chatter, a k residual
    floor): every monitor stationary within ``classify_tol`` over ``classify_window`` iterations and
    every scaled residual below ``stall_tol``. Checked every 10 iterations; off when ``stall_tol`` is
    None."""
    if cfg.stall_tol is None or it < cfg.classify_window or it % 10 or max(res.values()) >= cfg.stall_tol:
        return False
    from .convergence import classify

    window = {k: np.asarray(v[-cfg.classify_window:]) for k, v in monitors.items()}
    return classify(window, window=cfg.classify_window, tol=cfg.classify_tol).status == "stationary"


def _classify_at_cap(monitors: dict, hist: dict, cfg: SimpleSettings):
    """Status, message and :class:`solver.convergence.Classification` of a solve stopped by
    ``max_iter``: ``converged`` when every monitor is stationary within ``classify_tol`` over the last
    ``classify_window`` iterations (the residuals stalled; their last values are in the message),
    ``oscillating`` (bounded: use the window means) or ``not_converged`` (drifting)."""
    from .convergence import classify

    cls = classify(monitors, window=cfg.classify_window, tol=cfg.classify_tol)
    last = max(v[-1] for v in hist.values() if len(v)) if any(len(v) for v in hist.values()) else float("nan")
    head = f"reached max_iter = {cfg.max_iter} (largest scaled residual {last:.2e})"
    if cls.status == "stationary":
        return "converged", f"{head}; monitors stationary: {cls.reason}", cls
    return cls.status, f"{head}; {cls.reason}", cls


def _turbulent_fields(problem: Problem, s: FlowState) -> dict:
    """Keyword arguments of :class:`FlowResults` for the turbulent fields (empty when laminar)."""
    if problem.turbulence is None:
        return {}
    mu_wall = None
    if s.mu_wall is not None:
        mu_wall = np.full(problem.mesh.n_boundary, problem.fluid.mu)
        mu_wall[problem.turbulence_setup.wall_local] = s.mu_wall
    return dict(k=s.k, omega=s.omega, nu_t=s.nu_t, mu_wall=mu_wall,
                wall_treatment=problem.turbulence.wall_treatment)


class FlowStateCopy:
    """A copy of a :class:`FlowState` to fall back to after divergence."""

    def __init__(self, s: FlowState):
        def cp(a):
            return None if a is None else a.copy()

        self._s = FlowState(s.u.copy(), s.p.copy(), s.flux.copy(), s.grad_p.copy(), s.grad_u.copy(),
                            cp(s.k), cp(s.omega), cp(s.nu_t), cp(s.mu_wall))

    def restore(self) -> FlowState:
        return self._s


def _divergence(res: dict, hist: dict, s: FlowState, cfg: SimpleSettings) -> str:
    """Empty string, or which variable went non-finite or exploded."""
    for k, v in res.items():
        if not np.isfinite(v):
            return f"residual of {k} is not finite"
        if v > 1.0 and v > cfg.divergence_factor * min(hist[k]):
            return f"residual of {k} grew to {v:.3e} (> 1 and {cfg.divergence_factor:g} x its minimum)"
    for name, a in (("u", s.u), ("p", s.p), ("flux", s.flux), ("k", s.k), ("omega", s.omega)):
        if a is not None and not np.all(np.isfinite(a)):
            return f"field {name} is not finite"
    umax = float(np.abs(s.u).max())
    if umax > cfg.velocity_limit:
        return f"velocity exploded (max |u| = {umax:.3e} m/s > velocity_limit)"
    return ""


def _update_monitors(problem: Problem, s: FlowState, monitors: dict, cfg: SimpleSettings) -> None:
    monitors["c_max"].append(float(np.sqrt((s.u**2).sum(axis=1)).max()))
    if cfg.monitor_groups:
        r = FlowResults(problem.mesh, problem.bnd, s.u, s.p, s.flux, {}, "", "", 0, problem.fluid.rho,
                        problem.fluid.mu, **_turbulent_fields(problem, s))
        for g in cfg.monitor_groups:
            f = r.forces(g).total
            monitors[f"fx:{g}"].append(float(f[0]))
            monitors[f"fy:{g}"].append(float(f[1]))


def _stationary(monitors: dict, cfg: SimpleSettings) -> bool:
    """All monitors vary by less than ``monitor_tol`` (relative to their magnitude) over the window."""
    w = cfg.monitor_window
    for v in monitors.values():
        if len(v) < w:
            return False
        last = np.asarray(v[-w:])
        scale = max(np.abs(last).max(), 1e-12)
        if (last.max() - last.min()) / scale > cfg.monitor_tol:
            return False
    return True
