"""Settings of the steady pressure-based solver: :class:`SimpleSettings`, the one definition of every option.

Each field carries its one description in ``metadata``: ``doc`` (meaning and unit), and for a number its
documented range (``ge``/``gt``/``le``, with ``why``, the reason for the bounds) — read by
:func:`setting_doc` and by the optimiser's ``solver:`` configuration section, which is generated from these
fields and from :meth:`SimpleSettings.for_blades` (the blade evaluations' defaults). A non-default choice's
evidence is in its decision record under ``docs/decisions/``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Self

from .linalg import SolverSettings

#: Options of the default pressure solver, AMG-preconditioned CG (:func:`solver.linalg._amg_cg`, relative
#: tolerance 0.05): one Ruge–Stüben set-up per steady solve, used as built for the first ``refresh_after``
#: pressure solves, then kept for its interpolation while every level's operator is re-formed from each
#: iteration's p' matrix (``galerkin``, :class:`solver.amg.GalerkinHierarchy`); a new set-up after
#: ``rebuild_every`` solves or after one that took more than ``rebuild_above`` CG iterations.
#: docs/decisions/0012-pressure-amg.md.
PRESSURE_AMG = {"galerkin": True, "rebuild_every": 1000, "rebuild_above": 8, "refresh_after": 10}

_RELAXATION = "an under-relaxation factor"
_ITERATIONS = "iterations; 100 000 on the medium mesh are ~3 h"
_RELATIVE = "a relative change: 1e-12 is below what double precision resolves in a sum of many cells; 1 is 100 %"
_WINDOW = "iterations; a window of more than 10 000 is never filled by a solve of sensible length"
_RESIDUAL = "a scaled residual; below 1e-12 it stalls at round-off"


def _opt(default: Any = dataclasses.MISSING, doc: str = "", *, factory: Any = dataclasses.MISSING,
         **rules: Any) -> Any:
    """A field with its description ``doc`` and range ``rules`` (``ge``, ``gt``, ``le``, ``why``, ``unit``)."""
    return field(default=default, default_factory=factory, metadata={"doc": doc, **rules})


def setting_doc(cls: type, name: str) -> str:
    """The description of field ``name`` of the settings dataclass ``cls`` (its ``metadata["doc"]``)."""
    return next(f for f in dataclasses.fields(cls) if f.name == name).metadata.get("doc", "")


@dataclass(frozen=True)
class SimpleSettings:
    """Settings of the steady pressure-based solver; every option has a default (each field's
    ``metadata["doc"]`` says what it does, its unit and range).

    The defaults suit any flow, the laminar verification cases included; :meth:`for_blades` gives the blade
    evaluations' (Re ~ 1e6, k-omega SST, first cell at y+ ~ 1), which differ in ``pressure_gradient``,
    ``face_velocity``, ``alpha_p``, ``startup_alpha_p_iterations`` and ``limiter_k``.
    """

    algorithm: str = _opt("simplec", "pressure-velocity coupling, solver.simple.ALGORITHMS: simplec (bounded "
                          "SIMPLEC coefficient, docs/decisions/0010-simplec-alpha-u.md) or simple")
    alpha_u: float = _opt(0.95, "momentum under-relaxation factor, in (0, 1] "
                          "(docs/decisions/0010-simplec-alpha-u.md)", gt=0, le=1, why=_RELAXATION)
    alpha_p: float | None = _opt(None, "pressure under-relaxation factor, in (0, 1]; null: 1, no pressure "
                                 "relaxation, SIMPLEC's own value (docs/decisions/0001-blade-pressure-gradient.md)",
                                 gt=0, le=1, why=_RELAXATION)
    startup_iterations: int = _opt(50, "iterations at the start-up relaxation min(alpha_u, startup_alpha_u); 0: "
                                   "no start-up (docs/decisions/0011-start-up-relaxation.md)",
                                   ge=0, le=100_000, why="iterations at the start-up relaxation; 0: off")
    startup_alpha_u: float = _opt(0.7, "momentum under-relaxation of the start-up, in (0, 1]; does nothing at "
                                  "alpha_u <= startup_alpha_u", gt=0, le=1, why=_RELAXATION)
    startup_alpha_p: float | None = _opt(1.0, "SIMPLEC's pressure relaxation during startup_alpha_p_iterations, in "
                                         "(0, 1] (SIMPLE always runs at alpha_p); null: alpha_p throughout "
                                         "(docs/decisions/0001-blade-pressure-gradient.md)",
                                         gt=0, le=1, why=_RELAXATION)
    startup_alpha_p_iterations: int | None = _opt(
        None, "iterations run at startup_alpha_p; null: startup_iterations "
        "(docs/decisions/0001-blade-pressure-gradient.md)",
        ge=0, le=100_000, why="iterations at startup_alpha_p; None: startup_iterations")
    startup_ramp: int = _opt(50, "the start-up's last iterations (at most all of them), in which the momentum "
                             "relaxation rises linearly to alpha_u (solver.simple.iteration_alpha_u); 0: a step "
                             "(docs/decisions/0011-start-up-relaxation.md)", ge=0, le=100_000,
                             why="the start-up's last iterations, rising to alpha_u; 0: a step")
    convection: str = _opt("linear_upwind", "momentum convection scheme, solver.assembly.CONVECTION_SCHEMES: "
                           "linear_upwind (second order, deferred correction, limited gradient) or upwind")
    limiter: str = _opt("venkatakrishnan", "gradient limiter of linear_upwind convection, "
                        "solver.gradient.LIMITERS")
    limiter_k: float = _opt(5.0, "the limiter's K, in (0, 1000]: Venkatakrishnan's eps² = (K h)³ with h in m, "
                            "so a K limits differently at another scale and speed "
                            "(docs/decisions/0003-limiter-k-for-blades.md)", gt=0, le=1000,
                            why="the limiter's K: venkatakrishnan's eps² = (K h)³ depends on the units and the "
                            "scale (the blades' default 100 still limits their boundary layers, h ~ 1e-6 m), "
                            "10-80 for venkatakrishnan_wang")
    limiter_iterations: int | None = _opt(None, "the limiter acts in the first limiter_iterations iterations only, "
                                          "the unlimited linear-upwind reconstruction after them; null: throughout "
                                          "(docs/decisions/0007-limiter-iterations.md)", ge=0, le=100_000,
                                          why="iterations of the limited start-up; None: limited throughout")
    max_iter: int = _opt(2000, "iteration cap", ge=1, le=100_000,
                         why="the blade solves converge in 1 000-3 000 iterations; 100 000 on the medium mesh are "
                         "~3 h")
    tol: float = _opt(1e-6, "scaled-residual tolerance of u, v and continuity: the solve has converged below it",
                      ge=1e-12, le=1, why=_RESIDUAL)
    monitor_tol: float = _opt(1e-5, "with tol: the monitors (forces, C_max) must vary less than this (relative) "
                              "over the last monitor_window iterations", ge=1e-12, le=1, why=_RELATIVE)
    monitor_window: int = _opt(20, "iterations over which monitor_tol is judged", ge=2, le=10_000, why=_WINDOW)
    monitor_groups: tuple[str, ...] = _opt((), "boundary groups whose forces are monitored")
    classify_window: int = _opt(200, "a solve that reaches max_iter is classified (converged, oscillating, "
                                "not_converged) from its monitors over its last classify_window iterations "
                                "(solver.convergence.classify; docs/decisions/0014-convergence-classification.md)",
                                ge=8, le=10_000, why=_WINDOW)
    classify_tol: float = _opt(1e-3, "relative tolerance within which the monitors of a classify_window are "
                               "stationary (converged)", ge=1e-12, le=1, why=_RELATIVE)
    stall_tol: float | None = _opt(1e-4, "the stop test: a solve also stops as converged once every scaled "
                                   "residual is below stall_tol and every monitor is settled within stop_tol "
                                   "(solver.monitors.settled); null: off (docs/decisions/0013-stop-test.md)",
                                   ge=1e-12, le=1, why=_RESIDUAL)
    stop_window: int = _opt(50, "the stop test judges two windows of stop_window iterations", ge=2, le=10_000,
                            why=_WINDOW)
    stop_tol: float = _opt(1e-3, "the stop test's relative tolerance of each monitor to its extrapolated "
                           "converged value", ge=1e-12, le=1, why=_RELATIVE)
    stop_monitors: tuple[str, ...] = _opt((), "the monitors the stop test waits for (c_max, fx:<group>, "
                                          "fy:<group>); empty: all of them")
    early_classify: bool = _opt(True, "stop a solve whose oscillation or drift is established over two "
                                "classification windows with the class it would get at max_iter "
                                "(solver.monitors.established; docs/decisions/0015-early-stop.md)")
    early_periods: float | None = _opt(8.0, "oscillation periods spanned by each window of the early stop, the "
                                       "windows kept within [classify_window / 2, classify_window] iterations; "
                                       "null: windows of classify_window (docs/decisions/0015-early-stop.md)",
                                       gt=0, le=1000, why="oscillation periods spanned by each early-stop window; "
                                       "None: windows of classify_window")
    early_skip: int | None = _opt(100, "start-up iterations skipped before the early stop's two windows (at most "
                                  "one window); null: one window (docs/decisions/0015-early-stop.md)",
                                  ge=0, le=100_000, why="start-up iterations skipped before the early stop's two "
                                  "windows (at most one window); None: one window")
    pressure_gradient: str = _opt("least_squares", "pressure gradient of the momentum source and the Rhie–Chow "
                                  "interpolation, solver.simple.PRESSURE_GRADIENTS: least_squares, green_gauss "
                                  "(skewness-corrected face values), green_gauss_bounded (each face value within "
                                  "its two cells' values) or green_gauss_linear (OpenFOAM's Gauss linear) "
                                  "(docs/decisions/0001-blade-pressure-gradient.md)")
    face_velocity: str = _opt("corrected", "velocity of the Rhie–Chow mass flux through each face, "
                              "solver.pressure.FACE_VELOCITIES: corrected (reconstructed from both cells) or "
                              "bounded (the same, each component within its two cells' values) "
                              "(docs/decisions/0002-bounded-face-velocity.md)")
    green_gauss_relaxation: float = _opt(1.0, "under-relaxation between iterations of the green_gauss pressure "
                                         "gradient's correction, in (0, 1]; 1: none; the converged solution does "
                                         "not depend on it (docs/decisions/0006-green-gauss-relaxation.md)",
                                         gt=0, le=1, why="an under-relaxation factor of the green_gauss pressure "
                                         "gradient's correction")
    blas_threads: int | None = _opt(1, "BLAS threads while iterating (threadpoolctl, when installed); null: leave "
                                    "as is; more threads only contend on the many small vector operations")
    divergence_factor: float = _opt(1e5, "a residual above 1 and this many times its running minimum means "
                                    "divergence", gt=1, le=1e12, why="a residual this many times its minimum is "
                                    "divergence; 1e12 leaves no margin in double precision")
    velocity_limit: float = _opt(1e4, "a cell velocity component above this means divergence, m/s", gt=0, le=1e8,
                                 unit="m/s", why="a cell velocity above it is divergence")
    momentum_solver: SolverSettings = _opt(doc="linear solver of the momentum systems",
                                           factory=lambda: SolverSettings("gauss_seidel", 0.1, 8))
    pressure_solver: SolverSettings = _opt(doc="linear solver of the pressure correction: AMG-preconditioned CG to "
                                           "a relative residual of 0.05 (PRESSURE_AMG; "
                                           "docs/decisions/0012-pressure-amg.md)",
                                           factory=lambda: SolverSettings("amg", 0.05, 50, dict(PRESSURE_AMG)))

    @classmethod
    def for_blades(cls, **changes: Any) -> Self:
        """The blade evaluations' settings (with ``changes``): the bounded Green–Gauss pressure gradient with
        alpha_p 0.7 from iteration 151 (docs/decisions/0001-blade-pressure-gradient.md), the bounded face
        velocity (docs/decisions/0002-bounded-face-velocity.md) and the limiter's K = 100
        (docs/decisions/0003-limiter-k-for-blades.md); the other fields at their defaults."""
        return cls(**{**BLADE_DEFAULTS, **changes})

    @property
    def pressure_relaxation(self) -> float:
        """The pressure under-relaxation applied: ``alpha_p``, or 1 when it is None."""
        return 1.0 if self.alpha_p is None else self.alpha_p


#: The fields in which :meth:`SimpleSettings.for_blades` differs from the defaults.
BLADE_DEFAULTS: dict[str, Any] = {"pressure_gradient": "green_gauss_bounded", "face_velocity": "bounded",
                                  "alpha_p": 0.7, "startup_alpha_p_iterations": 150, "limiter_k": 100.0}
