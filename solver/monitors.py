"""Monitors of a steady solve and the tests on them: stationarity, early stop, classification at the cap,
divergence.

Every outer iteration appends C_max (the largest cell speed, m/s) and the forces ``fx:<group>``,
``fy:<group>`` (N/m) on the monitored boundary groups to their histories (:func:`update_monitors`).
:func:`stationary` is the convergence test together with the residuals; :func:`settled` stops a solve
whose residuals stall above ``tol``; :func:`classify_at_cap` gives the status of a solve stopped by
``max_iter`` (:func:`solver.convergence.classify`); :func:`divergence` says which variable blew up.
"""

from __future__ import annotations

import numpy as np

from .convergence import classify
from .problem import FlowState, Problem, turbulent_fields
from .results import FlowResults
from .settings import SimpleSettings


class DivergenceError(ArithmeticError):
    """Raised inside an iteration when a variable's system or field stops being finite."""

    def __init__(self, variable: str, reason: str):
        super().__init__(f"{variable}: {reason}")
        self.variable = variable


def check_finite(variable: str, what: str, *arrays) -> None:
    """Raise :class:`DivergenceError` naming ``variable`` and ``what`` if any array has a non-finite value."""
    for a in arrays:
        if not np.all(np.isfinite(a)):
            raise DivergenceError(variable, f"{what} not finite")


def new_monitors(groups: tuple[str, ...]) -> dict[str, list]:
    """Empty histories: ``c_max`` and ``fx:<g>``, ``fy:<g>`` for each monitored group."""
    monitors: dict[str, list] = {"c_max": []}
    for g in groups:
        monitors[f"fx:{g}"], monitors[f"fy:{g}"] = [], []
    return monitors


def update_monitors(problem: Problem, s: FlowState, monitors: dict, cfg: SimpleSettings) -> None:
    """Append the current C_max and the forces on ``cfg.monitor_groups``."""
    monitors["c_max"].append(float(np.sqrt((s.u**2).sum(axis=1)).max()))
    if cfg.monitor_groups:
        r = FlowResults(problem.mesh, problem.bnd, s.u, s.p, s.flux, {}, "", "", 0, problem.fluid.rho,
                        problem.fluid.mu, **turbulent_fields(problem, s))
        for g in cfg.monitor_groups:
            f = r.forces(g).total
            monitors[f"fx:{g}"].append(float(f[0]))
            monitors[f"fy:{g}"].append(float(f[1]))


def stationary(monitors: dict, cfg: SimpleSettings) -> bool:
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


def settled(res: dict, monitors: dict, it: int, cfg: SimpleSettings) -> bool:
    """Early stop of a solve whose residuals stall above ``tol`` (limiter chatter, a k residual
    floor): every monitor stationary within ``classify_tol`` over ``classify_window`` iterations and
    every scaled residual below ``stall_tol``. Checked every 10 iterations; off when ``stall_tol`` is
    None."""
    if cfg.stall_tol is None or it < cfg.classify_window or it % 10 or max(res.values()) >= cfg.stall_tol:
        return False
    window = {k: np.asarray(v[-cfg.classify_window:]) for k, v in monitors.items()}
    return classify(window, window=cfg.classify_window, tol=cfg.classify_tol).status == "stationary"


def classify_at_cap(monitors: dict, hist: dict, cfg: SimpleSettings):
    """Status, message and :class:`solver.convergence.Classification` of a solve stopped by
    ``max_iter``: ``converged`` when every monitor is stationary within ``classify_tol`` over the last
    ``classify_window`` iterations (the residuals stalled; their last values are in the message),
    ``oscillating`` (bounded: use the window means) or ``not_converged`` (drifting)."""
    cls = classify(monitors, window=cfg.classify_window, tol=cfg.classify_tol)
    last = max(v[-1] for v in hist.values() if len(v)) if any(len(v) for v in hist.values()) else float("nan")
    head = f"reached max_iter = {cfg.max_iter} (largest scaled residual {last:.2e})"
    if cls.status == "stationary":
        return "converged", f"{head}; monitors stationary: {cls.reason}", cls
    return cls.status, f"{head}; {cls.reason}", cls


def divergence(res: dict, hist: dict, s: FlowState, cfg: SimpleSettings) -> str:
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
