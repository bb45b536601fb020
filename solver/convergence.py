"""Convergence classification of a steady solve from its monitor histories (pure numpy).

A steady RANS solve around a blade does not always settle: the iterate may reach a fixed point
(``converged``, decided by the solver from its residuals and monitors), blow up (``diverged``, also
decided by the solver), or stop at the iteration cap while its integral quantities still move. In that
last case :func:`classify` looks at the last ``window`` iterations of every monitor (``"c_max"``,
``"fx:blade"``, ``"fy:blade"``, ...; one value per outer iteration) and says which of these it is:

``stationary``
    every monitor varies by at most ``tol`` (relative) over the window — the integral quantities have
    settled although the residuals did not reach their tolerance; the last values can be used.
``oscillating``
    bounded: no significant linear trend, but the monitor fluctuates by more than ``tol`` — a periodic
    limit cycle (vortex shedding, a SIMPLE iteration cycle) or noise; the window **mean** is the value
    to use, the amplitude says how uncertain it is.
``not_converged``
    drifting: the least-squares linear trend over the window changes the monitor by more than ``tol``
    (relative) *and* by more than ``drift_factor`` (default 2) times the fluctuation amplitude about the
    trend; more iterations are needed (or the run is slowly diverging).

The overall status is the worst over the monitors (``not_converged`` > ``oscillating`` >
``stationary``); the solver's own ``converged`` / ``diverged`` verdicts take precedence.

Figures, per monitor, over the last ``w = min(window, iterations)`` finite values ``x``:

* ``drift``: slope of the least-squares line × ``w`` (the change the trend makes over the window), in
  the monitor's unit;
* ``amplitude``: ``√2 × standard deviation of x about that line``. For a sine this is its amplitude
  (half the peak-to-peak range); unlike the half peak-to-peak range it does not follow a single spike;
  for white noise of standard deviation σ it is √2 σ;
* ``period``: dominant period in iterations, from the peak of the periodogram of the detrended,
  Hann-windowed signal (zero-padded 16×, peak refined by a parabola through the log-magnitudes), or
  ``None`` when no peak holds at least ``min_peak_fraction`` (0.3) of the fluctuation power (noise)
  or the fluctuation is below ``tol`` (nothing to measure);
* ``mean``: mean of x over the last whole number of periods when a period was found (removes the bias
  of a partial cycle), else over the window.

No figure is ever NaN or infinite: non-finite samples are dropped, and a monitor with fewer than two
finite values gets ``None`` figures.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np


class ConvergenceClass(enum.StrEnum):
    """The convergence class of a steady solve, best first (see the module docstring).

    Members equal their strings (``ConvergenceClass.CONVERGED == "converged"``), so stores, JSON and
    comparisons with plain strings keep working. ``converged`` and ``diverged`` are the solver's own
    verdicts; ``stationary``, ``oscillating`` and ``not_converged`` come from :func:`classify`.
    """

    CONVERGED = "converged"
    STATIONARY = "stationary"
    OSCILLATING = "oscillating"
    NOT_CONVERGED = "not_converged"
    DIVERGED = "diverged"

    @property
    def rank(self) -> int:
        """Position in the order best first (0 for ``converged``)."""
        return _RANK[self]

    @property
    def solved(self) -> bool:
        """The solve ran to an iterate whose figures can be read (every class but ``diverged``)."""
        return self is not ConvergenceClass.DIVERGED

    @classmethod
    def worst(cls, classes: Iterable[str]) -> ConvergenceClass:
        """The worst of ``classes`` (members or their strings); ValueError for an empty or unknown one."""
        found = [cls(c) for c in classes]
        if not found:
            raise ValueError("the worst of no convergence classes is undefined")
        return max(found, key=_RANK.__getitem__)


_RANK = {c: i for i, c in enumerate(ConvergenceClass)}
#: Fewer iterations than this cannot be classified (status ``not_converged``).
MIN_SAMPLES = 8


@dataclass(frozen=True)
class Classification:
    """Verdict on a steady solve and its per-monitor figures over the last ``window`` iterations.

    status: a :class:`ConvergenceClass`. mean, amplitude, drift: ``{monitor: value or None}`` in the
    monitor's unit (see the module docstring for the definitions). period: ``{monitor: iterations or
    None}``. window: number of iterations actually used. reason: one line saying why.
    monitor_status: ``{monitor: ConvergenceClass}`` (``stationary``, ``oscillating`` or ``not_converged``).
    """

    status: ConvergenceClass
    mean: dict
    amplitude: dict
    period: dict
    drift: dict
    window: int
    reason: str
    monitor_status: dict

    @property
    def dominant_period(self) -> float | None:
        """Median of the monitors' periods (iterations), None if none has one."""
        found = [p for p in self.period.values() if p is not None]
        return float(np.median(found)) if found else None

    def to_dict(self) -> dict:
        """JSON-ready copy (plain floats, None for undefined figures)."""
        return {"status": str(self.status), "reason": self.reason, "window": self.window,
                "dominant_period": self.dominant_period,
                "monitor_status": {k: str(v) for k, v in self.monitor_status.items()},
                "mean": dict(self.mean), "amplitude": dict(self.amplitude), "period": dict(self.period),
                "drift": dict(self.drift)}


@dataclass(frozen=True)
class _Figures:
    mean: float
    amplitude: float
    drift: float
    period: float | None
    scale: float
    spread: float          # max - min over the window


def classify(monitors: Mapping[str, np.ndarray], *, window: int = 200, tol: float = 1e-3,
             converged: bool = False, diverged: bool = False, drift_factor: float = 2.0,
             min_peak_fraction: float = 0.3) -> Classification:
    """Classify a solve from ``monitors`` (``{name: (iterations,) values}``), see the module docstring.

    window: number of last iterations examined. tol: relative tolerance on the monitors (the spread
        ``max - min`` and the drift are compared with ``tol × max(|mean|, 1e-3 max |history|)``).
    converged / diverged: the solver's verdict (``FlowResults.status``); they set the status, and the
        figures are still computed.

    >>> it = np.arange(400)
    >>> c = classify({"fy": 5 + 0.2 * np.sin(2 * np.pi * it / 25)}, window=200, tol=1e-3)
    >>> c.status, round(c.period["fy"], 1), round(c.amplitude["fy"], 2), round(c.mean["fy"], 4)
    ('oscillating', 25.0, 0.2, 5.0)
    """
    if window < 2:
        raise ValueError(f"window must be at least 2, got {window}")
    if not tol >= 0:
        raise ValueError(f"tol must be non-negative, got {tol}")
    mean, amplitude, period, drift, verdicts = {}, {}, {}, {}, {}
    used, shortest, why = 0, None, {}
    for name, values in monitors.items():
        x = np.asarray(values, dtype=float).ravel()
        x_all = x[np.isfinite(x)]
        x = x_all[-window:]
        used = max(used, x.size)
        shortest = x.size if shortest is None else min(shortest, x.size)
        if x.size < 2:
            mean[name] = amplitude[name] = drift[name] = period[name] = None
            verdicts[name], why[name] = ConvergenceClass.NOT_CONVERGED, f"{x.size} finite values"
            continue
        f = _figures(x, float(np.abs(x_all).max()), tol, min_peak_fraction)
        mean[name], amplitude[name], drift[name], period[name] = f.mean, f.amplitude, f.drift, f.period
        verdicts[name], why[name] = _verdict(f, tol, drift_factor)

    if diverged:
        status, reason = ConvergenceClass.DIVERGED, "the solver reported divergence"
    elif converged:
        status, reason = ConvergenceClass.CONVERGED, "the solver reported convergence"
    elif not monitors:
        status, reason = ConvergenceClass.NOT_CONVERGED, "no monitors to classify"
    elif shortest is not None and shortest < MIN_SAMPLES:
        status = ConvergenceClass.NOT_CONVERGED
        reason = f"only {shortest} finite monitor values (at least {MIN_SAMPLES} needed to classify)"
    else:
        status = ConvergenceClass.worst(verdicts.values())
        worst = [n for n, v in verdicts.items() if v == status]
        reason = "; ".join(f"{n}: {why[n]}" for n in worst)
    return Classification(status, mean, amplitude, period, drift, used, reason, verdicts)


def _figures(x: np.ndarray, history_max: float, tol: float, min_peak_fraction: float) -> _Figures:
    w = x.size
    t = np.arange(w, dtype=float) - 0.5 * (w - 1)
    slope = float(np.dot(t, x - x.mean()) / np.dot(t, t))
    resid = x - x.mean() - slope * t
    amplitude = float(np.sqrt(2.0) * resid.std())
    spread = float(x.max() - x.min())
    scale = max(abs(float(x.mean())), 1e-3 * history_max, np.finfo(float).tiny)
    period = None
    if spread > tol * scale and amplitude > 0.0:
        period = _dominant_period(resid, min_peak_fraction)
    if period is not None and period <= w:
        n = int(np.floor(w / period) * period + 0.5)   # samples in the last whole number of periods
        mean = float(x[-max(n, 1):].mean())
    else:
        mean = float(x.mean())
    return _Figures(mean, amplitude, slope * w, period, scale, spread)


def _verdict(f: _Figures, tol: float, drift_factor: float) -> tuple[ConvergenceClass, str]:
    rel_drift, rel_spread = abs(f.drift) / f.scale, f.spread / f.scale
    if abs(f.drift) > tol * f.scale and abs(f.drift) > drift_factor * f.amplitude:
        return ConvergenceClass.NOT_CONVERGED, (
            f"drifting: trend {f.drift:+.4g} over the window ({rel_drift:.2e} relative, "
            f"> tol {tol:g} and > {drift_factor:g} x amplitude {f.amplitude:.3g})")
    if f.spread <= tol * f.scale:
        return ConvergenceClass.STATIONARY, f"spread {rel_spread:.2e} relative <= tol {tol:g}"
    kind = f"periodic, period {f.period:.1f} iterations" if f.period is not None else "noisy (no dominant period)"
    return ConvergenceClass.OSCILLATING, (f"{kind}: mean {f.mean:.6g}, amplitude {f.amplitude:.3g} "
                           f"({f.amplitude / f.scale:.2e} relative), no significant trend")


def _dominant_period(resid: np.ndarray, min_peak_fraction: float) -> float | None:
    """Period (samples) of the strongest periodogram peak of ``resid`` (mean and trend removed), or None
    if that peak holds less than ``min_peak_fraction`` of the power or lies at the lowest frequencies."""
    w = resid.size
    if w < 4:
        return None
    pad = 16
    spec = np.abs(np.fft.rfft(resid * np.hanning(w), n=pad * w)) ** 2
    spec[0] = 0.0
    total = spec.sum()
    if not total > 0.0:
        return None
    k = int(np.argmax(spec))
    # Power in the main lobe (Hann: ±2 raw bins = ±2·pad padded bins) against all power.
    lobe = spec[max(k - 2 * pad, 1): k + 2 * pad + 1].sum()
    if lobe < min_peak_fraction * total:
        return None
    if 0 < k < spec.size - 1:
        a, b, c = np.log(spec[k - 1: k + 2] + 1e-300)
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den < 0 else 0.0
    else:
        shift = 0.0
    freq = (k + shift) / (pad * w)            # cycles per iteration
    if not freq > 1.5 / w:                    # fewer than ~1.5 cycles in the window: a trend, not a period
        return None
    period = 1.0 / freq
    return float(period) if np.isfinite(period) else None
