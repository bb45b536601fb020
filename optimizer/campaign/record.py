"""What a worker runs: one task payload in, one :class:`EvaluationRecord` out (never raising for a bad
blade).

:func:`evaluate_payload` is the ``fn`` the campaign hands to the runner
(:mod:`optimizer.campaign.runner`). The payload is built by :mod:`optimizer.campaign.problem`:

* ``{"kind": "blade", "config": <resolved campaign YAML>, "parameters": {name: value}}`` — runs the
  evaluation pipeline (:func:`optimizer.pipeline.evaluate`) on that blade;
* ``{"kind": "analytic", "problem": name, "x": [...], "delay": s, "failures": {...}}`` — an analytic
  test problem (pymoo's), with injected failures where asked;

plus ``fields`` (optional, blades only: the absolute path of the design's fields file, on a file system
the worker shares with the driver) and the runner's ``deadline_s`` (Unix time after which the runner has
given up: the solve stops at its next iteration and the record says ``timeout``).

The record, :class:`EvaluationRecord` (the driver stores it and judges it with
:meth:`CampaignProblem.assess`; :meth:`EvaluationRecord.to_dict` gives these keys)::

    status        "solved" (figures exist) or why not: "infeasible", "geometry_failed", "mesh_failed",
                  "solve_failed", "diverged", "timeout", "error"
    reason        one line
    class         convergence class of the solve (solver.convergence), None without a solve
    figures       {figure: value or None} as the pipeline reports them (FIGURES of campaign.config)
    window_figures  the same figures recomputed from the window means of their monitors (used for an
                  accepted oscillating solve whatever the whole solve's class)
    monitors      {monitor: {"mean", "amplitude", "drift", "period", "status"}} over the solve's window
    missing       {figure: reason} for figures without a value
    cells, iterations, seconds ({stage: wall s} plus "total" and "cpu", the worker process's CPU time)
    fields        where the payload names a fields file (``payload["fields"]``, added by the driver) and the
                  design was solved: the file written (:mod:`optimizer.campaign.fields`), or None when
                  writing failed (the reason then ends with "fields not kept (...)"; the evaluation counts)

BLAS/OpenMP threads are pinned to one in the worker: evaluations are parallel across processes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optimizer.campaign.status import STAGE_FAILED, EvaluationStatus
from solver.convergence import ConvergenceClass

#: Record status of an evaluation whose solve ran (its figures exist); the driver's assessment turns it into
#: an :class:`EvaluationStatus` under the convergence policy. Every other record status is one already.
SOLVED = "solved"
#: glibc's malloc in a worker process (``mallopt``): allocations up to ``MMAP_THRESHOLD`` bytes come from the
#: heap, and free memory at its top is returned to the kernel only beyond ``TRIM_THRESHOLD`` bytes. These
#: are the largest values glibc's own dynamic thresholds reach on 64-bit (:func:`keep_freed_memory`).
MMAP_THRESHOLD, TRIM_THRESHOLD = 32 * 2**20, 64 * 2**20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3       # mallopt's parameter numbers (malloc.h)
_prepared = False


@dataclass(frozen=True)
class EvaluationRecord:
    """The outcome of one task as the worker reports it (the fields are the module docstring's keys;
    ``convergence`` is the key ``class``). Picklable, so that it crosses to the driver unchanged.

    status: :data:`SOLVED` or an :class:`EvaluationStatus`. convergence: a :class:`ConvergenceClass` or None.
    figures, window_figures: ``{figure: value or None}`` (SI units); monitors: ``{monitor: {"mean",
    "amplitude", "drift", "period", "status"}}``; seconds: ``{stage: s}``.
    """

    status: str
    reason: str = ""
    convergence: ConvergenceClass | None = None
    figures: dict[str, float | None] = field(default_factory=dict)
    window_figures: dict[str, float | None] | None = None
    monitors: dict[str, dict[str, Any]] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    cells: int | None = None
    iterations: int | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    values_from: str | None = None
    fields: str | None = None

    def __post_init__(self) -> None:
        if self.status != SOLVED:
            object.__setattr__(self, "status", EvaluationStatus.parse(self.status))
        if self.convergence is not None:
            object.__setattr__(self, "convergence", ConvergenceClass(self.convergence))

    @property
    def solved(self) -> bool:
        """The solve ran and its figures exist (the driver's assessment decides whether they are used)."""
        return self.status == SOLVED

    def replace(self, **changes: Any) -> EvaluationRecord:
        """A copy with ``changes`` (field names)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The record as JSON-able plain values (the module docstring's keys)."""
        return {"status": str(self.status), "reason": self.reason,
                "class": None if self.convergence is None else str(self.convergence),
                "figures": dict(self.figures), "window_figures": self.window_figures,
                "monitors": {m: {k: (str(v) if k == "status" and v is not None else v) for k, v in info.items()}
                             for m, info in self.monitors.items()},
                "missing": dict(self.missing), "cells": self.cells, "iterations": self.iterations,
                "seconds": dict(self.seconds), "values_from": self.values_from, "fields": self.fields}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> EvaluationRecord:
        """The record of :meth:`to_dict`'s keys (missing keys take their defaults; ``status`` defaults to
        ``error``); ValueError for an unknown status or class."""
        return cls(status=data.get("status") or EvaluationStatus.ERROR, reason=data.get("reason") or "",
                   convergence=data.get("class"), figures=dict(data.get("figures") or {}),
                   window_figures=data.get("window_figures"), monitors=dict(data.get("monitors") or {}),
                   missing=dict(data.get("missing") or {}), cells=data.get("cells"),
                   iterations=data.get("iterations"), seconds=dict(data.get("seconds") or {}),
                   values_from=data.get("values_from"), fields=data.get("fields"))

    @classmethod
    def of(cls, record: EvaluationRecord | Mapping[str, Any]) -> EvaluationRecord:
        """``record`` itself, or the record of a mapping with :meth:`to_dict`'s keys."""
        return record if isinstance(record, cls) else cls.from_dict(record)


class _DeadlinePassed(Exception):
    """Raised from the solver's progress callback to stop a solve the runner has given up on."""


def evaluate_payload(payload: dict) -> EvaluationRecord:
    """Run one task payload (see the module docstring) and return its record."""
    _prepare_process()
    kind = payload.get("kind")
    handler = HANDLERS.get(kind)
    if handler is None:
        return EvaluationRecord(EvaluationStatus.ERROR, f"unknown payload kind {kind!r}; known: {', '.join(HANDLERS)}")
    return handler(payload)


def _prepare_process() -> None:
    """Once per process: BLAS and OpenMP on one thread, freed memory kept for reuse."""
    global _prepared
    if _prepared:
        return
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:            # the runner's worker environment pins them too (OMP_NUM_THREADS=1...)
        pass
    keep_freed_memory()
    _prepared = True


def keep_freed_memory() -> bool:
    """Make glibc keep freed memory for the next allocation instead of returning it to the kernel at once;
    False where there is no glibc ``mallopt`` (nothing is changed).

    A solve allocates and frees cell- and face-sized arrays every iteration (about 130 kB each at the medium
    mesh). dask's nanny starts every worker with ``MALLOC_TRIM_THRESHOLD_=65536`` (its default
    ``distributed.nanny.pre-spawn-environ``), which also freezes glibc's dynamic thresholds: every such array
    is then mapped from the kernel, faulted in page by page, zeroed and unmapped again, and a worker spent
    about half its time in the kernel, each medium evaluation taking twice as long as on its own
    (``python bench/bench_worker_memory.py``). Set at run time, these values hold however the worker was
    started (local cluster, SLURM, PBS)."""
    import ctypes
    import ctypes.util

    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))


# ------------------------------------------------------------------------------------------- blade
def blade_config(payload: dict):
    """The :class:`optimizer.config.Config` of the blade of ``payload``: the resolved campaign's
    ``blade``/``mesh``/``flow``/``solver`` sections with the design's parameters."""
    import yaml

    from optimizer.config import Config

    data = yaml.safe_load(payload["config"])
    data = {k: v for k, v in data.items() if k in Config.model_fields}
    data["blade"] = {**data.get("blade", {}), "parameters": dict(payload["parameters"])}
    return Config.model_validate(data)


def _pipeline() -> Callable[..., Any]:
    """The pipeline's ``evaluate`` (looked up at call time, so that tests can inject failures)."""
    from optimizer.pipeline import evaluate

    return evaluate


def evaluate_blade_payload(payload: dict) -> EvaluationRecord:
    t0, cpu0 = time.perf_counter(), time.process_time()
    try:
        config = blade_config(payload)
    except Exception as exc:     # a payload the driver built from a validated config: a bug, say so
        return EvaluationRecord(EvaluationStatus.ERROR, f"bad payload: {type(exc).__name__}: {exc}")
    deadline = payload.get("deadline_s")
    passed = []

    def watch(_line: str) -> None:
        if deadline is not None and time.time() > deadline:
            passed.append(True)
            raise _DeadlinePassed(f"past the runner's deadline ({time.time() - deadline:.0f} s)")

    ev = _pipeline()(config, log=watch if deadline is not None else None, every=1 if deadline is not None else 0)
    record = record_of(ev, config)
    if passed:
        record = record.replace(status=EvaluationStatus.TIMEOUT,
                                reason=f"stopped at the runner's deadline; {record.reason}")
    elif record.solved and payload.get("fields"):
        record = keep_fields(ev, config, payload["fields"], record)
    # the worker's CPU time: what load does not inflate
    return record.replace(seconds={**record.seconds, "total": time.perf_counter() - t0,
                                   "cpu": time.process_time() - cpu0})


def keep_fields(ev, config, path: str, record: EvaluationRecord) -> EvaluationRecord:
    """Write the fields file of a solved evaluation at ``path`` (:func:`optimizer.campaign.fields.write_fields`)
    and return ``record`` saying so in ``fields`` (the path, or None). A failure (a directory the worker
    cannot reach, a full disk) does not fail the evaluation: its reason says that the fields were not kept."""
    from optimizer.campaign.fields import write_fields

    try:
        return record.replace(fields=str(write_fields(ev, path, c0=config.flow.speed)))
    except Exception as exc:     # the figures are what the campaign needs; the fields are for the report
        return record.replace(fields=None, reason=f"{record.reason}; fields not kept ({type(exc).__name__}: {exc})")


def record_of(ev, config) -> EvaluationRecord:
    """The record of a pipeline :class:`~optimizer.evaluation.Evaluation` (see the module docstring)."""
    from optimizer.campaign.config import FIGURES

    solved = ev.ok
    if solved:
        status = SOLVED
    elif ev.status in (EvaluationStatus.INFEASIBLE, EvaluationStatus.DIVERGED):
        status = EvaluationStatus(ev.status)
    else:
        status = STAGE_FAILED.get(ev.stage or "", EvaluationStatus.ERROR)
    cls = ev.classification
    monitors = {}
    if cls is not None:
        for m in cls.mean:
            monitors[m] = {"mean": _num(cls.mean.get(m)), "amplitude": _num(cls.amplitude.get(m)),
                           "drift": _num(cls.drift.get(m)), "period": _num(cls.period.get(m)),
                           "status": cls.monitor_status.get(m)}
    figures = {f: _num(getattr(ev, f, None)) for f in FIGURES}
    return EvaluationRecord(
        status, ev.message, convergence=ev.status if solved else (cls.status if cls else None), figures=figures,
        window_figures=window_figures(monitors, ev, config) if solved else None, monitors=monitors,
        missing=dict(ev.missing or {}), cells=ev.cells, iterations=ev.iterations,
        seconds={k: float(v) for k, v in (ev.seconds or {}).items()}, values_from=ev.values_from)


def window_figures(monitors: dict, ev, config) -> dict:
    """Figures from the monitors' window means (forces per unit span, C_max) with the pipeline's
    definitions: ``F·span``, C_L (:func:`optimizer.figures.lift_coefficient`, with the evaluation's span and
    profile chord) and C_p,min (:func:`optimizer.figures.pressure_coefficient_min`)."""
    from optimizer.figures import lift_coefficient, pressure_coefficient_min

    fx = (monitors.get("fx:blade") or {}).get("mean")
    fy = (monitors.get("fy:blade") or {}).get("mean")
    c_max = (monitors.get("c_max") or {}).get("mean")
    span, chord, flow = ev.span, ev.chord, config.flow
    out: dict[str, float | None] = {}
    if fx is not None:
        out["fx"] = fx
        out["fx_span"] = fx * span if span else None
    if fy is not None:
        out["fy"] = fy
        out["fy_span"] = fy * span if span else None
        out["c_l"] = lift_coefficient(fy * span, flow.density, flow.speed, chord, span) if span and chord else None
    if c_max is not None:
        out["c_max"] = c_max
        out["cp_min"] = pressure_coefficient_min(c_max, flow.speed)
    return out


def _num(v: Any) -> float | None:
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


# ------------------------------------------------------------------------------------------ analytic
def analytic_problem(name: str, variables: int):
    """pymoo's problem ``name`` (two objectives) with ``variables`` design variables."""
    from pymoo.problems import get_problem

    return get_problem(name, n_var=variables, n_obj=2) if name == "dtlz2" else get_problem(name, n_var=variables)


def hidden_region(variables: int, share: float, seed: int) -> tuple[tuple[int, int], np.ndarray, np.ndarray]:
    """The hidden failing box of :class:`~optimizer.campaign.config.InjectedFailures`: two distinct design
    variables (chosen by ``seed``) and the box's lower and upper corners on them, each side ``sqrt(share)``
    of the unit interval, placed at random inside it."""
    rng = np.random.default_rng([seed, 7919])
    i, j = (int(v) for v in rng.choice(variables, size=2, replace=False))
    side = math.sqrt(share)
    lower = rng.random(2) * (1.0 - side)
    return (i, j), lower, lower + side


def injected_failure(x: list[float], failures: Mapping[str, Any]) -> tuple[str, str] | None:
    """``(status, reason)`` when design ``x`` is to fail under ``failures`` (the dump of
    :class:`~optimizer.campaign.config.InjectedFailures`), else None."""
    region, rate = float(failures.get("region", 0)), float(failures.get("random", 0))
    seed = int(failures.get("seed", 0))
    if region > 0:
        (i, j), lower, upper = hidden_region(len(x), region, seed)
        if lower[0] <= x[i] <= upper[0] and lower[1] <= x[j] <= upper[1]:
            return "diverged", f"injected failure: the hidden region (x{i + 1}, x{j + 1})"
    if rate > 0:
        digest = hashlib.sha256(json.dumps([seed, [float(v) for v in x]]).encode()).digest()
        if int.from_bytes(digest[:8], "big") / 2.0**64 < rate:
            return "solve_failed", f"injected failure: random ({rate:.0%} of designs)"
    return None


def evaluate_analytic_payload(payload: dict) -> EvaluationRecord:
    """One analytic design: ``{"kind": "analytic", "problem", "x", "delay", "failures"}``; figures f1, f2
    and the problem's own constraints g1, g2 (G ≤ 0 feasible)."""
    t0 = time.perf_counter()
    if payload.get("delay"):
        time.sleep(float(payload["delay"]))
    x = [float(v) for v in payload["x"]]
    failure = injected_failure(x, payload.get("failures") or {})
    if failure is not None:
        return EvaluationRecord(failure[0], failure[1], seconds={"total": time.perf_counter() - t0})
    problem = analytic_problem(payload["problem"], len(x))
    out = problem.evaluate(np.array([x]), return_as_dictionary=True)
    figures = {f"f{i + 1}": float(v) for i, v in enumerate(out["F"][0])}
    if problem.n_ieq_constr:
        figures.update({f"g{i + 1}": float(v) for i, v in enumerate(np.atleast_2d(out["G"])[0])})
    return EvaluationRecord(SOLVED, "analytic", convergence=ConvergenceClass.CONVERGED, figures=figures,
                            seconds={"total": time.perf_counter() - t0})


#: Payload kinds and their handlers (STYLE.md §7: a registry keyed by a string).
HANDLERS: dict[str, Callable[[dict], EvaluationRecord]] = {"blade": evaluate_blade_payload,
                                                          "analytic": evaluate_analytic_payload}
