"""The blade profile: a closed polyline of the blade surface, from the design curves or the N-buffer.

Point order (counter-clockwise, material on the left): the pressure-side trailing-edge corner first,
along the pressure side to the leading edge, along the suction side to the suction-side trailing-edge
corner; the trailing edge closes the loop back to the first point, which is not repeated.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely

from geometry.bezier import Array, BezierCurve
from geometry.blade import BladeCurves, blade_curves, tool_path_pieces
from geometry.nbuffer import MachinedBoundary, machine
from geometry.parameters import BladeSpec, Mode
from geometry.sampling import sample_curve

DEFAULT_TOLERANCE = 1e-6  # m: polyline within 1 µm of the exact curves / machined envelope
DEFAULT_MAX_SPACING = 1e-3  # m: largest distance between consecutive profile points


class GeometryError(ValueError):
    """A blade that cannot be built: no camber line, or a machined blade that splits or vanishes."""


@dataclass(frozen=True)
class Profile:
    """A blade profile in metres.

    Attributes
    ----------
    points: ``(n, 2)`` counter-clockwise closed polyline (see module docstring), first point not repeated.
    le_index: index of the leading-edge point.
    te_index: index of the suction-side trailing-edge corner; the trailing edge runs from there to the
        last point and back to ``points[0]``.
    curves: camber line and side curves (control points) the profile was built from.
    tool_path: ``(m, 2)`` closed cutter-centre polyline in tool-path mode, else ``None``.
    machining: N-buffer diagnostics in tool-path mode, else ``None``.
    """

    points: Array
    le_index: int
    te_index: int
    curves: BladeCurves
    tool_path: Array | None = None
    machining: MachinedBoundary | None = None

    @property
    def mode(self) -> Mode:
        return self.curves.mode

    @property
    def spec(self) -> BladeSpec:
        return self.curves.spec

    @property
    def chord(self) -> float:
        """Chord length L of the blade, m (the camber line's length parameter, Eq. 1 of the paper)."""
        return float(self.spec["L"])

    @property
    def leading_edge(self) -> Array:
        return self.points[self.le_index]

    @property
    def suction(self) -> Array:
        """Suction side from leading to trailing edge."""
        return self.points[self.le_index : self.te_index + 1]

    @property
    def pressure(self) -> Array:
        """Pressure side from leading to trailing edge."""
        return self.points[: self.le_index + 1][::-1]

    @property
    def trailing_edge(self) -> Array:
        """Trailing edge from the suction-side corner to the pressure-side corner."""
        return np.vstack([self.points[self.te_index :], self.points[:1]])

    @property
    def polygon(self) -> shapely.Polygon:
        return shapely.Polygon(self.points)

    @property
    def area(self) -> float:
        """Enclosed area in m² (per unit span: m³/m)."""
        return float(self.polygon.area)

    @property
    def max_thickness(self) -> float:
        """Diameter of the largest inscribed circle, m."""
        circle = shapely.maximum_inscribed_circle(self.polygon, tolerance=1e-8)
        return 2.0 * float(circle.length)

    @property
    def control_points(self) -> dict[str, Array]:
        return {
            "camber": self.curves.camber.control_points,
            "suction": self.curves.suction.control_points,
            "pressure": self.curves.pressure.control_points,
        }

    def to_csv(self, path: str | Path) -> None:
        """Write the points as CSV with an ``x,y`` header, metres, first point not repeated."""
        with open(path, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["x", "y"])
            writer.writerows((f"{x:.10e}", f"{y:.10e}") for x, y in self.points)


def build_profile(spec: BladeSpec, tolerance: float = DEFAULT_TOLERANCE,
                  max_spacing: float = DEFAULT_MAX_SPACING) -> Profile:
    """Build the profile of ``spec`` within ``tolerance`` (m) of the exact curves or machined envelope.

    Raises
    ------
    GeometryError if the camber line does not exist or the machined blade splits or vanishes.
    """
    try:
        curves = blade_curves(spec)
    except ValueError as exc:
        raise GeometryError(str(exc)) from exc
    if spec.mode is Mode.DESIGN:
        return _design_profile(curves, tolerance, max_spacing)
    return _machined_profile(curves, tolerance, max_spacing)


def _design_profile(curves: BladeCurves, tolerance: float, max_spacing: float) -> Profile:
    pressure = curves.pressure.points(sample_curve(curves.pressure, tolerance, max_spacing))[::-1]
    suction = curves.suction.points(sample_curve(curves.suction, tolerance, max_spacing))
    points = np.vstack([pressure, suction[1:]])  # the leading edge is shared
    return Profile(points, le_index=len(pressure) - 1, te_index=len(points) - 1, curves=curves)


def _machined_profile(curves: BladeCurves, tolerance: float, max_spacing: float) -> Profile:
    pieces = tool_path_pieces(curves)
    result = machine(pieces, curves.radius, tolerance, max_spacing)
    if result.points.shape[0] < 3:
        raise GeometryError("the machined blade vanishes: the cutter removes all the material")
    if result.split:
        where = ", ".join(f"({a[0]*1e3:.2f}, {a[1]*1e3:.2f}) mm" for a, _ in result.gaps[:3])
        count = f"into {result.pieces} pieces" if result.pieces > 1 else "(its outline does not close)"
        raise GeometryError(f"the machined blade splits {count}: the cutter cuts through it near {where}")
    if result.unlinked.shape[0]:
        where = ", ".join(f"({x*1e3:.2f}, {y*1e3:.2f}) mm" for x, y in result.unlinked[:3])
        raise GeometryError(f"the machined boundary is undetermined: {result.unlinked.shape[0]} stretch(es) of "
                            f"machined surface near {where} could not be linked into a closed outline")
    # Pieces: 0 pressure (P4 -> P0), 1 suction (S0 -> S4), 2-4 trailing-edge pass.
    le_index = int(np.argmin(np.abs(result.sigma - 1.0)))
    te_index = int(np.argmin(np.abs(result.sigma - 2.0)))
    return Profile(result.points, le_index, te_index, curves, tool_path=path_polyline(pieces, tolerance),
                   machining=result)


def path_polyline(pieces: list[BezierCurve], tolerance: float = DEFAULT_TOLERANCE,
                  max_spacing: float = DEFAULT_MAX_SPACING) -> Array:
    """Closed polyline through consecutive curves, first point not repeated."""
    return np.vstack([p.points(sample_curve(p, tolerance, max_spacing))[:-1] for p in pieces])
