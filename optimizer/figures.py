"""Figures of merit of one solved blade: forces, C_L (Eq. 23), C_max, C_p,min, y+ and wall distributions.

:func:`figures_of_merit` reduces a :class:`solver.FlowResults` to the figures of the paper (Vessaz et al.
2013) and returns them as an :class:`~optimizer.evaluation.Evaluation`; :func:`lift_coefficient` and
:func:`pressure_coefficient_min` are the definitions of C_L and C_p,min that every figure, the campaign's
window means included, is computed with; :func:`wall_distribution` gives
C_p, c_f and y+ along each side of the blade. The solver knows meshes and fields, never blades: splitting
the blade wall into suction side, pressure side and trailing edge uses the :class:`geometry.Profile` (its
leading- and trailing-edge indices) and is done here. See ``docs/explanation/evaluation.md``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from meshing import BOUNDARY_GROUPS
from optimizer.evaluation import SIDES, Evaluation, WallDistribution
from solver import ConvergenceClass, classify

if TYPE_CHECKING:
    from geometry import Profile
    from optimizer.config import Config
    from solver import FlowResults

#: The boundary groups of a blade mesh (:data:`meshing.BOUNDARY_GROUPS`, in its documented order): the
#: pipeline sets a condition on each; the figures are measured on the blade, with the inlet as reference.
INLET, OUTLET, TOP, BOTTOM, BLADE = BOUNDARY_GROUPS


def lift_coefficient(lift: float, density: float, speed: float, chord: float, span: float) -> float:
    """C_L of Eq. 23, ``F_Y / (½ rho C0² L span)``: lift: F_Y over the span depth, N (negative when the
    blade is pushed towards -y); density rho, kg/m³; speed C0, m/s (> 0); chord L, m (> 0, the
    profile's); span: the span depth, m (> 0)."""
    return lift / (0.5 * density * speed**2 * chord * span)


def pressure_coefficient_min(c_max: float, speed: float) -> float:
    """C_p,min ``= 1 - C_max² / C0²`` (Bernoulli from the free stream, ≤ 1): c_max, the largest velocity
    magnitude, and speed C0, both m/s (C0 > 0)."""
    return 1.0 - (c_max / speed) ** 2


def figures_of_merit(config: Config, profile: Profile, flow: FlowResults) -> Evaluation:
    """The evaluation of a solved blade: status and classification, F_X, F_Y (N/m and N over the span),
    C_L, C_max, C_p,min, wall C_p min, y+ max and mean, and the wall distribution (SI units).

    A solve that stopped at ``max_iter`` without a classification from the solver is classified here
    from its monitors (``solver:`` section's ``classify_window``, ``classify_tol``). Where it is
    ``oscillating``, F_X, F_Y and C_max are the window means of their monitors. A non-finite figure
    becomes None with its reason in :attr:`Evaluation.missing`. The pipeline adds the stage times and
    the artifacts.
    """
    s, fl = config.solver, config.flow
    chord = profile.chord
    span = fl.span_for(chord)
    cls = flow.classification or classify(flow.monitors, window=s.classify_window, tol=s.classify_tol,
                                          converged=flow.converged, diverged=flow.status == ConvergenceClass.DIVERGED)
    status = flow.status if flow.classification is not None or flow.converged else cls.status

    forces = flow.forces(BLADE)
    fx, fy, c_max = forces.fx, forces.fy, flow.c_max
    values_from = "final iterate"
    if status == ConvergenceClass.OSCILLATING:
        means = {k: cls.mean.get(k) for k in (f"fx:{BLADE}", f"fy:{BLADE}", "c_max")}
        if all(v is not None for v in means.values()):
            fx, fy, c_max = means.values()
            values_from = f"mean of the last {cls.window} iterations"

    wall = wall_distribution(flow, profile, fl.speed, fl.density)
    values = {
        "fx": fx, "fy": fy, "fx_span": fx * span, "fy_span": fy * span,
        "c_l": lift_coefficient(fy * span, fl.density, fl.speed, chord, span),
        "c_max": c_max, "cp_min": pressure_coefficient_min(c_max, fl.speed), "cp_wall_min": float(wall.cp.min()),
        "yplus_max": float(wall.y_plus.max()),
        "yplus_mean": float(np.dot(wall.y_plus, wall.length) / wall.length.sum()),
    }
    missing = {k: "not finite" for k, v in values.items() if not math.isfinite(v)}
    figures = {k: None if k in missing else float(v) for k, v in values.items()}
    return Evaluation(status, None, f"{flow.message}; classification: {cls.reason}", converged=flow.converged,
                      classification=cls, span=span, chord=chord, values_from=values_from, iterations=flow.iterations,
                      cells=flow.mesh.n_cells, model=s.model, missing=missing, wall=wall, **figures)


def wall_distribution(flow: FlowResults, profile: Profile, speed: float, density: float) -> WallDistribution:
    """C_p, c_f and y+ on the blade faces of ``flow``, split by side with the ``profile``'s leading and
    trailing edges; free-stream ``speed`` C0 (m/s) and ``density`` rho (kg/m³) make them dimensionless;
    reference pressure: the inlet's length-weighted mean."""
    m = flow.mesh
    faces = m.boundary[BLADE]
    j = m.boundary_local(BLADE)
    xy = m.face_centre[faces]
    side, s = _split_wall(xy, profile)
    q = 0.5 * density * speed**2

    pb = flow.boundary_pressure()
    inlet = m.boundary[INLET]
    p_ref = float(np.dot(pb[m.boundary_local(INLET)], m.length[inlet]) / m.length[inlet].sum())
    cp = (pb[j] - p_ref) / q

    tau = np.asarray(flow.wall_shear(BLADE), float)
    # Unit tangent away from the leading edge: the profile runs counter-clockwise, i.e. towards the
    # leading edge on the pressure side; the face normal n points out of the fluid (into the blade).
    n = m.normal[faces]
    t_ccw = np.column_stack([-n[:, 1], n[:, 0]])      # counter-clockwise along the blade outline
    t_ccw *= np.sign(np.einsum("ij,ij->i", t_ccw, _outline_direction(xy, profile)))[:, None]
    t = np.where((side == "pressure")[:, None], -t_ccw, t_ccw)
    cf = np.einsum("ij,ij->i", tau, t) / q
    yplus = np.asarray(flow.y_plus(BLADE), float)

    order = np.lexsort((s, np.array([SIDES.index(x) for x in side])))
    return WallDistribution(side[order], s[order], xy[order, 0], xy[order, 1], cp[order], cf[order],
                            yplus[order], m.length[faces][order])


def _split_wall(xy: np.ndarray, profile: Profile) -> tuple[np.ndarray, np.ndarray]:
    """Side and arc length (see :class:`WallDistribution`) of points ``xy (n, 2)`` on the profile wall.

    The profile runs counter-clockwise from the pressure-side trailing-edge corner (point 0) to the
    leading edge (``le_index``), the suction-side corner (``te_index``) and back along the trailing edge;
    each point is projected on that polyline and placed by its arc length from point 0.
    """
    import shapely

    pts = np.asarray(profile.points, float)
    closed = np.vstack([pts, pts[:1]])
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    s_le, s_te = cum[profile.le_index], cum[profile.te_index]
    t = shapely.line_locate_point(shapely.LineString(closed), shapely.points(xy))
    side = np.where(t <= s_le, "pressure", np.where(t <= s_te, "suction", "trailing_edge"))
    s = np.where(side == "pressure", s_le - t, np.where(side == "suction", t - s_le, t - s_te))
    return side, s


def _outline_direction(xy: np.ndarray, profile: Profile) -> np.ndarray:
    """Unit direction of the counter-clockwise profile polyline at the segment nearest each point."""
    from scipy.spatial import cKDTree

    pts = np.asarray(profile.points, float)
    seg = np.roll(pts, -1, axis=0) - pts
    mid = pts + 0.5 * seg
    _, k = cKDTree(mid).query(xy)
    d = seg[k]
    return d / np.linalg.norm(d, axis=1)[:, None]
