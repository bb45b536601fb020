"""One evaluation of one blade: geometry → mesh → flow solve → figures of merit, never raising.

:func:`evaluate` runs the pipeline for one configuration (one individual of a campaign) and returns an
:class:`Evaluation`: the status, the time of each stage, the figures of the paper (F_X, F_Y, C_L of
Eq. 23, C_max, C_p,min), y+ on the blade, the convergence classification of the solve and the wall
distributions (C_p, c_f, y+ against the arc length from the leading edge, per side). A bad individual
(infeasible blade, mesh below the quality thresholds, diverged solve) is not an error: the evaluation
records the stage that failed and why. No figure is ever NaN or infinite: an undefined figure is
``None`` and :attr:`Evaluation.missing` says why.

The solver knows meshes and fields, never blades: splitting the blade wall into suction side, pressure
side and trailing edge uses the :class:`geometry.Profile` (its leading- and trailing-edge indices) and
is done here (:func:`wall_distribution`). See ``docs/evaluation.md``.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from optimizer.config import Config

#: Stages in pipeline order; :attr:`Evaluation.seconds` has one entry per stage that ran.
STAGES = ("geometry", "mesh", "solve", "post")
#: Statuses of a completed solve (figures available), best first; then the failures.
SOLVED = ("converged", "stationary", "oscillating", "not_converged")
FAILED = ("infeasible", "diverged", "failed")
#: Blade wall parts of :class:`WallDistribution`.
SIDES = ("suction", "pressure", "trailing_edge")


@dataclass(frozen=True)
class WallDistribution:
    """Values on the blade wall faces, ordered by side then arc length (``n`` faces).

    side: ``(n,)`` one of :data:`SIDES`. s: ``(n,)`` arc length along the profile, m — from the leading
    edge on the suction and pressure sides, from the suction-side trailing-edge corner on the trailing
    edge. x, y: ``(n,)`` face centres, m. cp: ``(n,)`` pressure coefficient ``(p - p_ref) / (½ rho C0²)``
    with p_ref the length-weighted mean static pressure on the inlet. cf: ``(n,)`` skin friction
    ``tau_w · t / (½ rho C0²)``, t the unit tangent pointing away from the leading edge along the side
    (towards the pressure-side corner on the trailing edge): negative where the flow runs back.
    y_plus: ``(n,)`` y+ of the wall-adjacent cell centre, or None. length: ``(n,)`` face lengths, m.
    """

    side: np.ndarray
    s: np.ndarray
    x: np.ndarray
    y: np.ndarray
    cp: np.ndarray
    cf: np.ndarray
    y_plus: np.ndarray | None
    length: np.ndarray

    def part(self, side: str) -> dict[str, np.ndarray]:
        """The arrays of one side (:data:`SIDES`), sorted by arc length."""
        k = self.side == side
        out = {"s": self.s[k], "x": self.x[k], "y": self.y[k], "cp": self.cp[k], "cf": self.cf[k]}
        if self.y_plus is not None:
            out["y_plus"] = self.y_plus[k]
        return out

    def to_csv(self, path: str | Path) -> None:
        """Write ``side,s,x,y,Cp,cf,yplus`` (SI; yplus empty when unknown)."""
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["side", "s", "x", "y", "Cp", "cf", "yplus"])
            for i in range(self.s.size):
                yp = "" if self.y_plus is None else f"{self.y_plus[i]:.6g}"
                w.writerow([self.side[i], f"{self.s[i]:.9g}", f"{self.x[i]:.9g}", f"{self.y[i]:.9g}",
                            f"{self.cp[i]:.6g}", f"{self.cf[i]:.6g}", yp])

    def to_dict(self) -> dict:
        return {side: {k: _clean_list(v) for k, v in self.part(side).items()} for side in SIDES}


@dataclass(frozen=True)
class Evaluation:
    """The outcome of :func:`evaluate` for one blade (SI units).

    status: ``converged``, ``stationary``, ``oscillating``, ``not_converged`` (the solve ran; figures
        available, see ``docs/evaluation.md`` for which to trust) or ``infeasible``, ``diverged``,
        ``failed`` (no figures). stage: the stage that failed (:data:`STAGES`), else None.
    message: one line saying why (the failure reason, or the solver's and the classifier's verdict).
    converged: the solver's own convergence test passed.
    classification: :class:`solver.convergence.Classification` of the monitors, or None (no solve).
    fx, fy: force on the blade per unit span, N/m (x along the inflow). fx_span, fy_span: the same
        times the span depth, N. span: the span depth used, m. c_l: lift coefficient of Eq. 23
        ``F_Y / (½ rho C0² L span)``. c_max: largest velocity magnitude over the cell centres, m/s.
        cp_min: ``1 - C_max² / C0²``. cp_wall_min: smallest wall C_p (with p_ref = inlet mean).
        Where the status is ``oscillating``, fx, fy and c_max are the window means of their monitors
        (``values_from`` says which).
    yplus_max, yplus_mean: y+ of the wall-adjacent cell centres on the blade (face-length weighted mean).
    iterations, cells: solver iterations, mesh cells. seconds: ``{stage: wall-clock s}``.
    missing: ``{figure: reason}`` for every figure that is None although the solve ran.
    wall: :class:`WallDistribution` or None. artifacts: in-memory objects for saving (profile, mesh,
        flow results); not serialised.
    """

    status: str
    stage: str | None
    message: str
    converged: bool = False
    classification: Any = None
    fx: float | None = None
    fy: float | None = None
    fx_span: float | None = None
    fy_span: float | None = None
    span: float | None = None
    c_l: float | None = None
    c_max: float | None = None
    cp_min: float | None = None
    cp_wall_min: float | None = None
    yplus_max: float | None = None
    yplus_mean: float | None = None
    values_from: str | None = None
    iterations: int | None = None
    cells: int | None = None
    model: str | None = None
    seconds: dict = field(default_factory=dict)
    missing: dict = field(default_factory=dict)
    wall: WallDistribution | None = None
    artifacts: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """The solve ran and its figures exist (any status in :data:`SOLVED`)."""
        return self.status in SOLVED

    def summary(self) -> dict:
        """The scalar results, JSON-ready (the ``--json`` output of ``millfoil evaluate``)."""
        c = self.classification
        return {
            "status": self.status, "stage": self.stage, "message": self.message, "converged": self.converged,
            "model": self.model, "F_X": self.fx, "F_Y": self.fy, "F_X_span": self.fx_span,
            "F_Y_span": self.fy_span, "span": self.span, "C_L": self.c_l, "C_max": self.c_max,
            "Cp_min": self.cp_min, "Cp_wall_min": self.cp_wall_min, "yplus_max": self.yplus_max,
            "yplus_mean": self.yplus_mean, "values_from": self.values_from, "iterations": self.iterations,
            "cells": self.cells, "seconds": dict(self.seconds), "missing": dict(self.missing),
            "classification": None if c is None else _clean(c.to_dict()),
        }

    def to_dict(self, wall: bool = True) -> dict:
        """:meth:`summary` plus, with ``wall``, the wall distributions per side."""
        out = self.summary()
        if wall:
            out["wall"] = None if self.wall is None else self.wall.to_dict()
        return out

    def to_json(self, wall: bool = True, **kwargs) -> str:
        """:meth:`to_dict` as JSON (strict: no NaN, no infinity)."""
        return json.dumps(self.to_dict(wall), allow_nan=False, **kwargs)


class _StageFailure(Exception):
    def __init__(self, status: str, stage: str, reason: str):
        super().__init__(reason)
        self.status, self.stage, self.reason = status, stage, reason


def evaluate(config: Config, *, log: Callable[[str], None] | None = None, every: int = 50,
             warm_start=None) -> Evaluation:
    """Geometry → mesh → solve → figures for the blade of ``config``; never raises for a bad blade.

    log: called with one line of progress per stage start/end and every ``every`` solver iterations.
    warm_start: a :class:`solver.FlowResults` of another blade in the same flow (e.g. the previous
        evaluation's ``artifacts["flow"]``): the solve starts from its fields transferred to this mesh
        (:func:`solver.warmstart.mapped_state`) instead of ``solver.initial``.
    """
    say = log or (lambda _line: None)
    seconds: dict[str, float] = {}
    artifacts: dict[str, Any] = {}
    model = config.solver.model
    try:
        profile = _timed("geometry", seconds, say, _geometry, config)
        artifacts["profile"] = profile
        _, fvmesh = _timed("mesh", seconds, say, _mesh, config, profile, artifacts)
        flow = _timed("solve", seconds, say, _solve, config, fvmesh, say, every, warm_start)
        artifacts["flow"] = flow          # kept for saving, also when diverged (last finite iterate)
        if flow.status == "diverged":
            raise _StageFailure("diverged", "solve", flow.message)
    except _StageFailure as f:
        say(f"{f.stage}: {f.status}: {f.reason}")
        cells = artifacts["mesh"].n_cells if "mesh" in artifacts else None
        iterations = artifacts["flow"].iterations if "flow" in artifacts else None
        return Evaluation(f.status, f.stage, f.reason, model=model, cells=cells, iterations=iterations,
                          seconds=seconds, artifacts=artifacts)
    try:
        ev = _timed("post", seconds, say, _post, config, profile, flow, seconds, artifacts)
    except _StageFailure as f:
        return Evaluation(f.status, f.stage, f.reason, model=model, cells=fvmesh.n_cells, seconds=seconds,
                          iterations=flow.iterations, artifacts=artifacts)
    say(f"result: {ev.status}; {ev.message}")
    return ev


def _timed(stage, seconds, say, fn, *args):
    say(f"{stage}: start")
    t0 = time.perf_counter()
    try:
        return fn(*args)
    except _StageFailure:
        raise
    except Exception as exc:  # an unexpected error in a stage is recorded, not raised (one bad individual)
        raise _StageFailure("failed", stage, f"unexpected {type(exc).__name__}: {exc}") from exc
    finally:
        seconds[stage] = time.perf_counter() - t0
        say(f"{stage}: done in {seconds[stage]:.2f} s")


# ------------------------------------------------------------------------------------------- stages
def _geometry(config: Config):
    from geometry import GeometryError, evaluate_blade
    from optimizer.config import ConfigError

    try:
        result = evaluate_blade(config.blade.spec())
    except (GeometryError, ConfigError, ValueError) as exc:
        raise _StageFailure("failed", "geometry", f"blade cannot be built: {exc}") from exc
    if not result.feasible or result.profile is None:
        reasons = "; ".join(f"{c.name}: {c.reason}" for c in result.violations) or "no profile"
        raise _StageFailure("infeasible", "geometry", f"infeasible blade: {reasons}")
    return result.profile


def _mesh(config: Config, profile, artifacts: dict):
    from meshing import MeshingError, MeshQualityError, build_mesh, check_quality
    from solver import MeshError, build_fvmesh

    try:
        mesh2d = build_mesh(profile, config.mesh_spec())
        artifacts["mesh"] = mesh2d          # kept (and saved) even when below the quality thresholds
        check_quality(mesh2d)
        fvmesh = build_fvmesh(mesh2d.points, mesh2d.cells, mesh2d.boundary)
    except (MeshingError, MeshQualityError, MeshError) as exc:
        raise _StageFailure("failed", "mesh", f"{type(exc).__name__}: {exc}") from exc
    return mesh2d, fvmesh


def boundary_conditions(config: Config) -> dict:
    """The paper's conditions (§3.2): uniform inlet ``(C0, 0)`` (with turbulence intensity and viscosity
    ratio for a turbulence model), outlet at zero mean static pressure, symmetry top and bottom, no-slip
    blade."""
    flow = config.flow
    inlet: dict[str, Any] = {"type": "velocity_inlet", "velocity": (flow.speed, 0.0)}
    if config.solver.model != "laminar":
        inlet.update(intensity=flow.intensity, viscosity_ratio=flow.viscosity_ratio)
    return {"inlet": inlet, "outlet": {"type": "pressure_outlet", "p": 0.0, "mode": "mean"},
            "top": "symmetry", "bottom": "symmetry", "blade": "wall"}


def simple_settings(config: Config):
    """:class:`solver.SimpleSettings` from the ``solver:`` section (blade forces monitored)."""
    from solver import SimpleSettings

    s = config.solver
    changes = dict(max_iter=s.max_iter, tol=s.tol, monitor_tol=s.monitor_tol, monitor_window=s.monitor_window,
                   monitor_groups=("blade",), classify_window=s.classify_window, classify_tol=s.classify_tol,
                   stall_tol=s.stall_tol, convection=s.convection, algorithm=s.algorithm, alpha_u=s.alpha_u,
                   alpha_p=1.0 if s.alpha_p is None and s.algorithm == "simplec" else s.alpha_p)
    if changes["alpha_p"] is None:
        changes.pop("alpha_p")
    return dataclasses.replace(SimpleSettings(), **changes)


def _solve(config: Config, fvmesh, say, every, warm_start=None):
    from solver import Fluid, Problem, solve_steady
    from solver.steady import initial_state

    s = config.solver
    fluid = Fluid(config.flow.density, config.flow.viscosity)
    bcs = boundary_conditions(config)
    kwargs = {}
    if s.model == "sst":
        try:
            from solver.turbulence import SST
        except ImportError as exc:
            raise _StageFailure("failed", "solve", f"model 'sst' is not available in this solver ({exc}); "
                                "use solver.model=laminar") from exc
        kwargs["turbulence"] = SST(wall_treatment=s.wall_treatment)
    try:
        problem = Problem.create(fvmesh, bcs, fluid, **kwargs)
    except (TypeError, ValueError) as exc:
        raise _StageFailure("failed", "solve", f"cannot set up the problem: {exc}") from exc
    t0 = time.perf_counter()

    def progress(it, res, _state):
        if every and it % every == 0:
            r = " ".join(f"{k} {v:.2e}" for k, v in res.items())
            say(f"solve: iteration {it}/{s.max_iter}: residuals {r} ({time.perf_counter() - t0:.1f} s)")

    # (the AMG set-up seeds its own random vectors: solver.linalg, so an evaluation is reproducible)
    if warm_start is not None:
        from solver.warmstart import mapped_state

        state = mapped_state(problem, warm_start)
    else:
        state = initial_state(problem, (config.flow.speed, 0.0) if s.initial == "freestream" else (0.0, 0.0))
    flow = solve_steady(problem, simple_settings(config), state, callback=progress)
    return flow


# -------------------------------------------------------------------------------------------- post
def _post(config: Config, profile, flow, seconds, artifacts) -> Evaluation:
    from solver.convergence import classify

    s, fl = config.solver, config.flow
    chord = float(profile.spec["L"])
    span = fl.span_for(chord)
    q = 0.5 * fl.density * fl.speed**2
    cls = flow.classification or classify(flow.monitors, window=s.classify_window, tol=s.classify_tol,
                                          converged=flow.converged, diverged=flow.status == "diverged")
    status = flow.status if flow.classification is not None or flow.converged else cls.status
    missing: dict[str, str] = {}

    forces = flow.forces("blade")
    fx, fy, c_max = forces.fx, forces.fy, flow.c_max
    values_from = "final iterate"
    if status == "oscillating":
        means = {"fx": cls.mean.get("fx:blade"), "fy": cls.mean.get("fy:blade"), "c_max": cls.mean.get("c_max")}
        if all(v is not None for v in means.values()):
            fx, fy, c_max = means["fx"], means["fy"], means["c_max"]
            values_from = f"mean of the last {cls.window} iterations"

    wall = wall_distribution(flow, profile, fl.speed, fl.density)
    yplus_max = yplus_mean = None
    if wall.y_plus is None:
        missing["yplus"] = "the solver gives no y+ for this model"
    else:
        yplus_max = float(wall.y_plus.max())
        yplus_mean = float(np.dot(wall.y_plus, wall.length) / wall.length.sum())

    values = {
        "fx": fx, "fy": fy, "fx_span": fx * span, "fy_span": fy * span, "c_l": fy * span / (q * chord * span),
        "c_max": c_max, "cp_min": 1.0 - (c_max / fl.speed) ** 2, "cp_wall_min": float(wall.cp.min()),
        "yplus_max": yplus_max, "yplus_mean": yplus_mean,
    }
    for k, v in list(values.items()):
        if v is not None and not math.isfinite(v):
            values[k] = None
            missing[k] = "not finite"
    message = f"{flow.message}; classification: {cls.reason}"
    return Evaluation(status, None, message, converged=flow.converged, classification=cls, span=span,
                      values_from=values_from, iterations=flow.iterations, cells=flow.mesh.n_cells,
                      model=s.model, seconds=seconds, missing=missing, wall=wall, artifacts=artifacts,
                      **{k: (None if v is None else float(v)) for k, v in values.items()})


def _split_wall(xy: np.ndarray, profile) -> tuple[np.ndarray, np.ndarray]:
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


def wall_distribution(flow, profile, speed: float, density: float) -> WallDistribution:
    """C_p, c_f and y+ on the blade faces of ``flow`` (a :class:`solver.FlowResults`), split by side with
    the ``profile``'s leading and trailing edges; reference pressure: inlet length-weighted mean."""
    m = flow.mesh
    faces = m.boundary["blade"]
    j = m.boundary_local("blade")
    xy = m.face_centre[faces]
    side, s = _split_wall(xy, profile)
    q = 0.5 * density * speed**2

    pb = flow.boundary_pressure()
    ji = m.boundary_local("inlet")
    p_ref = float(np.dot(pb[ji], m.length[m.boundary["inlet"]]) / m.length[m.boundary["inlet"]].sum())
    cp = (pb[j] - p_ref) / q

    tau = _wall_shear(flow)
    # Unit tangent away from the leading edge: the profile runs counter-clockwise, i.e. towards the
    # leading edge on the pressure side; the face normal n points out of the fluid (into the blade).
    n = m.normal[faces]
    t_ccw = np.column_stack([-n[:, 1], n[:, 0]])      # counter-clockwise along the blade outline
    t_ccw *= np.sign(np.einsum("ij,ij->i", t_ccw, _outline_direction(xy, profile)))[:, None]
    t = np.where((side == "pressure")[:, None], -t_ccw, t_ccw)
    cf = np.einsum("ij,ij->i", tau, t) / q
    yplus = _y_plus(flow, tau)

    order = np.lexsort((s, np.array([SIDES.index(x) for x in side])))
    return WallDistribution(side[order], s[order], xy[order, 0], xy[order, 1], cp[order], cf[order],
                            None if yplus is None else yplus[order], m.length[faces][order])


def _outline_direction(xy: np.ndarray, profile) -> np.ndarray:
    """Unit direction of the counter-clockwise profile polyline at the segment nearest each point."""
    pts = np.asarray(profile.points, float)
    seg = np.roll(pts, -1, axis=0) - pts
    mid = pts + 0.5 * seg
    from scipy.spatial import cKDTree

    _, k = cKDTree(mid).query(xy)
    d = seg[k]
    return d / np.linalg.norm(d, axis=1)[:, None]


def _wall_shear(flow) -> np.ndarray:
    """Wall shear stress on the blade faces ``(n, 2)``, Pa (force per area of the fluid on the wall):
    ``FlowResults.wall_shear`` when the solver has it (turbulence models), else the laminar one-sided
    difference ``mu (u_P - u_wall)_t / dn`` used by ``FlowResults.forces``."""
    if hasattr(flow, "wall_shear"):
        return np.asarray(flow.wall_shear("blade"), float)
    m = flow.mesh
    f = m.boundary["blade"]
    j = m.boundary_local("blade")
    du = flow.u[m.owner[f]] - flow.boundary.velocity(m, flow.u, flow.grad_u())[j]
    n = m.normal[f]
    du_t = du - np.einsum("ij,ij->i", du, n)[:, None] * n
    dn = np.einsum("ij,ij->i", m.d[f], n)
    return (flow.mu / dn)[:, None] * du_t


def _y_plus(flow, tau: np.ndarray) -> np.ndarray | None:
    """y+ of the wall-adjacent cell centres: ``FlowResults.y_plus`` when the solver has it, else
    ``dn u_tau / nu`` with ``u_tau = sqrt(|tau_w| / rho)`` from the laminar wall shear."""
    if hasattr(flow, "y_plus"):
        try:
            y = flow.y_plus("blade")
        except (ValueError, NotImplementedError, AttributeError):
            y = None
        if y is not None:
            return np.asarray(y, float)
    m = flow.mesh
    f = m.boundary["blade"]
    dn = np.abs(np.einsum("ij,ij->i", m.d[f], m.normal[f]))
    u_tau = np.sqrt(np.linalg.norm(tau, axis=1) / flow.rho)
    return dn * u_tau * flow.rho / flow.mu


# ------------------------------------------------------------------------------------------ saving
def save(evaluation: Evaluation, config: Config, directory: str | Path) -> list[Path]:
    """Write what exists of ``mesh.msh``, ``fields.vtu``, ``wall.csv``, ``result.json`` and the resolved
    ``config.yaml`` into ``directory`` (created); returns the paths written."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    (out / "config.yaml").write_text(config.to_yaml())
    written.append(out / "config.yaml")
    a = evaluation.artifacts
    if "mesh" in a:
        a["mesh"].write(out / "mesh.msh")
        written.append(out / "mesh.msh")
    if "flow" in a:
        a["flow"].write_vtu(out / "fields.vtu")
        written.append(out / "fields.vtu")
    if evaluation.wall is not None:
        evaluation.wall.to_csv(out / "wall.csv")
        written.append(out / "wall.csv")
    (out / "result.json").write_text(evaluation.to_json(indent=2))
    written.append(out / "result.json")
    return written


# ------------------------------------------------------------------------------------------ helpers
def _clean(v):
    """Replace non-finite floats by None, recursively (JSON has no NaN)."""
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def _clean_list(a: np.ndarray) -> list:
    if a.dtype.kind in "US":
        return a.tolist()
    return [float(x) if math.isfinite(x) else None for x in np.asarray(a, float)]
