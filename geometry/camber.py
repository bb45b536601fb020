"""Camber line of the blade: a quadratic Bezier curve (Vessaz et al. 2013, Eq. 1, Fig. 1).

Conventions (used by every module of :mod:`geometry`):

* x points downstream along the undisturbed flow, y to its left; angles are measured from +x,
  counter-clockwise positive, in radians inside the code (degrees in configuration files).
* CL0 is the origin (leading edge), CL2 = L (cos α, sin α) (trailing edge), so α is the chord angle.
* CL1 is the intersection of the inlet line through CL0 at angle β1 with the outlet line through CL2 at
  angle β̄1. It exists and lies between the two for β1 ≤ α ≤ β̄1 (Eq. 21); then the camber line turns
  counter-clockwise by β̄1 − β1.
* The unit tangent t(u) points downstream (increasing u). The unit normal n(u) is t rotated by −90°: it
  points to the convex side of the camber line, which is the suction side (turbomachinery convention).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from geometry.bezier import Array, BezierCurve, rotate_right


class CamberError(ValueError):
    """The camber line cannot be constructed from the given angles."""


def camber_line(chord: float, alpha: float, beta1: float, beta1bar: float) -> BezierCurve:
    """Quadratic Bezier camber line from chord length and angles.

    Parameters
    ----------
    chord: chord length L in metres.
    alpha, beta1, beta1bar: chord, inlet and outlet angles in radians.

    Returns
    -------
    BezierCurve with control points CL0 = (0, 0), CL1, CL2 = L (cos α, sin α).

    Raises
    ------
    CamberError if the inlet and outlet lines are parallel but not along the chord (no CL1 exists).

    Examples
    --------
    >>> import numpy as np
    >>> c = camber_line(0.1, np.radians(30), 0.0, np.radians(60))
    >>> np.round(c.control_points, 6).tolist()
    [[0.0, 0.0], [0.057735, 0.0], [0.086603, 0.05]]
    """
    cl0 = np.zeros(2)
    cl2 = chord * np.array([np.cos(alpha), np.sin(alpha)])
    turning = np.sin(beta1bar - beta1)
    if abs(turning) < 1e-12:
        if abs(np.sin(alpha - beta1)) > 1e-12:
            raise CamberError(
                f"inlet angle {np.degrees(beta1):.4g}° and outlet angle {np.degrees(beta1bar):.4g}° are "
                f"parallel but the chord angle is {np.degrees(alpha):.4g}°: the camber lines do not intersect"
            )
        cl1 = 0.5 * (cl0 + cl2)  # straight camber line, uniformly parameterised
    else:
        # Sine rule in the triangle CL0-CL1-CL2: distance from CL0 to CL1 along the inlet direction.
        a = chord * np.sin(beta1bar - alpha) / turning
        cl1 = a * np.array([np.cos(beta1), np.sin(beta1)])
    return BezierCurve(np.array([cl0, cl1, cl2]))


def camber_frame(camber: BezierCurve, u: ArrayLike) -> tuple[Array, Array, Array]:
    """Points, unit tangents t (downstream) and unit normals n (suction side) of the camber line at ``u``."""
    tangent = camber.unit_tangent(u)
    return camber.points(u), tangent, rotate_right(tangent)
