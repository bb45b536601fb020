"""Suction and pressure curves of a blade (Vessaz et al. 2013, Eq. 2–16, Table 3).

Both sides are degree-4 Bezier curves running from the leading edge (index 0) to the trailing edge
(index 4). With the camber line CL(u), unit tangent t (downstream) and unit normal n (suction side) of
:mod:`geometry.camber`:

* Design mode (Eq. 2–7): S0 = P0 = CL0; S_i = CL(u_si) + d_si n(u_si) and P_i = CL(u_pi) − d_pi n(u_pi)
  for i = 1, 2 (u_s1 = u_p1 = 0 from G1 on); S4 = CL2 + d_s4 n(1), P4 = CL2 − d_p4 n(1); S3 and P3 lie
  d_s3 and d_p3 upstream of S4 and P4 along t(1), so both sides leave the blade at the outlet angle.
* Tool-path mode (Eq. 14–16): the curves are the path of the cutter centre. S0 = P0 = CL0 − R t(0): the
  tangent t of Eq. 14 points upstream, so the cutter at S0 touches CL0 and the machined leading edge
  passes through CL0. S4 = CL2 + (R + d_s4) n(1) and P4 = CL2 − (R + d_p4) n(1), so the machined
  trailing-edge half-thicknesses are d_s4 and d_p4, as in design mode. The leading-edge legs S0S1 and
  P0P1 of the control polygons are those of Eq. 2–3 translated with S0 by −R t(0); from G1 on the path
  is then normal to the camber line at S0, which is what puts the machined leading edge at CL0.

Leading-edge continuity, with the suction side as the anchor (Table 3). The joined curve J runs along
the pressure side reversed, then the suction side: J(τ) = P(−τ) for τ ≤ 0 and S(τ) for τ ≥ 0, so
J'(0⁻) = −P'(0), J''(0⁻) = P''(0), and for degree 4, P'(0) = 4(P1 − P0), P''(0) = 12(P0 − 2P1 + P2).

* G0: the sides only share S0 = P0.
* G1: J'(0⁻) = k1 J'(0⁺) with k1 = d_p1/d_s1 > 0 (Eq. 10–11): P1 = S0 + k1 (S0 − S1).
* C1: G1 with k1 = 1 (d_p1 = d_s1).
* G2: G1 plus equal curvature. With S''(0) = a T + b N in the unit tangent/normal of S at S0, the
  curvature of J at 0⁻ equals that at 0⁺ if and only if the N-component of P''(0) is k1² b; its
  T-component is free, and millfoil sets it to k2 a:  P''(0) = k2 a T + k1² b N. Eq. 13 of the paper
  (P''(0) = k2 S''(0)) is curvature-continuous only for k2 = k1², and as printed its coefficients do not
  even sum to one; this form keeps the paper's k2 as a ratio of second derivatives and contains C2.
* C2: G2 with k1 = k2 = 1, i.e. P1 = 2 S0 − S1 and P2 = 4 S0 − 4 S1 + S2 (J' and J'' continuous). The
  paper's Eq. 13 at k1 = k2 = 1 gives 5 S0 − 3 S1 + S2, which is not C2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.bezier import Array, BezierCurve, rotate_left
from geometry.camber import camber_frame, camber_line
from geometry.parameters import BladeSpec, Continuity, Mode


@dataclass(frozen=True)
class BladeCurves:
    """Camber line and the two side curves of a blade, each running from leading to trailing edge.

    In tool-path mode ``suction`` and ``pressure`` are the cutter-centre path and ``radius`` is R (m);
    in design mode they are the blade surface and ``radius`` is 0.
    """

    spec: BladeSpec
    camber: BezierCurve
    suction: BezierCurve
    pressure: BezierCurve

    @property
    def mode(self) -> Mode:
        return self.spec.mode

    @property
    def radius(self) -> float:
        return self.spec["R"] if self.spec.mode is Mode.TOOLPATH else 0.0


def blade_curves(spec: BladeSpec) -> BladeCurves:
    """Build camber line, suction and pressure curves of ``spec`` (raises CamberError if no CL1)."""
    camber = camber_line(spec["L"], spec.radians("alpha"), spec.radians("beta1"), spec.radians("beta1bar"))
    (cl0, cl2), (t0, t2), (n0, n2) = camber_frame(camber, [0.0, 1.0])
    radius = spec["R"] if spec.mode is Mode.TOOLPATH else 0.0
    le_shift = -radius * t0  # Eq. 14 with t pointing upstream

    def offset_point(u: float, d: float, side: float, shifted: bool) -> Array:
        (point,), _, (normal,) = camber_frame(camber, [u])
        return point + side * d * normal + (le_shift if shifted else 0.0)

    s0 = cl0 + le_shift
    s1 = offset_point(spec.get("u_s1", 0.0), spec["d_s1"], +1.0, True)
    s2 = offset_point(spec["u_s2"], spec["d_s2"], +1.0, False)
    s4 = cl2 + (radius + spec["d_s4"]) * n2
    s3 = s4 - spec["d_s3"] * t2
    p4 = cl2 - (radius + spec["d_p4"]) * n2
    p3 = p4 - spec["d_p3"] * t2

    if spec.continuity is Continuity.G0:
        k1 = float("nan")  # no tangent relation between the sides
        p1 = offset_point(spec["u_p1"], spec["d_p1"], -1.0, True)
    else:
        k1 = 1.0 if spec.continuity in (Continuity.C1, Continuity.C2) else spec["d_p1"] / spec["d_s1"]
        p1 = g1_pressure_point(s0, s1, k1)
    if spec.continuity in (Continuity.G2, Continuity.C2):
        k2 = spec["k2"] if spec.continuity is Continuity.G2 else 1.0
        p2 = g2_pressure_point(s0, s1, s2, k1, k2)
    else:
        p2 = offset_point(spec["u_p2"], spec["d_p2"], -1.0, False)

    suction = BezierCurve(np.array([s0, s1, s2, s3, s4]))
    pressure = BezierCurve(np.array([s0, p1, p2, p3, p4]))
    return BladeCurves(spec, camber, suction, pressure)


def g1_pressure_point(s0: Array, s1: Array, k1: float) -> Array:
    """P1 such that the pressure side leaves S0 opposite to the suction side, k1 times as fast (Eq. 10)."""
    return s0 + k1 * (s0 - s1)


def g2_pressure_point(s0: Array, s1: Array, s2: Array, k1: float, k2: float, degree: int = 4) -> Array:
    """P2 for curvature continuity at S0 (see the module docstring): P''(0) = k2 a T + k1² b N."""
    p1 = g1_pressure_point(s0, s1, k1)
    tangent = (s1 - s0) / np.linalg.norm(s1 - s0)
    normal = rotate_left(tangent)
    s_dd = degree * (degree - 1) * (s0 - 2.0 * s1 + s2)
    p_dd = k2 * np.dot(s_dd, tangent) * tangent + k1**2 * np.dot(s_dd, normal) * normal
    return p_dd / (degree * (degree - 1)) + 2.0 * p1 - s0


def tool_path_pieces(curves: BladeCurves) -> list[BezierCurve]:
    """The closed, counter-clockwise cutter path of a tool-path blade.

    Order: pressure side from P4 to P0, suction side from S0 to S4, then the trailing-edge pass: the
    cutter leaves S4 along t(1) by R, crosses the trailing edge along −n to P4 + R t(1), and returns by R
    to P4. Its flank thus cuts the flat trailing-edge face through CL2, normal to the camber line, leaving
    the chord at L and the half-thicknesses at d_s4 and d_p4; a straight S4P4 pass through CL2 would cut R
    off the chord.
    """
    if curves.mode is not Mode.TOOLPATH:
        raise ValueError("tool_path_pieces needs a tool-path blade")
    (t2,) = curves.camber.unit_tangent([1.0])
    lead = curves.radius * t2
    s4, p4 = curves.suction.end, curves.pressure.end
    return [
        curves.pressure.reversed(),
        curves.suction,
        BezierCurve(np.array([s4, s4 + lead])),
        BezierCurve(np.array([s4 + lead, p4 + lead])),
        BezierCurve(np.array([p4 + lead, p4])),
    ]
