"""Parameter sampling that spreads points by a density, so polylines meet a chord-error tolerance.

A curve sampled so that the number of points per unit parameter follows a density ``ρ(u)`` puts about
``∫ρ du`` points on it; choosing ``ρ = |Q'| sqrt(|κ| / (8 ε))`` makes every chord's sagitta (≈ h²κ/8 for a
chord of length h) at most ``ε``: the classical equidistribution of the interpolation error.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_trapezoid

from geometry.bezier import Array, BezierCurve

DENSE = 1025  # dense samples per piece used to integrate the density; smooth Bezier pieces need no more


def equidistribute(u_dense: Array, density: Array, minimum_intervals: int = 1) -> Array:
    """Parameters that split ``∫density du`` into equal parts of at most one; ends included."""
    cumulative = cumulative_trapezoid(density, u_dense, initial=0.0)
    n = max(minimum_intervals, int(np.ceil(cumulative[-1] - 1e-9)))
    return np.interp(np.linspace(0.0, cumulative[-1], n + 1), cumulative, u_dense)


def chord_density(curve: BezierCurve, u: Array, tolerance: float, max_spacing: float,
                  offset: float = 0.0) -> Array:
    """Points per unit parameter for the curve offset by ``offset`` to its left.

    The offset curve Q + offset·ν (ν the left unit normal) has speed |Q'| |1 − offset κ| and curvature
    κ / (1 − offset κ); the density bounds its chord sagitta by ``tolerance`` and its point spacing (and
    that of Q itself) by ``max_spacing``. ``offset = 0`` samples the curve itself.
    """
    speed = np.linalg.norm(curve.derivative(u, 1), axis=1)
    kappa = curve.curvature(u)
    stretch = np.abs(1.0 - offset * kappa)
    sagitta = speed * np.sqrt(np.abs(kappa) * stretch / (8.0 * tolerance))
    spacing = speed * np.maximum(1.0, stretch) / max_spacing
    return np.maximum(sagitta, spacing)


def sample_curve(curve: BezierCurve, tolerance: float, max_spacing: float) -> Array:
    """Parameters of a polyline that follows ``curve`` within ``tolerance`` (m); ends included."""
    u = np.linspace(0.0, 1.0, DENSE)
    return equidistribute(u, chord_density(curve, u, tolerance, max_spacing))
