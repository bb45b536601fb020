"""Feasibility of a blade as constraint values for the optimiser (value ≤ 0 is feasible).

Constraints, in the order of :func:`constraint_names`:

* ``eq21_inlet``  = β1 − α (rad) and ``eq21_outlet`` = α − β̄1 (rad): the chord angle lies between the
  inlet and outlet angles (Eq. 21), so that CL1 exists between CL0 and CL2.
* ``eq22_curvature`` (tool-path mode) = 1 − R_κ,min / R: the curvature radius of both cutter-path curves
  is at least the cutter radius (Eq. 22, with the printed ‖Q̈‖³ read as ‖Q̇‖³), otherwise the offset loops.
* ``sides_simple`` = +1 if the closed blade outline (design) or cutter path (tool path) crosses itself or
  runs clockwise (sides swapped), else −1.
* ``machined_intact`` (tool-path mode) = +1 if the machined blade splits, vanishes, self-intersects or has
  machined surface the N-buffer could not link into its outline, else −1.

Each constraint carries a reason that names the figure behind it, so an optimiser log or report can say
why an individual was rejected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.optimize import minimize_scalar

from geometry.bezier import BezierCurve
from geometry.blade import BladeCurves, blade_curves, tool_path_pieces
from geometry.parameters import BladeSpec, Mode
from geometry.profile import DEFAULT_TOLERANCE, GeometryError, Profile, build_profile, path_polyline
from geometry.sampling import DENSE

_VIOLATED, _SATISFIED = 1.0, -1.0


@dataclass(frozen=True)
class Constraint:
    """One feasibility constraint: ``value`` ≤ 0 is feasible; ``reason`` explains the value."""

    name: str
    value: float
    reason: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", float(self.value))

    @property
    def satisfied(self) -> bool:
        return self.value <= 0.0


@dataclass(frozen=True)
class BladeResult:
    """A blade with its profile (``None`` if it could not be built) and its constraints."""

    spec: BladeSpec
    profile: Profile | None
    constraints: tuple[Constraint, ...]

    @property
    def feasible(self) -> bool:
        return self.profile is not None and all(c.satisfied for c in self.constraints)

    @property
    def violations(self) -> list[Constraint]:
        return [c for c in self.constraints if not c.satisfied]

    @property
    def values(self) -> np.ndarray:
        """Constraint vector G (≤ 0 feasible), ordered as :func:`constraint_names`."""
        return np.array([c.value for c in self.constraints])


def constraint_names(mode: Mode) -> tuple[str, ...]:
    if Mode(mode) is Mode.TOOLPATH:
        return ("eq21_inlet", "eq21_outlet", "eq22_curvature", "sides_simple", "machined_intact")
    return ("eq21_inlet", "eq21_outlet", "sides_simple")


def evaluate_blade(spec: BladeSpec, tolerance: float = DEFAULT_TOLERANCE) -> BladeResult:
    """Build the profile of ``spec`` and evaluate every constraint; never raises for a bad shape."""
    constraints = list(_eq21(spec))
    try:
        curves = blade_curves(spec)
    except ValueError as exc:
        failed = [Constraint(n, _VIOLATED, f"no camber line: {exc}") for n in constraint_names(spec.mode)[2:]]
        return BladeResult(spec, None, tuple(constraints + failed))

    if spec.mode is Mode.TOOLPATH:
        constraints.append(_eq22(curves))
        try:
            profile, failure = build_profile(spec, tolerance), None
        except GeometryError as exc:
            profile, failure = None, str(exc)
        outline = profile.tool_path if profile else path_polyline(tool_path_pieces(curves), tolerance)
        constraints.append(_simple(outline, "cutter path"))
        if profile is None:
            constraints.append(Constraint("machined_intact", _VIOLATED, failure))
        else:
            machined = _simple(profile.points, "machined blade")
            constraints.append(Constraint("machined_intact", machined.value, machined.reason))
        return BladeResult(spec, profile, tuple(constraints))

    profile = build_profile(spec, tolerance)
    constraints.append(_simple(profile.points, "blade outline"))
    return BladeResult(spec, profile, tuple(constraints))


def _eq21(spec: BladeSpec) -> tuple[Constraint, Constraint]:
    alpha, beta1, beta1bar = spec["alpha"], spec["beta1"], spec["beta1bar"]
    inlet = math.radians(beta1 - alpha)
    outlet = math.radians(alpha - beta1bar)
    return (
        Constraint("eq21_inlet", inlet,
                   f"Eq. 21: inlet angle β1 = {beta1:g}° {'<=' if inlet <= 0 else '>'} chord angle α = {alpha:g}°"),
        Constraint("eq21_outlet", outlet,
                   f"Eq. 21: chord angle α = {alpha:g}° {'<=' if outlet <= 0 else '>'} outlet angle "
                   f"β̄1 = {beta1bar:g}°"),
    )


def minimum_curvature_radius(curve: BezierCurve) -> tuple[float, float]:
    """Smallest curvature radius (m) of ``curve`` and the parameter u where it occurs."""
    u = np.linspace(0.0, 1.0, DENSE)
    return _refined(curve, u, np.abs(curve.curvature(u)))


def curvature_radius_at_least(curve: BezierCurve, radius: float) -> bool:
    """Whether the smallest curvature radius of ``curve`` is at least ``radius`` (m), exactly as
    :func:`minimum_curvature_radius` finds it. The refinement only ever finds a sharper turn than the dense
    samples, so it is skipped where they already turn more sharply than 1/``radius``: most of a screened
    pool's rejections cost one evaluation of the curvature."""
    u = np.linspace(0.0, 1.0, DENSE)
    kappa = np.abs(curve.curvature(u))
    k_max = kappa.max()
    if k_max > 0 and 1.0 / k_max < radius:
        return False
    return _refined(curve, u, kappa)[0] >= radius


def _refined(curve: BezierCurve, u: np.ndarray, kappa: np.ndarray) -> tuple[float, float]:
    """The smallest curvature radius from the samples ``kappa`` = |curvature(u)|, refined around their
    maximum by a bounded scalar search."""
    i = int(np.argmax(kappa))
    lo, hi = u[max(i - 1, 0)], u[min(i + 1, u.size - 1)]
    best = minimize_scalar(lambda s: -abs(curve.curvature([s])[0]), bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-12})
    u_best, k_best = (best.x, -best.fun) if -best.fun > kappa[i] else (u[i], kappa[i])
    return (1.0 / k_best if k_best > 0 else math.inf), float(u_best)


def _eq22(curves: BladeCurves) -> Constraint:
    radius = curves.radius
    (rs, us), (rp, up) = minimum_curvature_radius(curves.suction), minimum_curvature_radius(curves.pressure)
    side, r_min, u_min = ("suction", rs, us) if rs <= rp else ("pressure", rp, up)
    value = 1.0 - r_min / radius
    relation = ">=" if value <= 0 else "<"
    return Constraint("eq22_curvature", value,
                      f"Eq. 22: minimum cutter-path curvature radius {r_min * 1e3:.4g} mm ({side} side, "
                      f"u = {u_min:.4f}) {relation} R = {radius * 1e3:g} mm")


def _simple(points: np.ndarray, what: str) -> Constraint:
    name = "sides_simple"
    ring = shapely.LinearRing(points)
    if not ring.is_simple:
        return Constraint(name, _VIOLATED, f"the {what} crosses itself (suction and pressure sides cross)")
    if not shapely.is_ccw(ring):
        return Constraint(name, _VIOLATED, f"the {what} runs clockwise: suction and pressure sides are swapped")
    return Constraint(name, _SATISFIED, f"the {what} is a simple counter-clockwise loop")
