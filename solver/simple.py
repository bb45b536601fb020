"""Steady incompressible Navier–Stokes (laminar, or RANS with k-omega SST): the SIMPLE / SIMPLEC outer
iteration on a collocated unstructured mesh and the loop that drives it to convergence.

One outer iteration (:func:`outer_iteration`) reads like the algorithm:

1. boundary values and gradients of u and p (least squares; limited gradient for convection);
2. momentum systems (:func:`solver.momentum.momentum_system`) solved for the predicted velocity u*;
3. Rhie–Chow fluxes F* (:func:`solver.pressure.rhie_chow_flux`);
4. pressure correction p' (:func:`solver.pressure.pressure_correction_system`, AMG-preconditioned CG) with
   the coefficient of the algorithm (:data:`ALGORITHMS`);
5. corrections ``F = F* + F'``, ``u = u* - D̃ grad p'``, ``p = p + alpha_p p'``;
6. with a turbulence model (:class:`solver.turbulence.SST`): the omega and k equations from the corrected
   velocity and fluxes, then the eddy viscosity ``mu_t`` used by the next momentum step (per face
   ``mu + mu_t``, :func:`solver.turbulence.turbulence_step`).

:func:`solve_steady` loops until the scaled residuals are below ``tol`` and the monitored integral
quantities (C_max and the forces on ``monitor_groups``, :mod:`solver.monitors`) have stopped changing, or
until ``max_iter``; non-finite or exploding values stop the loop with status ``diverged``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable

import numpy as np

from .assembly import convection_gradient
from .gradient import green_gauss_gradient, green_gauss_linear_gradient, ls_gradient
from .momentum import MomentumSystem, momentum_system
from .monitors import (
    DivergenceError,
    check_finite,
    classify_at_cap,
    divergence,
    established,
    new_monitors,
    settled,
    stationary,
    stop_monitor_names,
    update_monitors,
)
from .pressure import (
    FACE_VELOCITIES,
    correct_flux,
    mass_imbalance,
    predicted_velocity_flux,
    pressure_correction_system,
    rhie_chow_flux,
)
from .problem import FlowState, Problem, initial_state, turbulent_fields
from .results import FlowResults
from .settings import SimpleSettings
from .turbulence import momentum_viscosity, turbulence_step


def simplec_coefficient(volume: np.ndarray, mom: MomentumSystem) -> np.ndarray:
    """SIMPLEC's ``D̃ = V / (a_P - H1)`` (Van Doormaal & Raithby 1984; OpenFOAM's ``consistent``), with the
    denominator bounded below by ``(1 - alpha) a_P``, m² s/kg · m².

    Why the bound: ``a_P = (Σ|a_nb| + net outflow + boundary terms) / alpha``, so ``a_P - H1 = (1/alpha - 1)
    Σ|a_nb| + (net outflow + boundary terms) / alpha``; in a cell with net inflow (a continuity error of
    the current iterate, large in the first iterations at Re ~ 1e6) it turns small or negative and the
    pressure correction explodes. ``(1 - alpha) a_P`` is its value for a cell without continuity error
    (what OpenFOAM's ``bounded`` convection schemes build by removing ``div(phi)`` from the diagonal). At
    convergence ``p' = 0``: the bound changes the path, never the converged solution."""
    return volume / np.maximum(mom.a_p - mom.h1, (1.0 - mom.alpha) * mom.a_p)


#: Pressure-velocity algorithms by name: ``f(volume (nc,), momentum system) -> D̃ (nc,)``, the coefficient of
#: the pressure correction ``u' = -D̃ grad p'``: ``V / a_P`` (SIMPLE) or ``V / (a_P - H1)`` (SIMPLEC, bounded:
#: :func:`simplec_coefficient`).
ALGORITHMS: dict[str, Callable[[np.ndarray, MomentumSystem], np.ndarray]] = {
    "simple": lambda volume, mom: volume / mom.a_p,
    "simplec": simplec_coefficient,
}

#: Pressure gradients of the momentum source by name: ``f(mesh, p, p_b, grad_p_ls) -> (nc, 2)`` Pa/m; the
#: least-squares gradient itself, or Green–Gauss on skewness-corrected face values
#: (:func:`solver.gradient.green_gauss_gradient`), the same with each face value kept within its two cells'
#: values (``green_gauss_bounded``), or on plain linear ones (:func:`solver.gradient.green_gauss_linear_gradient`,
#: OpenFOAM's ``Gauss linear``). The same gradient is the cell gradient of the Rhie–Chow interpolation
#: (:func:`outer_iteration`, step 3), so that the face flux keeps no pressure term the p' equation does not see.
#: docs/decisions/0001-blade-pressure-gradient.md.
PRESSURE_GRADIENTS: dict[str, Callable] = {
    "least_squares": lambda mesh, p, p_b, grad_p: grad_p,
    "green_gauss": green_gauss_gradient,
    "green_gauss_bounded": lambda mesh, p, p_b, grad_p: green_gauss_gradient(mesh, p, p_b, grad_p, bounded=True),
    "green_gauss_linear": green_gauss_linear_gradient,
}


def _lookup(registry: dict, kind: str, name: str):
    try:
        return registry[name]
    except KeyError:
        raise ValueError(f"unknown {kind} {name!r}; choose from {sorted(registry)}") from None


def active_limiter(cfg: SimpleSettings, solver_state: dict) -> str:
    """The convection limiter of this iteration: ``cfg.limiter`` up to ``cfg.limiter_iterations``, then none."""
    limited_until = cfg.limiter_iterations
    if limited_until is not None and solver_state.get("iteration", 0) > limited_until:
        return "none"
    return cfg.limiter


def limiter_settled(cfg: SimpleSettings, iteration: int) -> bool:
    """True once the limiter of the start-up (``cfg.limiter_iterations``) is off or there is none."""
    return cfg.limiter_iterations is None or iteration > cfg.limiter_iterations


def outer_iteration(problem: Problem, s: FlowState, cfg: SimpleSettings, solver_state: dict) -> dict:
    """One SIMPLE(C) iteration, updating ``s`` in place; returns the scaled residuals."""
    m, bnd, rho, mu = problem.mesh, problem.bnd, problem.fluid.rho, problem.fluid.mu
    # 1. boundary values and gradients (the turbulence step of the iteration before computed the same
    #    gradient of the same velocity with the same boundary values: kept, not recomputed)
    grad_u = solver_state.pop("grad_u", None)
    if grad_u is None:
        grad_u = ls_gradient(m, s.u, bnd.velocity(m, s.u, s.grad_u))
    u_b = bnd.velocity(m, s.u, grad_u)
    s.grad_u = grad_u
    p_b = bnd.pressure(m, s.p, s.grad_p)
    s.grad_p = ls_gradient(m, s.p, p_b)
    p_b = bnd.pressure(m, s.p, s.grad_p)
    grad_ho = convection_gradient(m, s.u, u_b, grad_u, cfg.convection, active_limiter(cfg, solver_state),
                                  cfg.limiter_k)
    # 2. momentum predictor
    grad_p_mom = _lookup(PRESSURE_GRADIENTS, "pressure_gradient", cfg.pressure_gradient)(m, s.p, p_b, s.grad_p)
    if cfg.pressure_gradient in ("green_gauss", "green_gauss_bounded") and cfg.green_gauss_relaxation < 1.0:
        grad_p_mom = relaxed_correction(grad_p_mom, green_gauss_linear_gradient(m, s.p, p_b),
                                        cfg.green_gauss_relaxation, solver_state)
    turb = problem.turbulence
    mu_eff = mu if turb is None else momentum_viscosity(m, problem.turbulence_setup, s.nu_t, s.mu_wall, rho, mu,
                                                        turb.face_interpolation)
    mom = momentum_system(m, problem.pattern, bnd, s.u, u_b, s.flux, grad_u, grad_ho, grad_p_mom, mu_eff,
                          cfg.alpha_u, problem.body_force)
    check_finite("u", "momentum coefficients or source", mom.u.A.data, mom.u.b, mom.v.A.data, mom.v.b)
    (ru, nu), (rv, nv) = mom.u.residual_norms(), mom.v.residual_norms()
    scale = max(nu, nv) + 1e-300        # one normaliser for both components (a zero v field stays 0)
    res = {"u": ru / scale, "v": rv / scale}
    u_star = mom.solve(cfg.momentum_solver)
    # 3. Rhie–Chow fluxes (Majumdar's term keeps the converged flux independent of alpha_u). The cell
    #    pressure gradient interpolated to the faces is the momentum source's (grad_p_mom): only then does
    #    the face flux's pressure term reduce to the compact face gradient that the p' equation sees
    bounded = _lookup(FACE_VELOCITIES, "face_velocity", cfg.face_velocity)
    relax = (1.0 - cfg.alpha_u) * (s.flux - predicted_velocity_flux(m, bnd, s.u, u_b, grad_u, rho, bounded))
    r_au = m.volume / mom.a_p
    u_b_star = bnd.velocity(m, u_star, grad_u)
    grad_u_star = ls_gradient(m, u_star, u_b_star)
    flux = rhie_chow_flux(m, bnd, u_star, u_b_star, grad_u_star, s.p, p_b, grad_p_mom, r_au, rho, relax, bounded)
    imbalance = mass_imbalance(m, flux)
    res["continuity"] = float(np.abs(imbalance).sum() / (np.abs(flux).sum() + 1e-300))
    # 4. pressure correction
    r_atu = _lookup(ALGORITHMS, "algorithm", cfg.algorithm)(m.volume, mom)
    pc = pressure_correction_system(m, problem.pattern, bnd, flux, r_atu, rho, imbalance)
    check_finite("p", "pressure-correction coefficients or source", pc.system.A.data, pc.system.b)
    p_corr, _ = cfg.pressure_solver.solve(pc.system, solver_state.setdefault("pressure", {}))
    # 5. corrections
    s.flux = correct_flux(m, flux, pc.coef, p_corr)
    pcb = np.where(bnd.p_fixed, 0.0, p_corr[m.owner[m.n_internal:]])
    s.u = u_star - r_atu[:, None] * ls_gradient(m, p_corr, pcb)
    s.p = s.p + cfg.pressure_relaxation * p_corr
    if pc.pinned:
        s.p -= s.p.mean()
    # 6. turbulence (omega, k, nu_t) from the corrected velocity and fluxes
    if turb is not None:
        u_b = bnd.velocity(m, s.u, grad_u)
        grad_u_new = ls_gradient(m, s.u, u_b)
        r_t, s.k, s.omega, s.nu_t, s.mu_wall = turbulence_step(
            turb, problem.turbulence_setup, m, problem.pattern, bnd, s.u, grad_u_new, s.flux, s.k, s.omega,
            rho, mu, solver_state)
        check_finite("k", "k or omega", s.k, s.omega)
        res.update(r_t)
        solver_state["grad_u"] = grad_u_new
    return res


def relaxed_correction(grad: np.ndarray, grad_linear: np.ndarray, factor: float, solver_state: dict) -> np.ndarray:
    """``grad_linear + c``, ``c`` the correction ``grad - grad_linear`` under-relaxed by ``factor`` against the
    last iteration's (kept in ``solver_state``); the first iteration takes it whole. At a fixed point ``c`` is
    the correction itself, so the converged solution is ``grad``'s."""
    correction = grad - grad_linear
    last = solver_state.get("green_gauss_correction")
    if last is not None:
        correction = factor * correction + (1.0 - factor) * last
    solver_state["green_gauss_correction"] = correction
    return grad_linear + correction


#: The settings of a :func:`solve_steady` call that gives none.
DEFAULT_SETTINGS = SimpleSettings()


def solve_steady(problem: Problem, settings: SimpleSettings = DEFAULT_SETTINGS, state: FlowState | None = None,
                 callback=None) -> FlowResults:
    """Iterate :func:`outer_iteration` to convergence; never returns NaN fields.

    ``state``: the initial iterate (default :func:`solver.problem.initial_state`, fluid at rest; updated in
    place). ``callback(iteration, residuals, state)`` is called after each iteration (for logging).
    Status ``diverged`` (with the iteration and the variable in ``message``) when a residual or field
    becomes non-finite or a residual exceeds ``divergence_factor`` times its running minimum; the fields
    returned are then the last finite iterate.
    """
    with _blas_threads(settings.blas_threads):
        return _iterate(problem, settings, state, callback)


def _blas_threads(n):
    """Context limiting BLAS threads to ``n`` (no-op without threadpoolctl or with ``n`` None)."""
    if n is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=n, user_api="blas")


def iteration_alpha_u(settings: SimpleSettings, it: int) -> float:
    """The momentum relaxation of iteration ``it`` (from 1). The start-up's ``n = startup_iterations``
    iterations run at ``a0 = min(alpha_u, startup_alpha_u)``, except its last ``r = min(startup_ramp, n)``,
    which rise linearly towards ``alpha_u`` (iteration ``n - r + j`` at ``a0 + (alpha_u - a0) j / (r + 1)``,
    j = 1 … r); ``alpha_u`` after the start-up."""
    n = settings.startup_iterations
    if it > n:
        return settings.alpha_u
    a0 = min(settings.alpha_u, settings.startup_alpha_u)
    r = min(settings.startup_ramp, n)
    j = it - (n - r)
    return a0 if j <= 0 else a0 + (settings.alpha_u - a0) * j / (r + 1)


def _startup_settings(settings: SimpleSettings, current: SimpleSettings, it: int) -> SimpleSettings:
    """``current`` where iteration ``it``'s relaxation (:func:`iteration_alpha_u`, and with SIMPLEC
    ``startup_alpha_p`` when given) is its own, else a new one."""
    n_p = settings.startup_iterations if settings.startup_alpha_p_iterations is None \
        else settings.startup_alpha_p_iterations
    if it > max(settings.startup_iterations, n_p):
        return settings
    alpha_u = iteration_alpha_u(settings, it)
    # SIMPLE keeps its own alpha_p: its small value (0.3 with alpha_u 0.7) is what makes it stable at all
    simplec = settings.algorithm == "simplec" and settings.startup_alpha_p is not None and it <= n_p
    alpha_p = settings.startup_alpha_p if simplec else settings.alpha_p
    if current.alpha_u == alpha_u and current.alpha_p == alpha_p:
        return current
    return dataclasses.replace(settings, alpha_u=alpha_u, alpha_p=alpha_p)


def _iterate(problem: Problem, settings: SimpleSettings, state: FlowState | None, callback) -> FlowResults:
    """The outer loop of :func:`solve_steady`."""
    t0 = time.perf_counter()
    s = initial_state(problem) if state is None else state
    hist = {"u": [], "v": [], "continuity": []}
    if problem.turbulence is not None:
        hist.update(k=[], omega=[])
    monitors = new_monitors(settings.monitor_groups)
    stop_monitor_names(monitors, settings)          # an unknown name fails here, not at the first stop test
    solver_state: dict = {}
    status, message = "not_converged", f"reached max_iter = {settings.max_iter}"
    classification = None
    # the impulsive start's first iterations, gentler (SimpleSettings.startup_iterations), their last
    # startup_ramp rising linearly to alpha_u; a settings object is built only where alpha_u changes
    current = settings
    it = 0
    for it in range(1, settings.max_iter + 1):
        # the iterate to fall back to: outer_iteration replaces the state's arrays and never writes into
        # them, so a shallow snapshot is the last iterate (a deep copy took 0.35 ms, 4 % of a coarse blade
        # iteration; tests/solver/test_turbulence.py checks that the arrays stay untouched)
        last_good = dataclasses.replace(s)
        solver_state["iteration"] = it
        try:
            with np.errstate(all="ignore"):
                current = _startup_settings(settings, current, it)
                res = outer_iteration(problem, s, current, solver_state)
        except (DivergenceError, ValueError, np.linalg.LinAlgError) as exc:
            status, message = "diverged", f"diverged at iteration {it}: {exc}"
            s = last_good
            break
        for k, v in res.items():
            hist[k].append(v)
        bad = divergence(res, hist, s, settings)
        if bad:
            status, message = "diverged", f"diverged at iteration {it}: {bad}"
            s = last_good
            break
        update_monitors(problem, s, monitors, settings)
        if callback is not None:
            callback(it, res, s)
        if not limiter_settled(settings, it):
            continue                    # the start-up solution is not the answer: no stop test yet
        if max(res.values()) < settings.tol and stationary(monitors, settings):
            status, message = "converged", (f"scaled residuals < {settings.tol:g} and monitors stationary "
                                            f"within {settings.monitor_tol:g} over {settings.monitor_window}"
                                            " iterations")
            break
        if settled(res, monitors, it, settings):
            status, message = "converged", (
                f"monitors within {settings.stop_tol:g} of their converged values (two windows of "
                f"{settings.stop_window} iterations, geometric decay extrapolated) and scaled residuals < "
                f"{settings.stall_tol:g} (largest {max(res.values()):.2e})")
            break
        early = established(monitors, it, settings)
        if early is not None:
            status, message, classification = early
            break
    monitor_arrays = {k: np.array(v) for k, v in monitors.items()}
    if status == "not_converged" and classification is None:
        status, message, classification = classify_at_cap(monitor_arrays, hist, settings)
    return FlowResults(problem.mesh, problem.bnd, s.u, s.p, s.flux, {k: np.array(v) for k, v in hist.items()},
                       status, message, it, problem.fluid.rho, problem.fluid.mu,
                       time.perf_counter() - t0, monitor_arrays, classification=classification,
                       **turbulent_fields(problem, s))
