"""The optimisation problem a campaign hands to NSGA-II: design vectors, feasibility, objectives.

The optimiser sees a problem, not a CFD code (STYLE.md §8). A :class:`CampaignProblem` says

* which design variables there are and their bounds (the blade's :class:`geometry.ParameterSpace`: the
  Table 6 ranges with the config's ``blade.bounds`` / ``blade.fixed``; or the analytic problem's box);
* which designs are geometrically feasible (:meth:`check`, milliseconds, before any mesh): the
  constraints of :func:`geometry.evaluate_blade` as G ≤ 0;
* what one evaluation needs (:meth:`payload`, a JSON-able dict for
  :func:`optimizer.campaign.record.evaluate_payload` in a worker) and its content hash (:meth:`key`);
* what an evaluation's record is worth (:meth:`assess`): status under the convergence policy, the
  objectives as the user states them, the vector pymoo minimises (a ``max`` objective negated) and the
  constraint vector. A design without usable values (failed mesh, diverged solve, rejected oscillation,
  timeout...) enters the optimiser as a violated constraint (``evaluation`` = :data:`FAILED_VIOLATION`)
  with objectives :data:`FAILED_VALUE`, so NSGA-II ranks it behind every design with values, feasible
  or not, but never stops on it.

Constraint vector, in order: the geometric constraints (:func:`geometry.constraint_names`; none for the
analytic problem), the analytic problem's own (MW: g1, g2),
one per bound of the ``constraints:`` section (``(value - upper) / scale`` and
``(lower - value) / scale``, ``scale`` = |bound| or 1 when the bound is 0), then ``evaluation``.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from optimizer.campaign.config import MONITOR_OF, CampaignConfig
from optimizer.campaign.record import EvaluationRecord
from optimizer.campaign.status import EvaluationStatus
from solver.convergence import ConvergenceClass

#: Minimised objective value of a design without usable values (pymoo needs finite numbers; it ranks
#: such designs by their constraint violation only).
FAILED_VALUE = 1.0e12
#: The ``evaluation`` constraint of a design without usable values: a violation larger than any design
#: with values can have, so that NSGA-II's constrained domination ranks a failed design behind every
#: evaluated one, infeasible ones included. With 1, a design that violated a CFD constraint by more than
#: 1 (an analytic MW problem's g, a ``constraints:`` bound exceeded by more than its own size) ranked
#: behind a diverged one, and a run drifted into the region where solves fail.
FAILED_VIOLATION = 1.0e12


class EmptySpaceError(ValueError):
    """Rejection sampling found too few feasible designs: the space is (nearly) empty."""


def millfoil_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("millfoil")
    except PackageNotFoundError:    # running from a source tree that is not installed
        return "unknown"


def content_key(content: Mapping[str, Any]) -> str:
    """SHA-256 of the canonical JSON of ``content`` (floats as their shortest exact repr)."""
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class Feasibility:
    """Geometric feasibility of one design: ``values`` (G ≤ 0 feasible, ordered as the problem's geometric
    constraint names) and, when infeasible, ``reason`` naming the violated constraints."""

    values: tuple[float, ...]
    reason: str = ""

    @property
    def feasible(self) -> bool:
        return all(v <= 0.0 for v in self.values)


@dataclass(frozen=True)
class Assessment:
    """What one design is worth to the optimiser (see the module docstring).

    status, reason: the store's status (``ok`` or why not). convergence: the class judged on the chosen
    figures' monitors (None without a solve). objectives: ``{label: value}`` as the user states them
    (None unless ``ok``). minimised: pymoo's F. constraints: ``{name: G}`` in the problem's order.
    """

    status: EvaluationStatus
    reason: str
    convergence: ConvergenceClass | None
    objectives: dict[str, float] | None
    minimised: list[float]
    constraints: dict[str, float]


class CampaignProblem:
    """Common part of the blade and analytic problems (see the module docstring)."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    geometric_names: tuple[str, ...] = ()
    #: Constraints the evaluated problem carries itself (the analytic MW problems' g1, g2), after the
    #: geometric ones.
    own_names: tuple[str, ...] = ()

    def __init__(self, config: CampaignConfig):
        self.config = config
        self.objectives = config.objectives
        self.version = millfoil_version()

    # ----------------------------------------------------------------------------------------- shape
    @property
    def n_var(self) -> int:
        return len(self.names)

    @cached_property
    def objective_labels(self) -> tuple[str, ...]:
        return tuple(o.label for o in self.objectives)

    @cached_property
    def constraint_names(self) -> tuple[str, ...]:
        figure = [name for c in self.config.constraints for name in c.names]
        return (*self.geometric_names, *self.own_names, *figure, "evaluation")

    def pymoo_problem(self):
        """A pymoo ``Problem`` with this shape; it never evaluates (the driver does, see the driver)."""
        from pymoo.core.problem import Problem

        return Problem(n_var=self.n_var, n_obj=len(self.objectives), n_ieq_constr=len(self.constraint_names),
                       xl=self.lower, xu=self.upper)

    # ------------------------------------------------------------------------------- per design
    def parameters(self, x: np.ndarray) -> dict[str, float]:
        """``{name: value}`` of the design variables of ``x``."""
        return {n: float(v) for n, v in zip(self.names, x, strict=True)}

    def stored_parameters(self, x: np.ndarray) -> dict[str, float]:
        """The parameters stored with design ``x`` (the blade's include its fixed ones)."""
        return self.parameters(x)

    def check(self, x: np.ndarray) -> Feasibility:
        """Geometric feasibility (none for the analytic problem)."""
        return Feasibility(())

    def prescreen(self, X: np.ndarray) -> np.ndarray:
        """``(n,)`` bool: cheap necessary conditions of feasibility (none here)."""
        return np.ones(len(X), bool)

    def payload(self, x: np.ndarray) -> dict:
        raise NotImplementedError

    def key(self, x: np.ndarray) -> str:
        raise NotImplementedError

    # ----------------------------------------------------------------------------- assessment
    def infeasible(self, feasibility: Feasibility) -> Assessment:
        """A design that failed the geometric check: never meshed, its G values are the geometry's."""
        figure = {n: 0.0 for n in self.constraint_names[len(self.geometric_names):]}
        return Assessment(EvaluationStatus.INFEASIBLE, feasibility.reason, None, None,
                          [FAILED_VALUE] * len(self.objectives),
                          {**dict(zip(self.geometric_names, feasibility.values, strict=True)), **figure})

    def failed(self, status: str, reason: str, feasibility: Feasibility | None = None,
               convergence: str | None = None) -> Assessment:
        """A feasible design without usable values: ``evaluation`` = :data:`FAILED_VIOLATION`. status: an
        :class:`EvaluationStatus` or its string (ValueError for another)."""
        status = EvaluationStatus.parse(status)
        geometric = feasibility.values if feasibility is not None else (0.0,) * len(self.geometric_names)
        constraints = {n: 0.0 for n in self.constraint_names}
        constraints.update(zip(self.geometric_names, geometric, strict=True))
        constraints["evaluation"] = FAILED_VIOLATION
        return Assessment(status, reason, convergence, None, [FAILED_VALUE] * len(self.objectives), constraints)

    def assess(self, record: EvaluationRecord | Mapping[str, Any],
               feasibility: Feasibility | None = None) -> Assessment:
        """Status, objectives and constraints of an evaluation ``record`` (:class:`.record.EvaluationRecord`,
        or a mapping with its :meth:`~.record.EvaluationRecord.to_dict` keys)."""
        record = EvaluationRecord.of(record)
        if not record.solved:
            return self.failed(record.status, record.reason, feasibility, record.convergence)
        figures_used = [o.figure for o in self.objectives] + [c.figure for c in self.config.constraints]
        cls, why = judge(record, figures_used)
        values = record.figures
        if cls == ConvergenceClass.NOT_CONVERGED:
            return self.failed(EvaluationStatus.NOT_CONVERGED, f"{why}; more iterations needed", feasibility, cls)
        if cls == ConvergenceClass.OSCILLATING:
            verdict = self._oscillating(record, figures_used)
            if verdict:
                return self.failed(EvaluationStatus.OSCILLATING, f"{why}; {verdict}", feasibility, cls)
            values = {**values, **(record.window_figures or {})}
        missing = [f for f in figures_used if values.get(f) is None]
        if missing:
            reasons = record.missing
            text = ", ".join(f"{f} ({reasons.get(f, 'not reported')})" for f in missing)
            return self.failed(EvaluationStatus.SOLVE_FAILED, f"no value for {text}", feasibility, cls)
        return self._accepted(values, cls, why, feasibility)

    def _accepted(self, values: Mapping[str, float], cls: str, why: str,
                  feasibility: Feasibility | None) -> Assessment:
        objectives, minimised = {}, []
        for o in self.objectives:
            v = float(values[o.figure])
            v = abs(v) if o.abs else v
            objectives[o.label] = v
            minimised.append(-v if o.sense == "max" else v)
        constraints = dict(zip(self.geometric_names,
                               feasibility.values if feasibility is not None else (0.0,) * len(self.geometric_names),
                               strict=True))
        constraints.update({n: float(values[n]) for n in self.own_names})
        for c in self.config.constraints:
            v = abs(float(values[c.figure])) if c.abs else float(values[c.figure])
            bounds = [("upper", c.upper), ("lower", c.lower)]
            for name, (kind, bound) in zip(c.names, [b for b in bounds if b[1] is not None], strict=True):
                scale = abs(bound) if bound != 0 else 1.0
                constraints[name] = (v - bound) / scale if kind == "upper" else (bound - v) / scale
        constraints["evaluation"] = 0.0
        return Assessment(EvaluationStatus.OK, why, cls, objectives, minimised, constraints)

    def _oscillating(self, record: EvaluationRecord, figures: list[str]) -> str:
        """Why an oscillating result is rejected under the policy ('' when accepted)."""
        policy = self.config.convergence
        if policy.oscillating == "fail":
            return "oscillating results are rejected (convergence.oscillating = fail)"
        if policy.oscillating == "accept_mean":
            return ""
        worst, name = worst_amplitude(record.monitors, figures)
        if math.isnan(worst):
            return f"monitor {name} has no window figures"
        if worst > policy.max_amplitude:
            return (f"amplitude of {name} is {worst:.2%} of its mean > convergence.max_amplitude "
                    f"{policy.max_amplitude:.2%}")
        return ""


def worst_amplitude(monitors: Mapping[str, Any], figures: list[str]) -> tuple[float, str]:
    """The largest oscillation amplitude relative to its window mean over the monitors of ``figures``
    (what ``convergence.max_amplitude`` limits) and that monitor; ``(nan, monitor)`` where a monitor has no
    window figures, ``(0, '')`` where no figure has a monitor."""
    worst, name = 0.0, ""
    for m in sorted({MONITOR_OF[f] for f in figures if f in MONITOR_OF}):
        info = monitors.get(m) or {}
        mean, amplitude = info.get("mean"), info.get("amplitude")
        if mean is None or amplitude is None:
            return math.nan, m
        rel = amplitude / abs(mean) if mean != 0 else math.inf
        if rel > worst:
            worst, name = rel, m
    return worst, name


def judge(record: EvaluationRecord | Mapping[str, Any], figures: list[str]) -> tuple[ConvergenceClass, str]:
    """The convergence class of a solve judged on the monitors of ``figures`` and the reason.

    The solver's ``converged`` stands. Otherwise the class is the worst of the chosen figures' monitors
    (a blade whose drag drifts while lift and C_max have settled is ``stationary`` for an |F_Y| / C_max
    campaign); a figure without a monitor (wall C_p, y+) falls back to the solve's overall class.
    """
    record = EvaluationRecord.of(record)
    overall = record.convergence or ConvergenceClass.NOT_CONVERGED
    if overall == ConvergenceClass.CONVERGED:
        return overall, "converged"
    monitor_status = {m: (info or {}).get("status") for m, info in record.monitors.items()}
    if any(f not in MONITOR_OF for f in figures):
        return overall, f"class of the whole solve: {overall}"
    classes = {MONITOR_OF[f]: monitor_status.get(MONITOR_OF[f]) for f in figures}
    if any(c is None for c in classes.values()):
        return overall, f"class of the whole solve: {overall}"
    worst = ConvergenceClass.worst(classes.values())
    detail = ", ".join(f"{m} {c}" for m, c in sorted(set(classes.items())))
    return worst, f"{worst} on the chosen figures' monitors ({detail}); whole solve {overall}"


class BladeProblem(CampaignProblem):
    """Blade parameters within the configured space; evaluations through the CFD pipeline."""

    def __init__(self, config: CampaignConfig):
        super().__init__(config)
        from geometry import constraint_names

        self.space = config.blade.space()
        self.names, self.lower, self.upper = self.space.names, self.space.lower, self.space.upper
        self.geometric_names = constraint_names(self.space.mode)
        base = config.model_dump(mode="json", include={"flow", "solver"})
        self._fixed_content = {"mesh": _mesh_dict(config), **base, "version": self.version,
                               "mode": self.space.mode.value, "continuity": self.space.continuity.value}
        self._resolved = config.to_yaml()
        self._checked: dict[bytes, Feasibility] = {}

    def blade_parameters(self, x: np.ndarray) -> dict[str, float]:
        """Every blade parameter (fixed ones included) of design ``x``."""
        return dict(self.space.spec(x).values)

    stored_parameters = blade_parameters

    def check(self, x: np.ndarray) -> Feasibility:
        """The geometric check of design ``x`` (the machined profile in tool-path mode, about 20 ms), kept
        for the designs checked recently: the offspring filter, the surrogate's choice and the driver all
        ask about the same designs."""
        key = np.asarray(x, float).tobytes()
        if key not in self._checked:
            if len(self._checked) >= 4096:
                self._checked.clear()
            self._checked[key] = self._check(x)
        return self._checked[key]

    def _check(self, x: np.ndarray) -> Feasibility:
        from geometry import evaluate_blade

        try:
            result = evaluate_blade(self.space.spec(x))
        except ValueError as exc:              # a parameter out of its domain: cannot be a blade at all
            return Feasibility((1.0,) * len(self.geometric_names), f"not a blade: {exc}")
        reason = "; ".join(f"{c.name}: {c.reason}" for c in result.violations)
        if result.profile is None and not reason:
            reason = "the profile could not be built"
        values = tuple(float(v) for v in result.values)
        if result.profile is None and all(v <= 0 for v in values):
            values = (*values[:-1], 1.0)
        return Feasibility(values, reason)

    def prescreen(self, X: np.ndarray) -> np.ndarray:
        """Cheap necessary conditions (Eq. 21 angles; Eq. 22 cutter-path curvature in tool-path mode),
        ``(n,)`` bool: designs failing them need not be machined to be rejected."""
        from geometry import blade_curves
        from geometry.feasibility import curvature_radius_at_least

        ok = np.ones(len(X), bool)
        for i, x in enumerate(X):
            s = self.space.spec(x)
            if not s["beta1"] <= s["alpha"] <= s["beta1bar"]:
                ok[i] = False
                continue
            if self.space.mode.value == "toolpath":
                try:
                    c = blade_curves(s)
                except ValueError:
                    ok[i] = False
                    continue
                ok[i] = all(curvature_radius_at_least(side, c.radius) for side in (c.suction, c.pressure))
        return ok

    def key(self, x: np.ndarray) -> str:
        return content_key({**self._fixed_content, "parameters": self.blade_parameters(x)})

    def payload(self, x: np.ndarray) -> dict:
        return {"kind": "blade", "config": self._resolved, "parameters": self.blade_parameters(x)}


class AnalyticProblem(CampaignProblem):
    """One of pymoo's analytic problems (``analytic.problem``) on its box, with injected failures where the
    configuration asks for them (see :class:`~optimizer.campaign.config.AnalyticConfig`)."""

    def __init__(self, config: CampaignConfig):
        super().__init__(config)
        from optimizer.campaign.config import ANALYTIC_CONSTRAINTS
        from optimizer.campaign.record import analytic_problem

        a = config.analytic
        box = analytic_problem(a.problem, a.variables)
        self.names = tuple(f"x{i + 1}" for i in range(a.variables))
        self.lower, self.upper = np.asarray(box.xl, float), np.asarray(box.xu, float)
        self.own_names = ANALYTIC_CONSTRAINTS.get(a.problem, ())
        # a campaign without injected failures keeps the keys it had before failures could be injected
        content = a.model_dump(mode="json", exclude={"delay"} if a.failures.any else {"delay", "failures"})
        self._content = {"analytic": content, "version": self.version}

    def key(self, x: np.ndarray) -> str:
        return content_key({**self._content, "x": [float(v) for v in x]})

    def payload(self, x: np.ndarray) -> dict:
        a = self.config.analytic
        return {"kind": "analytic", "problem": a.problem, "x": [float(v) for v in x], "delay": a.delay,
                "failures": a.failures.model_dump(mode="json")}


def make_problem(config: CampaignConfig) -> CampaignProblem:
    return AnalyticProblem(config) if config.analytic is not None else BladeProblem(config)


def initial_population(problem: CampaignProblem, size: int, seed: int, max_draws: int) -> tuple[np.ndarray, int]:
    """``size`` geometrically feasible designs drawn uniformly in the box (rejection sampling, seeded) and
    the number of draws it took; raises :class:`EmptySpaceError` when ``max_draws`` draws per member are
    not enough (the space is nearly empty: narrow the bounds, see ``millfoil space``)."""
    rng = np.random.default_rng(seed)
    found: list[np.ndarray] = []
    draws, budget, batch = 0, max_draws * size, max(4 * size, 64)
    while len(found) < size and draws < budget:
        X = problem.lower + (problem.upper - problem.lower) * rng.random((min(batch, budget - draws), problem.n_var))
        screened = problem.prescreen(X)
        for i, x in enumerate(X):
            if screened[i] and problem.check(x).feasible:
                found.append(x)
                if len(found) == size:
                    X = X[: i + 1]
                    break
        draws += len(X)
    if len(found) < size:
        raise EmptySpaceError(
            f"only {len(found)} of {draws} random designs are geometrically feasible "
            f"({len(found) / max(draws, 1):.3%}); the initial population needs {size}. The space is (nearly) "
            f"empty: narrow blade.bounds (see `millfoil space`) or raise algorithm.initial_draws ({max_draws})")
    return np.array(found), draws


def _mesh_dict(config: CampaignConfig) -> dict:
    import dataclasses

    return dataclasses.asdict(config.mesh_spec())
