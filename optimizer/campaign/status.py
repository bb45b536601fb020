"""The status of one evaluation in a campaign: :class:`EvaluationStatus`, the one vocabulary that the
problem, the driver, the store, the progress lines and the report use; and :class:`TaskStatus`, whether the
runner got an answer for a task at all.

``ok`` means the solve ran and its values were accepted under the convergence policy; every other status
says why a design has no usable values (it then enters the optimiser as a violated constraint). The
convergence class of a solve is another vocabulary: :class:`solver.ConvergenceClass`.
"""

from __future__ import annotations

import enum


class EvaluationStatus(enum.StrEnum):
    """Why a design has (``ok``) or has not got usable values; members equal their strings, so the store's
    text column, JSON and comparisons with plain strings keep working.

    ``infeasible``: the geometric check rejected the blade (never meshed). ``geometry_failed``,
    ``mesh_failed``, ``solve_failed``: that stage could not go on (``solve_failed`` also when a chosen
    figure has no value). ``diverged``: the solve blew up. ``not_converged``: the chosen figures still
    drift at the iteration cap. ``oscillating``: rejected under ``convergence.oscillating``. ``timeout``:
    the runner gave up on it. ``worker_lost``: its worker died too often. ``error``: a bug, recorded.
    """

    OK = "ok"
    INFEASIBLE = "infeasible"
    GEOMETRY_FAILED = "geometry_failed"
    MESH_FAILED = "mesh_failed"
    SOLVE_FAILED = "solve_failed"
    DIVERGED = "diverged"
    NOT_CONVERGED = "not_converged"
    OSCILLATING = "oscillating"
    TIMEOUT = "timeout"
    WORKER_LOST = "worker_lost"
    ERROR = "error"

    @property
    def failed(self) -> bool:
        """The design was meshed or tried and has no usable values (neither ``ok`` nor ``infeasible``)."""
        return self not in (EvaluationStatus.OK, EvaluationStatus.INFEASIBLE)

    @classmethod
    def parse(cls, value: str) -> EvaluationStatus:
        """The member of ``value``; ValueError naming the allowed statuses for any other string."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(f"unknown evaluation status {value!r}; allowed: {', '.join(cls)}") from None


#: The pipeline stage that failed -> the status of its evaluation (``post`` failing is a bug).
STAGE_FAILED = {"geometry": EvaluationStatus.GEOMETRY_FAILED, "mesh": EvaluationStatus.MESH_FAILED,
                "solve": EvaluationStatus.SOLVE_FAILED, "post": EvaluationStatus.ERROR}


class TaskStatus(enum.StrEnum):
    """Whether a runner's task returned (:class:`optimizer.campaign.runner.TaskResult`): ``done`` (the evaluation's
    own status is inside its record) or why not. The three failures are evaluation statuses of the same names, which
    the store records for the design."""

    DONE = "done"
    TIMEOUT = EvaluationStatus.TIMEOUT.value
    WORKER_LOST = EvaluationStatus.WORKER_LOST.value
    ERROR = EvaluationStatus.ERROR.value
