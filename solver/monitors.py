"""Monitors of a steady solve and the tests on them: stationarity, early stop, classification at the cap,
divergence.

Every outer iteration appends C_max (the largest cell speed, m/s) and the forces ``fx:<group>``,
``fy:<group>`` (N/m) on the monitored boundary groups to their histories (:func:`update_monitors`).
:func:`stationary` is the convergence test together with the residuals; :func:`settled` stops a solve
whose residuals stall above ``tol``; :func:`established` stops a solve whose oscillation or drift is
established; :func:`classify_at_cap` gives the status of a solve stopped by ``max_iter``
(:func:`solver.convergence.classify`); :func:`divergence` says which variable blew up.
"""

from __future__ import annotations

import numpy as np

from .convergence import ConvergenceClass, classify
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
    # the components summed by hand: numpy's reduction over a length-2 axis takes 15x as long
    monitors["c_max"].append(float(np.sqrt((s.u[:, 0] ** 2 + s.u[:, 1] ** 2).max())))
    if cfg.monitor_groups:
        r = FlowResults(problem.mesh, problem.bnd, s.u, s.p, s.flux, {}, ConvergenceClass.NOT_CONVERGED, "", 0,
                        problem.fluid.rho, problem.fluid.mu, **turbulent_fields(problem, s))
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
    """Early stop of a solve whose monitors are within ``stop_tol`` of their converged values while the
    residuals stall above ``tol`` (limiter chatter, a k residual floor): every scaled residual is below
    ``stall_tol`` and every monitor of :func:`stop_monitor_names` passes :func:`near_fixed_point` over
    windows of ``stop_window`` iterations. Checked every 10 iterations; off when ``stall_tol`` is None."""
    if cfg.stall_tol is None or it < 2 * cfg.stop_window or it % 10 or max(res.values()) >= cfg.stall_tol:
        return False
    return all(near_fixed_point(np.asarray(monitors[name], dtype=float), cfg.stop_window, cfg.stop_tol)
               for name in stop_monitor_names(monitors, cfg))


def stop_monitor_names(monitors: dict, cfg: SimpleSettings) -> tuple[str, ...]:
    """The monitors :func:`settled` waits for: ``cfg.stop_monitors``, or all when it is empty. An unknown
    name is a ValueError that lists the monitors there are."""
    unknown = sorted(set(cfg.stop_monitors) - set(monitors))
    if unknown:
        raise ValueError(f"stop_monitors {unknown} are not monitored; the monitors are {sorted(monitors)}")
    return cfg.stop_monitors or tuple(monitors)


def near_fixed_point(x: np.ndarray, window: int, tol: float) -> bool:
    """Whether the history ``x`` is within ``tol`` (relative) of the value it converges to, judged from its
    last two windows of ``window`` samples:

    * its spread (max - min) over the last window is at most ``tol |x|``; and
    * where the least-squares trend over the last window is larger than the fluctuation about it (the
      classification's drift and amplitude, :func:`solver.convergence.classify`), the trend decays
      geometrically — same sign as in the window before, ratio ``r = |d1 / d0| < 1`` — and the change
      still to come, ``|d1| r / (1 - r)`` (the sum of the geometric series), is at most ``tol |x|``.

    Why: a SIMPLE(C) iterate near its fixed point converges linearly, so the monitors' changes shrink by
    a constant factor per window, and the remaining change is the tail of that series. Measured on the
    benchmark blade at ``medium`` (16 641 cells, SIMPLEC 0.9/1): the window ratio is 0.4-0.5 and the
    extrapolated remaining change of the lift at iteration 400 is 4.6e-4 against 4.0e-4 actual. A
    spread alone (the test before) has to be set ~3x tighter than the accuracy it must guarantee,
    because it says nothing about the change still to come.
    """
    if x.size < 2 * window or not np.all(np.isfinite(x[-2 * window:])):
        return False
    last, before = x[-window:], x[-2 * window:-window]
    scale = max(float(np.abs(last).max()), 1e-300)
    if last.max() - last.min() > tol * scale:
        return False
    d1, amplitude = _trend(last)
    if abs(d1) <= amplitude:
        return True                     # no trend above the fluctuation: nothing left to extrapolate
    d0, _ = _trend(before)
    r = d1 / d0 if d0 != 0 else np.inf
    return 0.0 < r < 1.0 and abs(d1) * r / (1.0 - r) <= tol * scale


def _trend(x: np.ndarray) -> tuple[float, float]:
    """``(change of the least-squares line over the window, sqrt(2) x std about it)`` of ``x``."""
    t = np.arange(x.size, dtype=float) - 0.5 * (x.size - 1)
    slope = float(np.dot(t, x - x.mean()) / np.dot(t, t))
    return slope * x.size, float(np.sqrt(2.0) * (x - x.mean() - slope * t).std())


def established(monitors: dict, it: int, cfg: SimpleSettings):
    """``(status, message, classification)`` of a solve whose monitors will not settle by ``max_iter``, or
    None.

    Two consecutive windows of ``w`` iterations — the last ``w`` and the ``w`` before them — are classified
    (:func:`solver.convergence.classify`) from ``2 w + min(early_skip, w)`` iterations on (the start-up
    skipped: :func:`first_early_check`), checked every 25 iterations. ``w`` is :func:`early_window`:
    ``early_periods`` times the longest period found over the last ``classify_window`` iterations, between
    ``classify_window / 2`` and ``classify_window`` (``classify_window`` when no period is found or
    ``early_periods`` is None). The
    solve stops with the last window's class and figures — what it would get at ``max_iter`` — when both
    windows agree and, in every monitor that is not stationary, the behaviour is established and its
    decay from one window to the next, extrapolated to ``max_iter``, still leaves it above ``classify_tol``:

    * ``oscillating``: periods (where both are found) within 20 %, means apart by less than a quarter of
      the amplitude, amplitude not growing by more than 1.5x, and either the two window means within
      ``classify_tol`` (relative) — the window mean is the figure an oscillating solve is used by, and it
      is final; more iterations could only change the label — or ``2 a (a / a_before)^m`` (``m`` windows
      left; no decay assumed when it grows) above ``classify_tol`` times the mean; but never when
      ``2 a (a / a_before)^2`` is below it (:data:`SETTLE_WINDOWS`): a ripple that decays below the
      tolerance within two windows runs on to ``converged``;
    * ``not_converged`` (drifting): the trend has the same sign in both windows, is not smaller than the
      window before's, and is above ``classify_tol`` times the mean. A drift that slows down runs on: its
      decay is not geometric where a blade climbs out of a stall (table4 at medium slowed by too little at
      first, was stopped at 825 iterations, and converges at 1 870; docs/decisions/0015-early-stop.md);
      none of the blade solves of the robustness sweeps stops early as drifting.

    So a drift that would settle before the cap, or an oscillation whose mean still moves and whose
    amplitude decays, runs on. Measured (random blade 0 of ``bench/bench_robustness.py`` at medium): an
    oscillation of 1e-3 relative amplitude with a settled mean ran to the 2 000-iteration cap under the
    decay test alone (4.4x the iterations of a converged blade); it stopped at 600 with the fixed window.
    The window scaled to the period (docs/decisions/0015-early-stop.md): the
    24 oscillating blades of that sweep stop after 637.5 iterations by the median instead of 725 (1.96x
    the converged median, was 2.23x), every class and every converged blade unchanged, the window means
    of F_Y and C_max within ``max(classify_tol |mean|, amplitude / 2)`` of those at the cap. The margin is
    thin: with windows of 6 or 7 periods, random blade 20 (converged at 1 250, its lift ringing at period 15
    with the amplitude halving every 100 iterations) stops early as oscillating by its settled mean. Off
    when ``early_classify`` is False."""
    w_cap = cfg.classify_window
    if not cfg.early_classify or it % 25 or it < first_early_check(min_early_window(cfg), cfg):
        return None
    arrays = {k: np.asarray(v) for k, v in monitors.items()}
    w = early_window(arrays, cfg)
    if it < first_early_check(w, cfg):
        return None
    now = classify(arrays, window=w, tol=cfg.classify_tol)
    if now.status not in (ConvergenceClass.OSCILLATING, ConvergenceClass.NOT_CONVERGED):
        return None
    before = classify({k: v[:-w] for k, v in arrays.items()}, window=w, tol=cfg.classify_tol)
    windows_left = max(cfg.max_iter - it, 0) / w
    for name, verdict in now.monitor_status.items():
        if verdict == ConvergenceClass.STATIONARY:
            continue
        if before.monitor_status[name] != verdict or not _persists(now, before, name, verdict, windows_left,
                                                                   cfg.classify_tol):
            return None
    head = f"stopped at iteration {it}: {now.status} established over {2 * w} iterations"
    if w != w_cap:
        head += f" (two windows of {w}: {cfg.early_periods:g} periods)"
    return now.status, f"{head}; {now.reason}", now


#: An oscillation whose spread, decaying at the rate of its last two windows, falls below ``classify_tol``
#: within this many more windows is not stopped as ``oscillating``: it is a ripple on the way to
#: ``converged``. Measured (docs/decisions/0015-early-stop.md): table5 under the Green-Gauss SST gradient, its ripple
#: at 7e-4 of
#: the means and 3.4x smaller per window, was stopped as oscillating at 575 and converges at 600; on three
#: sweeps of 50 medium blades to the cap the only other change is random blade 15
#: (converged at 1 030, stopped at 575 by its settled mean); every other stop is unchanged.
SETTLE_WINDOWS = 2


def first_early_check(w: int, cfg: SimpleSettings) -> int:
    """The first iteration at which windows of ``w`` may stop a solve: two windows after the start-up,
    ``min(early_skip, w)`` iterations (a whole window when ``early_skip`` is None)."""
    return 2 * w + (w if cfg.early_skip is None else min(cfg.early_skip, w))


def min_early_window(cfg: SimpleSettings) -> int:
    """The shortest window :func:`early_window` can give: ``classify_window / 2`` when the window follows
    the period (``early_periods`` set), else ``classify_window``."""
    return cfg.classify_window if cfg.early_periods is None else max(cfg.classify_window // 2, 2)


def early_window(arrays: dict, cfg: SimpleSettings) -> int:
    """The window (iterations) of :func:`established`: ``early_periods`` times the longest period of the
    monitors over the last ``classify_window`` iterations, rounded down and clamped to
    ``[classify_window / 2, classify_window]``; ``classify_window`` when no monitor has a period (noise, a
    drift) or ``early_periods`` is None. The longest period, so that every monitor's window holds at least
    ``early_periods`` of its cycles; eight cycles give a period within 20 % and a whole-period mean."""
    w = cfg.classify_window
    if cfg.early_periods is None:
        return w
    probe = classify(arrays, window=w, tol=cfg.classify_tol)
    periods = [p for p in probe.period.values() if p is not None]
    if not periods:
        return w
    return int(min(max(cfg.early_periods * max(periods), min_early_window(cfg)), w))


def _persists(now, before, name: str, verdict: str, windows_left: float, tol: float) -> bool:
    """Whether monitor ``name`` keeps its verdict up to ``max_iter`` (see :func:`established`)."""
    limit = tol * max(abs(now.mean[name]), 1e-300)
    if verdict == ConvergenceClass.OSCILLATING:
        a1, a0 = now.amplitude[name], before.amplitude[name]
        if not (a0 > 0 and a1 > 0 and a1 <= 1.5 * a0):
            return False
        if abs(now.mean[name] - before.mean[name]) > 0.25 * a1:
            return False
        p1, p0 = now.period[name], before.period[name]
        if p1 is not None and p0 is not None and abs(p1 - p0) > 0.2 * p0:
            return False
        decay = min(a1 / a0, 1.0)
        if 2.0 * a1 * decay ** min(SETTLE_WINDOWS, windows_left) <= limit:
            return False                # a ripple about to fall below tol: let the solve converge
        if abs(now.mean[name] - before.mean[name]) <= limit:
            return True                 # its window mean, the figure used, is already final within tol
        return 2.0 * a1 * decay ** windows_left > limit
    d1, d0 = now.drift[name], before.drift[name]
    # a drift that slows down runs on: table4 climbing out of its leading-edge stall slowed by less than the
    # geometric rate at first, was stopped as drifting at 825 iterations, and converges at 1 870
    return d1 * d0 > 0 and abs(d1) >= abs(d0) and abs(d1) > limit


def classify_at_cap(monitors: dict, hist: dict, cfg: SimpleSettings):
    """Status, message and :class:`solver.convergence.Classification` of a solve stopped by
    ``max_iter``: ``converged`` when every monitor is stationary within ``classify_tol`` over the last
    ``classify_window`` iterations (the residuals stalled; their last values are in the message),
    ``oscillating`` (bounded: use the window means) or ``not_converged`` (drifting)."""
    cls = classify(monitors, window=cfg.classify_window, tol=cfg.classify_tol)
    last = max(v[-1] for v in hist.values() if len(v)) if any(len(v) for v in hist.values()) else float("nan")
    head = f"reached max_iter = {cfg.max_iter} (largest scaled residual {last:.2e})"
    if cls.status == ConvergenceClass.STATIONARY:
        return ConvergenceClass.CONVERGED, f"{head}; monitors stationary: {cls.reason}", cls
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
