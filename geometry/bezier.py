"""Planar Bezier curves of any degree, evaluated on arrays of parameters.

A Bezier curve of degree m with control points Q_0..Q_m is

    Q(u) = sum_i B_{i,m}(u) Q_i,   u in [0, 1],

with the Bernstein polynomials B_{i,m} (Vessaz et al. 2013, Eq. 1 and 8). Evaluation and derivatives are
delegated to :class:`scipy.interpolate.BPoly`, which stores polynomials in exactly this basis.

Conventions: points are rows, ``(n, 2)`` arrays in metres; parameters are 1-D arrays in [0, 1]. The signed
curvature is positive where the curve turns left (counter-clockwise) and is in 1/m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import BPoly

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BezierCurve:
    """A planar Bezier curve defined by its control points.

    Parameters
    ----------
    control_points:
        ``(m + 1, 2)`` array of control points in metres; the degree is ``m``.

    Examples
    --------
    >>> c = BezierCurve([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    >>> c.points([0.5]).tolist()
    [[1.0, 0.5]]
    """

    control_points: Array
    _poly: BPoly = field(init=False, repr=False, compare=False)
    # derivative polynomials by order, built on first use: the curvature checks of a campaign's screening
    # evaluate them thousands of times per curve
    _derivatives: dict[int, BPoly] = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self) -> None:
        cp = np.array(self.control_points, dtype=float)
        if cp.ndim != 2 or cp.shape[1] != 2 or cp.shape[0] < 2:
            raise ValueError(f"control points must be an (m+1, 2) array with m >= 1, got shape {cp.shape}")
        cp.setflags(write=False)
        object.__setattr__(self, "control_points", cp)
        object.__setattr__(self, "_poly", BPoly(cp[:, None, :], [0.0, 1.0]))

    @property
    def degree(self) -> int:
        return self.control_points.shape[0] - 1

    @property
    def start(self) -> Array:
        return self.control_points[0]

    @property
    def end(self) -> Array:
        return self.control_points[-1]

    def points(self, u: ArrayLike) -> Array:
        """Points Q(u), shape ``(len(u), 2)``, metres."""
        return self._poly(np.atleast_1d(np.asarray(u, dtype=float)))

    def derivative(self, u: ArrayLike, order: int = 1) -> Array:
        """d^order Q / du^order at ``u``, shape ``(len(u), 2)``, metres (per unit parameter^order)."""
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if order > self.degree:
            return np.zeros((u.size, 2))
        if order not in self._derivatives:
            self._derivatives[order] = self._poly.derivative(order)
        return self._derivatives[order](u)

    def curvature(self, u: ArrayLike) -> Array:
        """Signed curvature (1/m), positive for a left (counter-clockwise) turn."""
        d1 = self.derivative(u, 1)
        d2 = self.derivative(u, 2)
        return cross(d1, d2) / np.linalg.norm(d1, axis=1) ** 3

    def unit_tangent(self, u: ArrayLike) -> Array:
        """Unit tangent in the direction of increasing ``u``.

        Where the first derivative vanishes (coincident control points at an end) the direction of the
        first non-vanishing derivative is used, which is the geometric tangent of the curve there.
        """
        u = np.atleast_1d(np.asarray(u, dtype=float))
        tangent = self.derivative(u, 1)
        scale = np.abs(self.control_points).max() + 1.0
        for order in range(2, self.degree + 1):
            speed = np.linalg.norm(tangent, axis=1)
            degenerate = speed <= 1e-14 * scale
            if not degenerate.any():
                break
            # Near u = 1 the next derivative points backwards along the curve, so its sign is flipped.
            sign = np.where(u[degenerate] > 0.5, (-1.0) ** (order - 1), 1.0)[:, None]
            tangent[degenerate] = sign * self.derivative(u[degenerate], order)
        return tangent / np.linalg.norm(tangent, axis=1)[:, None]

    def reversed(self) -> BezierCurve:
        """The same curve traversed from end to start."""
        return BezierCurve(self.control_points[::-1])


def cross(a: Array, b: Array) -> Array:
    """z-component of the cross product of rows of two ``(n, 2)`` arrays."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rotate_left(v: Array) -> Array:
    """Rotate vectors (rows) by +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def rotate_right(v: Array) -> Array:
    """Rotate vectors (rows) by -90 degrees."""
    return np.stack([v[..., 1], -v[..., 0]], axis=-1)
