"""What a report computes from a run's store: points in the paper's planes, the front, the Table 7 summary,
the gallery's designs, the designs whose fields are kept and the campaign's health per generation. Pure
functions of a :class:`Run` (and of which fields files exist): no CFD, no geometry (the gallery rebuilds its
few blades in :mod:`optimizer.report.figures`).

The paper's planes (Vessaz et al. 2013, Fig. 9–11, Eq. 23): |F_Y| (N, the force on the span 0.04 L: the
``fy_span`` figure) against C_max (m/s), and C_L against |C_p,min|. An ``oscillating`` design's values are
its monitors' window means; its amplitude becomes an error bar: the ``fy:blade`` monitor's amplitude scaled
like F_Y to the span and to C_L, the ``c_max`` monitor's amplitude for C_max and, through
C_p,min = 1 − C_max²/C0², 2 C_max ΔC_max / C0² for |C_p,min|.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optimizer.campaign.store import non_dominated
from optimizer.figures import pressure_coefficient_min
from optimizer.report.run import Design, Run
from solver.convergence import ConvergenceClass

#: Table 7 of Vessaz et al. (2013): max |F_Y| [N], max C_L, min C_max [m/s], min |C_p,min| per case.
PAPER_TABLE7 = {
    ("design", "G1"): (84.14, 4.20, 12.15, 0.48), ("toolpath", "G1"): (88.16, 4.41, 12.25, 0.50),
    ("design", "C1"): (87.00, 4.35, 11.66, 0.36), ("toolpath", "C1"): (84.30, 4.21, 12.08, 0.46),
    ("design", "G2"): (88.00, 4.40, 11.73, 0.38), ("toolpath", "G2"): (84.74, 4.23, 12.49, 0.56),
    ("design", "C2"): (78.02, 3.90, 11.73, 0.37), ("toolpath", "C2"): (76.40, 3.82, 12.80, 0.64),
}
#: Columns of the Table 7 summary: (label, quantity, best is max?).
TABLE7_COLUMNS = (("Max |F_Y| [N]", "fy", True), ("Max C_L [-]", "cl", True), ("Min C_max [m/s]", "cmax", False),
                  ("Min |C_p,min| [-]", "cpmin", False))


@dataclass(frozen=True)
class Point:
    """One design in the paper's planes. fy: |F_Y| over the span, N; cl: C_L; cmax: C_max, m/s; cpmin:
    |C_p,min|; d*: the oscillation amplitude of each (0 unless the design's convergence class is oscillating)."""

    design: Design
    fy: float
    cl: float
    cmax: float
    cpmin: float
    dfy: float = 0.0
    dcl: float = 0.0
    dcmax: float = 0.0
    dcpmin: float = 0.0

    @property
    def status(self) -> str:
        return self.design.row.status

    @property
    def feasible(self) -> bool:
        return self.design.row.feasible

    def value(self, name: str) -> float:
        return getattr(self, name)


def speed(run: Run) -> float:
    """C0, the inlet speed of the run's flow (m/s)."""
    return float((run.config.get("flow") or {}).get("speed", 10.0))


def points(run: Run) -> list[Point]:
    """Every design of ``run`` that has the figures of the paper's planes (solved designs, accepted or not)."""
    c0 = speed(run)
    out = []
    for d in run.designs:
        f = d.row.figures or {}
        fy_span = f.get("fy_span", f.get("fy"))
        if fy_span is None or f.get("c_max") is None or f.get("c_l") is None:
            continue
        fy, cl, cmax = abs(fy_span), abs(f["c_l"]), f["c_max"]
        cpmin = abs(f["cp_min"]) if f.get("cp_min") is not None else abs(pressure_coefficient_min(cmax, c0))
        if not all(np.isfinite([fy, cl, cmax, cpmin])):
            continue
        # a design the stop test found converged keeps its values and has no amplitude, whatever its monitors'
        # window says: a solve that converged within the window (200 iterations) has its start-up in it
        m = (d.row.monitors or {}) if d.row.convergence == ConvergenceClass.OSCILLATING else {}
        amp_f = _amplitude(m, "fy:blade")
        scale = abs(fy_span / f["fy"]) if f.get("fy") else 1.0
        amp_c = _amplitude(m, "c_max")
        out.append(Point(d, fy, cl, cmax, cpmin, amp_f * scale, amp_f * abs(f["c_l"] / f["fy"]) if f.get("fy") else 0.0,
                         amp_c, 2 * cmax * amp_c / c0**2))
    return out


def _amplitude(monitors: dict, name: str) -> float:
    m = monitors.get(name) or {}
    a = m.get("amplitude")
    return float(a) if a is not None and np.isfinite(a) and m.get("status") == ConvergenceClass.OSCILLATING else 0.0


def front(pts: list[Point], x: str = "cmax", y: str = "fy") -> list[Point]:
    """Non-dominated feasible points for min ``x``, max ``y`` (:func:`optimizer.campaign.store.non_dominated`),
    sorted by ``x``."""
    feas = sorted((p for p in pts if p.feasible), key=lambda p: (p.value(x), -p.value(y)))
    if not feas:
        return []
    keep = non_dominated(np.array([[p.value(x), -p.value(y)] for p in feas], float))
    return [p for p, k in zip(feas, keep, strict=True) if k]


def table7(run: Run, pts: list[Point]) -> dict[str, tuple[float, str, int] | None]:
    """The run's extremes among feasible accepted designs: {quantity: (value, convergence class, design
    number)} for each of :data:`TABLE7_COLUMNS` (None when no design is feasible yet)."""
    feas = [p for p in pts if p.feasible]
    out = {}
    for _label, q, best_max in TABLE7_COLUMNS:
        if not feas:
            out[q] = None
            continue
        p = (max if best_max else min)(feas, key=lambda p, q=q: p.value(q))
        out[q] = (p.value(q), p.design.row.convergence or "-", p.design.number)
    return out


def paper_row(run: Run) -> tuple[float, ...] | None:
    """The paper's Table 7 row of the run's blade family when the run optimises the paper's objective pair."""
    figures = [(o.get("figure"), o.get("sense")) for o in run.objectives]
    if run.analytic or figures != [("fy", "max"), ("c_max", "min")]:
        return None
    return PAPER_TABLE7.get((run.mode, run.continuity))


def gallery(pts: list[Point], count: int = 6) -> list[Point]:
    """About ``count`` designs spread along the |F_Y|–C_max front (evenly in front order, ends included)."""
    f = front(pts)
    if len(f) <= count:
        return f
    index = np.unique(np.round(np.linspace(0, len(f) - 1, count)).astype(int))
    return [f[i] for i in index]


def fields_designs(run: Run, pts: list[Point], count: int = 3) -> tuple[list[tuple[Point, Path]], list[Point]]:
    """The designs whose fields the report draws: up to ``count`` of the |F_Y|–C_max front's designs that have
    a fields file (``RUN/fields/<key>.npz``, :mod:`optimizer.campaign.fields`), the two ends and the middle
    in front order, with their files; and the front's designs without a file (not kept). Where no design
    of this front has a file (a campaign with other objectives), the feasible designs that have one,
    by C_max, take its place."""
    from optimizer.campaign.fields import fields_path

    f = front(pts)
    kept = [(p, fields_path(run.directory, p.design.key)) for p in f]
    kept = [(p, path) for p, path in kept if path.is_file()]
    if not kept:
        others = sorted((p for p in pts if p.feasible), key=lambda p: p.cmax)
        kept = [(p, path) for p in others if (path := fields_path(run.directory, p.design.key)).is_file()]
    if len(kept) > count:
        index = np.unique(np.round(np.linspace(0, len(kept) - 1, count)).astype(int))
        kept = [kept[i] for i in index]
    have = {p.design.key for p, _ in kept}
    missing = [p for p in f if p.design.key not in have and not fields_path(run.directory, p.design.key).is_file()]
    return kept, missing


@dataclass(frozen=True)
class Health:
    """Per generation (index = generation): hypervolume, feasible share of offspring, cache hits, counts by
    status and by convergence class of the designs first asked for in that generation; wall times of all
    solved evaluations (s). A surrogate-assisted run adds the models' out-of-sample error on each batch
    (``model_error``: ``{objective: RMSE of predicted against computed, in standard deviations of the
    training values}``; 1 is what predicting their mean would give), the batch's failed share, computed
    and predicted (``failures``: ``{"observed", "predicted"}``), and the driver's seconds fitting the models
    and screening the candidates (``seconds``: ``{"fit", "screen"}``); None where a generation has none
    (the initial population, NSGA-II's own offspring; a plain run's are all empty)."""

    generations: list[int]
    hypervolume: list[float | None]
    feasible_share: list[float | None]
    cache_hits: list[int]
    by_status: dict[str, list[int]]
    by_class: dict[str, list[int]]
    times: list[float]
    model_error: dict[str, list[float | None]] = field(default_factory=dict)
    failures: dict[str, list[float | None]] = field(default_factory=dict)
    seconds: dict[str, list[float | None]] = field(default_factory=dict)


def health(run: Run) -> Health:
    gens = sorted({d.row.generation for d in run.designs} | {g.generation for g in run.generations})
    stored = {g.generation: g for g in run.generations}
    status = {g: Counter(d.row.status for d in run.designs if d.row.generation == g) for g in gens}
    cls = {g: Counter(d.row.convergence for d in run.designs if d.row.generation == g and d.row.convergence)
           for g in gens}
    statuses = sorted({s for c in status.values() for s in c})
    classes = sorted({s for c in cls.values() for s in c})
    times = [d.row.wall_seconds for d in run.designs if d.row.wall_seconds is not None]
    search = {g: (stored[g].search or {}) if g in stored else {} for g in gens}
    labels = list(dict.fromkeys(k for g in gens for k in search[g].get("error") or {}))
    model_error = {k: [(search[g].get("error") or {}).get(k) for g in gens] for k in labels}
    failures, seconds = {}, {}
    if labels:
        failures = {k: [(search[g].get("failures") or {}).get(k) for g in gens] for k in ("observed", "predicted")}
        seconds = {k: [(search[g].get("seconds") or {}).get(k) for g in gens] for k in ("fit", "screen")}
    return Health(gens, [stored[g].hypervolume if g in stored else None for g in gens],
                  [stored[g].feasible_share if g in stored else None for g in gens],
                  [stored[g].cache_hits if g in stored else 0 for g in gens],
                  {s: [status[g][s] for g in gens] for s in statuses},
                  {c: [cls[g][c] for g in gens] for c in classes}, times, model_error, failures, seconds)


@dataclass(frozen=True)
class Convergence:
    """A run's progress against its cost: after each design that reached the CFD (store order), how many
    had (``evaluations``), the CPU hours they took (``cpu_hours``: the workers' CPU time, their wall time
    where a record has none) and the hypervolume of every feasible design stored so far (``hypervolume``)
    in the report's common normalisation (:func:`convergence`)."""

    run: Run
    evaluations: np.ndarray
    cpu_hours: np.ndarray
    hypervolume: np.ndarray


def convergence(runs: list[Run]) -> list[Convergence]:
    """Hypervolume against CFD evaluations for ``runs`` with the same objectives, on one scale: each
    minimised objective mapped so that the best and worst values over the feasible designs of **all** the
    runs are 0 and 1, against the reference point (1.1, …, 1.1). Failed evaluations count; geometrically
    infeasible designs never reached the CFD and do not."""
    from pymoo.indicators.hv import HV

    feasible = [np.array(d.row.minimised, float) for r in runs for d in r.designs if d.row.feasible]
    out = []
    if not feasible:
        return [Convergence(r, np.zeros(0), np.zeros(0), np.zeros(0)) for r in runs]
    F = np.array(feasible)
    lo, hi = F.min(axis=0), F.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    reference = np.full(F.shape[1], 1.1)
    hv = HV(ref_point=reference)
    for r in runs:
        counted = [d for d in r.designs if d.row.status != "infeasible"]
        evaluations = np.arange(1, len(counted) + 1, dtype=float)
        seconds = [(d.row.seconds or {}).get("cpu") or d.row.wall_seconds or 0.0 for d in counted]
        scaled = ((np.array(d.row.minimised, float) - lo) / span if d.row.feasible else None for d in counted)
        values = hypervolume_trace((f if f is not None and np.all(f < reference) else None for f in scaled), hv)
        out.append(Convergence(r, evaluations, np.cumsum(seconds) / 3600.0, values))
    return out


def hypervolume_trace(points: Iterable[np.ndarray | None], hv: Callable[[np.ndarray], float]) -> np.ndarray:
    """After each of ``points`` (minimised objectives; None for one that adds nothing: failed, infeasible or
    beyond the reference point), the hypervolume ``hv`` of the non-dominated set of the points so far (0
    before the first). The front is kept up to date point by point and ``hv`` evaluated only when it
    changes: a point that a front point dominates leaves front and value as they were. The front's rows
    stay in arrival order, so each value is that of ``hv`` on the whole set's non-dominated rows."""
    values, front, level = [], None, 0.0
    for f in points:
        if f is not None:
            f = np.asarray(f, float)
            if front is None:
                front = f[None, :]
                level = float(hv(front))
            elif not np.any(np.all(front <= f, axis=1) & np.any(front < f, axis=1)):
                beaten = np.all(f <= front, axis=1) & np.any(f < front, axis=1)
                front = np.vstack([front[~beaten], f])
                level = float(hv(front))
        values.append(level)
    return np.array(values)
