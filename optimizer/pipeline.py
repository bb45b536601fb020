"""One evaluation of one blade: geometry → mesh → flow solve → figures of merit, never raising.

:func:`evaluate` runs the pipeline for one configuration (one individual of a campaign) and returns an
:class:`~optimizer.evaluation.Evaluation`: the status, the time of each stage, the figures of the paper
(:mod:`optimizer.figures`) and the objects it built (:class:`~optimizer.evaluation.Artifacts`). A bad
individual (infeasible blade, mesh below the quality thresholds, diverged solve) is not an error: the
evaluation records the stage that failed and why. Its stages are plain functions that raise
:class:`StageFailure` for such a blade, so that a command can run one of them alone (``millfoil mesh``):

* geometry: :func:`blade_profile` (:func:`build_blade`) — the profile of a feasible blade;
* mesh: :func:`blade_mesh` (hybrid mesh, quality-checked), :func:`finite_volume_mesh` — the solver's mesh;
* solve: :func:`solve_flow` — a :class:`solver.FlowResults`;
* post: :func:`optimizer.figures.figures_of_merit` — the figures.

See ``docs/explanation/evaluation.md``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from geometry import DEFAULT_TOLERANCE, BladeResult, GeometryError, Profile, evaluate_blade
from meshing import Mesh2D, MeshingError, MeshQualityError, QualityReport, build_mesh, check_quality
from optimizer.config import Config, ConfigError
from optimizer.evaluation import Artifacts, Evaluation
from optimizer.figures import BLADE, BOTTOM, INLET, OUTLET, TOP, figures_of_merit
from solver import (
    SST,
    ConvergenceClass,
    Fluid,
    MeshError,
    Problem,
    SimpleSettings,
    build_fvmesh,
    initial_state,
    mapped_state,
    potential_start,
    solve_steady,
)

if TYPE_CHECKING:
    from solver import FlowResults, FVMesh

Log = Callable[[str], None]


class StageFailure(Exception):
    """A stage that cannot go on for this blade (a bad individual, not a bug).

    status: the evaluation's status (``infeasible``, ``diverged``, ``failed``). stage: the stage
    (:data:`optimizer.evaluation.STAGES`). reason: one line saying why. details: the reason's parts,
    each a line on its own (the violated constraints; the mesher's message). built: what the stage had
    built before it failed (e.g. the mesh below the quality thresholds), kept for saving.
    """

    def __init__(self, status: str, stage: str, reason: str, *, details: tuple[str, ...] = (),
                 built: Artifacts | None = None):
        super().__init__(reason)
        self.status, self.stage, self.reason, self.details = status, stage, reason, details
        self.built = built or Artifacts()


def evaluate(config: Config, *, log: Log | None = None, every: int = 50,
             warm_start: FlowResults | None = None) -> Evaluation:
    """Geometry → mesh → solve → figures for the blade of ``config``; never raises for a bad blade.

    log: called with one line of progress per stage start/end and every ``every`` solver iterations.
    warm_start: a :class:`solver.FlowResults` of another blade in the same flow (e.g. the previous
        evaluation's ``artifacts.flow``): the solve starts from its fields transferred to this mesh
        (:func:`solver.mapped_state`) instead of the ``solver.initial`` field.
    An unexpected exception in a stage is recorded as ``failed`` with its type and message, so that a
    campaign goes on.
    """
    clock = _StageClock(log)
    built = Artifacts()
    try:
        profile = clock.run("geometry", blade_profile, config)
        built = Artifacts(profile=profile)
        mesh, fvmesh = clock.run("mesh", _meshes, config, profile)
        built = built.merged(Artifacts(mesh=mesh))
        flow = clock.run("solve", solve_flow, config, fvmesh, log=clock.say, every=every, warm_start=warm_start)
        built = built.merged(Artifacts(flow=flow))      # kept for saving, also when diverged (last finite iterate)
        if flow.status == ConvergenceClass.DIVERGED:
            raise StageFailure(ConvergenceClass.DIVERGED, "solve", flow.message)
        result = clock.run("post", figures_of_merit, config, profile, flow)
    except StageFailure as f:
        built = built.merged(f.built)
        clock.say(f"{f.stage}: {f.status}: {f.reason}")
        return Evaluation(f.status, f.stage, f.reason, model=config.solver.model,
                          cells=None if built.mesh is None else built.mesh.n_cells,
                          iterations=None if built.flow is None else built.flow.iterations,
                          seconds=dict(clock.seconds), artifacts=built)
    clock.say(f"result: {result.status}; {result.message}")
    return dataclasses.replace(result, seconds=dict(clock.seconds), artifacts=built)


class _StageClock:
    """Runs the stages: logs their start and end, times them (``seconds``, s) and records an unexpected
    exception as a ``failed`` stage."""

    def __init__(self, log: Log | None):
        self.say: Log = log or (lambda _line: None)
        self.seconds: dict[str, float] = {}

    def run(self, stage: str, fn: Callable[..., Any], *args, **kwargs) -> Any:
        self.say(f"{stage}: start")
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        except StageFailure:
            raise
        except Exception as exc:  # one bad individual is recorded, not raised
            raise StageFailure("failed", stage, f"unexpected {type(exc).__name__}: {exc}") from exc
        finally:
            self.seconds[stage] = time.perf_counter() - t0
            self.say(f"{stage}: done in {self.seconds[stage]:.2f} s")


# ------------------------------------------------------------------------------------------- geometry
def build_blade(config: Config, tolerance: float = DEFAULT_TOLERANCE) -> BladeResult:
    """The blade of ``config`` and every feasibility constraint (:func:`geometry.evaluate_blade`; the
    profile within ``tolerance``, m, of the exact curves). StageFailure ``failed`` if it cannot be built."""
    try:
        return evaluate_blade(config.blade.blade_spec(), tolerance)
    except (GeometryError, ConfigError, ValueError) as exc:
        raise StageFailure("failed", "geometry", f"blade cannot be built: {exc}", details=(str(exc),)) from exc


def blade_profile(config: Config) -> Profile:
    """Geometry stage: the profile of a feasible blade; StageFailure ``infeasible`` naming each violated
    constraint (``details``: ``"name: reason"``), or ``failed`` (:func:`build_blade`)."""
    result = build_blade(config)
    if not result.feasible or result.profile is None:
        violated = tuple(f"{c.name}: {c.reason}" for c in result.violations)
        raise StageFailure("infeasible", "geometry", f"infeasible blade: {'; '.join(violated) or 'no profile'}",
                           details=violated)
    return result.profile


# ----------------------------------------------------------------------------------------------- mesh
def blade_mesh(config: Config, profile: Profile) -> tuple[Mesh2D, QualityReport]:
    """The hybrid mesh around ``profile`` (``config.mesh_spec()``) and its quality report; StageFailure
    ``failed`` if gmsh fails or a cell is below the quality thresholds (the mesh is then kept in
    ``built``). ``details``: the mesher's message."""
    try:
        mesh = build_mesh(profile, config.mesh_spec())
    except MeshingError as exc:
        raise StageFailure("failed", "mesh", f"{type(exc).__name__}: {exc}", details=(str(exc),)) from exc
    try:
        return mesh, check_quality(mesh)
    except MeshQualityError as exc:
        raise StageFailure("failed", "mesh", f"{type(exc).__name__}: {exc}", details=(str(exc),),
                           built=Artifacts(mesh=mesh)) from exc


def finite_volume_mesh(mesh: Mesh2D) -> FVMesh:
    """The solver's finite-volume mesh of ``mesh``; StageFailure ``failed`` (mesh kept) if it is unusable."""
    try:
        return build_fvmesh(mesh.points, mesh.cells, mesh.boundary)
    except MeshError as exc:
        raise StageFailure("failed", "mesh", f"{type(exc).__name__}: {exc}", details=(str(exc),),
                           built=Artifacts(mesh=mesh)) from exc


def _meshes(config: Config, profile: Profile) -> tuple[Mesh2D, FVMesh]:
    """Mesh stage: the quality-checked hybrid mesh and its finite-volume mesh."""
    mesh, _quality = blade_mesh(config, profile)
    return mesh, finite_volume_mesh(mesh)


# ---------------------------------------------------------------------------------------------- solve
def boundary_conditions(config: Config) -> dict[str, Any]:
    """The paper's conditions (§3.2) on each boundary group of the blade mesh: uniform inlet ``(C0, 0)``
    (with turbulence intensity and viscosity ratio for a turbulence model), outlet at zero mean static
    pressure, symmetry top and bottom, no-slip blade."""
    flow = config.flow
    inlet: dict[str, Any] = {"type": "velocity_inlet", "velocity": (flow.speed, 0.0)}
    if config.solver.model != "laminar":
        inlet.update(intensity=flow.intensity, viscosity_ratio=flow.viscosity_ratio)
    return {INLET: inlet, OUTLET: {"type": "pressure_outlet", "p": 0.0, "mode": "mean"},
            TOP: "symmetry", BOTTOM: "symmetry", BLADE: "wall"}


def simple_settings(config: Config) -> SimpleSettings:
    """:class:`solver.SimpleSettings` from the ``solver:`` section (whose keys are its fields), the blade
    forces monitored, and the stop test waiting for the objectives' monitors, F_Y and C_max (F_X, reported
    but not optimised, settles last: docs/explanation/performance.md, "Stop on the objectives")."""
    return SimpleSettings(**config.solver.settings(), monitor_groups=(BLADE,),
                          stop_monitors=(f"fy:{BLADE}", "c_max"))


def turbulence_model(config: Config) -> SST | None:
    """The ``solver:`` section's turbulence model: :class:`solver.SST` with the section's SST keys, or None
    (``model: laminar``)."""
    s = config.solver
    if s.model != "sst":
        return None
    return SST(wall_treatment=s.wall_treatment, omega_production=s.omega_production,
               omega_wall_flux=s.omega_wall_flux, velocity_gradient=s.sst_velocity_gradient)


def solve_flow(config: Config, fvmesh: FVMesh, *, log: Log | None = None, every: int = 0,
               warm_start: FlowResults | None = None) -> FlowResults:
    """Solve stage: the steady flow on ``fvmesh`` (model, settings and initial field from ``config``;
    from ``warm_start`` mapped to this mesh when given). ``log`` gets the residuals every ``every``
    iterations (0: never). StageFailure ``failed`` if the problem cannot be set up; a diverged solve is
    returned (its status says so)."""
    s = config.solver
    say = log or (lambda _line: None)
    model = turbulence_model(config)
    turbulence = {"turbulence": model} if model is not None else {}
    try:
        problem = Problem.create(fvmesh, boundary_conditions(config), Fluid(config.flow.density,
                                 config.flow.viscosity), **turbulence)
    except (TypeError, ValueError) as exc:
        raise StageFailure("failed", "solve", f"cannot set up the problem: {exc}") from exc
    t0 = time.perf_counter()

    def progress(it, res, _state):
        if every and it % every == 0:
            r = " ".join(f"{k} {v:.2e}" for k, v in res.items())
            say(f"solve: iteration {it}/{s.max_iter}: residuals {r} ({time.perf_counter() - t0:.1f} s)")

    # (the AMG set-up seeds its own random vectors: solver.linalg, so an evaluation is reproducible)
    if warm_start is not None:
        state = mapped_state(problem, warm_start)
    elif s.initial == "potential":
        state = potential_start(problem, (config.flow.speed, 0.0))
    else:
        state = initial_state(problem, (config.flow.speed, 0.0) if s.initial == "freestream" else (0.0, 0.0))
    return solve_steady(problem, simple_settings(config), state, callback=progress)
