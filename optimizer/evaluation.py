"""The record of one evaluation: :class:`Evaluation`, its :class:`WallDistribution` and :class:`Artifacts`.

These are plain frozen records: :mod:`optimizer.pipeline` fills them, :mod:`optimizer.figures` computes
their figures, :mod:`optimizer.saving` writes them. Their JSON is strict: a non-finite float becomes
``null`` (JSON has no NaN), so a record can always be written and read back.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from solver.convergence import ConvergenceClass

if TYPE_CHECKING:
    from geometry import Profile
    from meshing import Mesh2D
    from solver import FlowResults

#: Stages in pipeline order; :attr:`Evaluation.seconds` has one entry per stage that ran.
STAGES = ("geometry", "mesh", "solve", "post")
#: Statuses of a completed solve (figures available), best first: every convergence class but diverged.
SOLVED = tuple(c for c in ConvergenceClass if c.solved)
#: Statuses of an evaluation without figures.
FAILED = ("infeasible", ConvergenceClass.DIVERGED.value, "failed")
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
        """``{side: {array name: list}}`` per :data:`SIDES`, non-finite values as None."""
        return {side: {k: _finite_list(v) for k, v in self.part(side).items()} for side in SIDES}


@dataclass(frozen=True)
class Artifacts:
    """What an evaluation built, kept in memory for saving and reuse (never serialised).

    profile: the :class:`geometry.Profile`, or None (the blade could not be built).
    mesh: the :class:`meshing.Mesh2D`, kept also when it is below the quality thresholds; or None.
    flow: the :class:`solver.FlowResults`, kept also when the solve diverged (the last finite iterate;
        e.g. a warm start for the next evaluation); or None.
    """

    profile: Profile | None = None
    mesh: Mesh2D | None = None
    flow: FlowResults | None = None

    def merged(self, other: Artifacts) -> Artifacts:
        """These artifacts with those that ``other`` has (not None) added or replaced."""
        present = {f.name: getattr(other, f.name) for f in fields(other) if getattr(other, f.name) is not None}
        return Artifacts(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **present})


@dataclass(frozen=True)
class Evaluation:
    """The outcome of :func:`optimizer.pipeline.evaluate` for one blade (SI units).

    status: ``converged``, ``stationary``, ``oscillating``, ``not_converged`` (the solve ran; figures
        available, see ``docs/explanation/evaluation.md`` for which to trust) or ``infeasible``, ``diverged``,
        ``failed`` (no figures). stage: the stage that failed (:data:`STAGES`), else None.
    message: one line saying why (the failure reason, or the solver's and the classifier's verdict).
    converged: the solver's own convergence test passed.
    classification: :class:`solver.convergence.Classification` of the monitors, or None (no solve).
    fx, fy: force on the blade per unit span, N/m (x along the inflow). fx_span, fy_span: the same
        times the span depth, N. span: the span depth used, m. chord: the profile's chord L, m.
        c_l: lift coefficient of Eq. 23 ``F_Y / (½ rho C0² L span)``. c_max: largest velocity magnitude
        over the cell centres, m/s. cp_min: ``1 - C_max² / C0²``. cp_wall_min: smallest wall C_p (with
        p_ref = inlet mean).
        Where the status is ``oscillating``, fx, fy and c_max are the window means of their monitors
        (``values_from`` says which).
    yplus_max, yplus_mean: y+ of the wall-adjacent cell centres on the blade (face-length weighted mean).
    iterations, cells: solver iterations, mesh cells. seconds: ``{stage: wall-clock s}``.
    missing: ``{figure: reason}`` for every figure that is None although the solve ran.
    wall: :class:`WallDistribution` or None. artifacts: :class:`Artifacts`, the in-memory objects built
        (profile, mesh, flow results); not serialised.
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
    chord: float | None = None
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
    artifacts: Artifacts = field(default_factory=Artifacts, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """The solve ran and its figures exist (any status in :data:`SOLVED`)."""
        return self.status in SOLVED

    def summary(self) -> dict:
        """The scalar results, JSON-ready (the ``--json`` output of ``millfoil evaluate``)."""
        c = self.classification
        return {
            "status": str(self.status), "stage": self.stage, "message": self.message, "converged": self.converged,
            "model": self.model, "F_X": self.fx, "F_Y": self.fy, "F_X_span": self.fx_span,
            "F_Y_span": self.fy_span, "span": self.span, "C_L": self.c_l, "C_max": self.c_max,
            "Cp_min": self.cp_min, "Cp_wall_min": self.cp_wall_min, "yplus_max": self.yplus_max,
            "yplus_mean": self.yplus_mean, "values_from": self.values_from, "iterations": self.iterations,
            "cells": self.cells, "seconds": dict(self.seconds), "missing": dict(self.missing),
            "classification": None if c is None else finite(c.to_dict()),
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


def finite(value: Any) -> Any:
    """``value`` with every non-finite float replaced by None, recursively through dicts, lists and
    tuples (tuples become lists); numpy scalars become Python numbers. JSON has no NaN."""
    if isinstance(value, dict):
        return {k: finite(x) for k, x in value.items()}
    if isinstance(value, list | tuple):
        return [finite(x) for x in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def _finite_list(array: np.ndarray) -> list:
    """An array as a list: strings as they are, numbers as floats with non-finite ones None."""
    if array.dtype.kind in "US":
        return array.tolist()
    return [float(x) if math.isfinite(x) else None for x in np.asarray(array, float)]
