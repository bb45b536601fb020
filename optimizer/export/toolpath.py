"""The tool path of a tool-path blade as the machine receives it: curves in millimetres, in cutting order.

The optimiser's cutter-centre path (:func:`geometry.tool_path_pieces`) is closed and counter-clockwise:
the pressure side from P4 to P0 and the suction side from S0 to S4 (degree-4 Bezier curves, Eq. 14–16 of
Vessaz et al. 2013), then the trailing-edge pass — lead-out, cross, lead-in — as three straight lines back
to P4. Every exporter writes exactly these curves; only the notation changes (power form for a Sinumerik
``POLY`` block, control points for a LinuxCNC NURBS block or a DXF ``SPLINE``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry import BezierCurve, BladeSpec, Mode, blade_curves, tool_path_pieces
from geometry.bezier import Array
from geometry.camber import camber_frame

#: Millimetres per metre: the geometry works in metres, NC programs and CAD files in millimetres.
MM = 1000.0


class ExportError(ValueError):
    """A design that cannot be exported (design mode, failed, infeasible, unknown); the message says why."""


@dataclass(frozen=True)
class ToolPath:
    """The closed cutter-centre path of one blade, millimetres.

    pieces: the five curves in cutting order (pressure side P4→P0, suction side S0→S4, lead-out, cross,
    lead-in), each a :class:`geometry.BezierCurve` of control points in mm (degree 4 for the sides,
    degree 1 for the trailing-edge pass). radius: cutter radius R, mm. spec: the blade.
    exit_normal: unit vector pointing away from the blade at P4 (−n(1), the camber normal towards the
    pressure side), the direction of a retract; lead: unit vector t(1), downstream along the camber line
    at the trailing edge, the direction the lead-in arrives from.
    """

    pieces: tuple[BezierCurve, ...]
    radius: float
    spec: BladeSpec
    exit_normal: Array
    lead: Array

    @property
    def start(self) -> Array:
        """P4, mm: where the cut starts and ends."""
        return self.pieces[0].start

    @property
    def curves(self) -> tuple[BezierCurve, ...]:
        """The two degree-4 sides (the curves the NC blocks carry exactly)."""
        return tuple(p for p in self.pieces if p.degree > 1)


def tool_path_of(spec: BladeSpec) -> ToolPath:
    """The tool path of a tool-path blade, in mm (raises :class:`ExportError` for a design-mode blade)."""
    if spec.mode is not Mode.TOOLPATH:
        raise ExportError("a design-mode blade has no tool path: its curves are the blade surface, which a "
                          "cutter of finite radius cannot follow; export a tool-path (blade.mode: toolpath) "
                          "design")
    curves = blade_curves(spec)
    pieces = tuple(BezierCurve(p.control_points * MM) for p in tool_path_pieces(curves))
    _, (t2,), (n2,) = camber_frame(curves.camber, [1.0])     # n points to the suction side
    return ToolPath(pieces, spec["R"] * MM, spec, exit_normal=-n2, lead=t2)


def power_form(curve: BezierCurve) -> Array:
    """Coefficients ``a_0 .. a_m`` (rows) of C(p) = Σ a_k p^k, p ∈ [0, 1], for a Bezier curve of degree m.

    a_k = C(m, k) Σ_{i≤k} (−1)^{k−i} C(k, i) b_i (the Bernstein-to-monomial change of basis); for m = 4
    these are the formulas a0 = b0, a1 = 4(b1 − b0), a2 = 6(b0 − 2b1 + b2), a3 = 4(−b0 + 3b1 − 3b2 + b3),
    a4 = b0 − 4b1 + 6b2 − 4b3 + b4. Shape ``(m + 1, 2)``, units of the control points.
    """
    from math import comb

    b = curve.control_points
    m = curve.degree
    return np.array([comb(m, k) * sum((-1) ** (k - i) * comb(k, i) * b[i] for i in range(k + 1))
                     for k in range(m + 1)])
