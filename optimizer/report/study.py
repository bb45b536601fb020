"""The paper study: what a report of several of the paper's eight cases (Vessaz et al. 2013: design and
tool-path blades, G1, C1, G2 and C2 leading-edge continuity, objectives max |F_Y|, min C_max) sets beside
the paper. Pure functions of :class:`~optimizer.report.run.Run` objects and their
:class:`~optimizer.report.analysis.Point` lists (and, for the wall C_p of the paired designs, of which
fields files exist): no CFD, no geometry, no drawing.

* :func:`table7_rows`: every paper run's Table 7 extremes beside the paper's row, with the relative
  difference, the run's mesh level and the CFD evaluations it spent.
* :func:`fronts_by_case`: each run's C_L–|C_p,min| front, labelled by case (Fig. 9).
* :func:`pair_fronts`: six designs spread along the G1 design front, each paired with the nearest unused
  design of the G1 tool-path front (Fig. 10–13: "as near as possible for both cases").
* :func:`claims`: the paper's three statements on Table 7 (§4) with our figures and a verdict.
* :func:`mesh_dependence`: each case run to its end at two mesh levels, the two |F_Y|–C_max fronts read at
  common C_max bounds: how much the mesh moves a front.

Runs are compared only within one mesh level (:func:`mesh_level`); where two runs of one case share a level,
the first given is used and the others are named in :attr:`StudyLevel.ignored`.

Verdict rules (also in ``docs/explanation/reports.md``). Every figure carries the uncertainty of the
designs that set it: an oscillating design's amplitude, and at least :data:`STEADY_TOLERANCE` (10⁻³) of the
figure, the accuracy the solver's stop test gives a steady one; ``u`` below is the sum of the two designs'
uncertainties, in the figure's unit. A class's test is decided only when it gives the same answer
anywhere within ±u; otherwise it "cannot tell". Over the continuity classes: "does not hold" if any class
does not, else "cannot tell" if any class cannot tell or cannot be tested (a run missing), else "holds".

(a) Lift difference below 4 %: per continuity class with both approaches,
    r = |F_d − F_t| / max(F_d, F_t) of the two runs' max |F_Y| (N); holds if (|F_d − F_t| + u) / max < 4 %,
    does not hold if (|F_d − F_t| − u) / max ≥ 4 %, cannot tell in between (a difference within the
    designs' lift oscillation of the 4 % line).
(b) C_max greater for the tool path: per class, Δ = min C_max(tool path) − min C_max(design) (m/s);
    holds if Δ − u > 0, does not hold if Δ + u ≤ 0, cannot tell in between.
(c) C2 lift about 15 % lower: per approach, d = 1 − F(C2) / max(F(G1), F(C1), F(G2)); holds if d lies in
    [10 %, 20 %] over the whole range the amplitudes allow, does not hold if the whole range lies outside,
    cannot tell otherwise; the claim needs both approaches ("for both"): one approach alone can show that
    it does not hold, never that it holds. The band: "about 15 %" read as 15 ± 5 points; the paper's own
    Table 7 gives 11.3 % (design) and 13.3 % (tool path), both inside.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optimizer.campaign.status import EvaluationStatus
from optimizer.report.analysis import PAPER_TABLE7, TABLE7_COLUMNS, Point, front, paper_row, table7
from optimizer.report.run import Run
from solver.convergence import ConvergenceClass

#: The paper's continuity classes, in Table 7's order.
CONTINUITIES = ("G1", "C1", "G2", "C2")
#: The two approaches: designed blades and blades defined by their milling tool path.
MODES = ("design", "toolpath")
#: The mesh levels, coarsest first.
LEVEL_ORDER = {"coarse": 0, "medium": 1, "fine": 2}
#: Claim (a): the largest relative lift difference between the approaches the paper states (4 %).
LIFT_DIFFERENCE = 0.04
#: Relative accuracy of a steady design's figures: the solver's stop test ends a solve when its F_Y and C_max
#: are within 10⁻³ of their extrapolated fixed point (``stop_tol``, decision 0013), and a stationary solve's
#: monitors vary by at most 10⁻³ over their window (``classify_tol``).
STEADY_TOLERANCE = 1e-3
#: Claim (c): the band read into "about 15 % lower" (15 ± 5 points).
C2_LIFT_DROP = (0.10, 0.20)
#: Designs along the G1 fronts for Fig. 10–13 (the paper shows six).
PAIR_COUNT = 6
#: C_max bounds at which two mesh levels' fronts of one case are read (:func:`mesh_dependence`).
MESH_BOUNDS = 6


class Verdict(enum.StrEnum):
    """What our runs say of one of the paper's statements."""

    HOLDS = "holds"
    FAILS = "does not hold"
    CANNOT_TELL = "cannot tell"


Case = tuple[str, str]


# ------------------------------------------------------------------------------------------- cases
def case(run: Run) -> Case | None:
    """The run's paper case ``(mode, continuity)``, or None when it is not one of the eight (another blade
    family or other objectives: :func:`~optimizer.report.analysis.paper_row`)."""
    return (run.mode, run.continuity) if paper_row(run) is not None else None


def mesh_level(run: Run) -> str:
    """The mesh level the run solved on (``coarse``, ``medium``, ``fine``)."""
    return str((run.config.get("mesh") or {}).get("level", "medium"))


def case_name(c: Case) -> str:
    """``("toolpath", "G1")`` → ``"G1 tool path"`` (Table 7's wording)."""
    return f"{c[1]} {'tool path' if c[0] == 'toolpath' else 'design'}"


def case_label(run: Run) -> str:
    """The run's case and mesh level, ``"G1 tool path (coarse)"``; the run's name for other runs."""
    c = case(run)
    return f"{case_name(c)} ({mesh_level(run)})" if c else run.name


def is_study(runs: list[Run]) -> bool:
    """True when the runs hold at least two of the paper's eight cases (the report's "Paper study")."""
    return len({c for r in runs if (c := case(r)) is not None}) >= 2


def study_order(runs: list[Run]) -> list[int]:
    """Indices of ``runs`` in the paper's order: by mesh level (coarse, medium, fine, then any other), design
    before tool path, G1, C1, G2, C2 (Table 7's rows); runs that are not paper cases after them, as given."""
    def key(i: int):
        c = case(runs[i])
        if c is None:
            return (1, 0, "", 0, 0, i)
        level = mesh_level(runs[i])
        return (0, LEVEL_ORDER.get(level, len(LEVEL_ORDER)), level, MODES.index(c[0]), CONTINUITIES.index(c[1]), i)

    return sorted(range(len(runs)), key=key)


def cfd_evaluations(run: Run) -> int:
    """Designs that reached the CFD (every stored design but the geometrically infeasible ones)."""
    return sum(d.row.status != EvaluationStatus.INFEASIBLE for d in run.designs)


@dataclass(frozen=True)
class StudyLevel:
    """The paper runs of one mesh level: ``cases`` maps each case to its (run, points) — the first run of
    that case given —, ``ignored`` names the other runs of a case already present."""

    level: str
    cases: dict[Case, tuple[Run, list[Point]]]
    ignored: tuple[str, ...] = ()


def study_levels(runs: list[Run], pts: list[list[Point]]) -> list[StudyLevel]:
    """The paper runs grouped by mesh level (coarse, medium, fine, then any other, in that order)."""
    grouped: dict[str, dict[Case, tuple[Run, list[Point]]]] = {}
    ignored: dict[str, list[str]] = {}
    for r, p in zip(runs, pts, strict=True):
        c = case(r)
        if c is None:
            continue
        cases = grouped.setdefault(mesh_level(r), {})
        if c in cases:
            ignored.setdefault(mesh_level(r), []).append(r.name)
        else:
            cases[c] = (r, p)
    return [StudyLevel(lv, grouped[lv], tuple(ignored.get(lv, ())))
            for lv in sorted(grouped, key=lambda lv: (LEVEL_ORDER.get(lv, len(LEVEL_ORDER)), lv))]


# ---------------------------------------------------------------------------------------- Table 7
@dataclass(frozen=True)
class Table7Row:
    """One paper run's Table 7 row beside the paper's. ours: {quantity: (value, convergence class, design
    number) or None} (:func:`~optimizer.report.analysis.table7`); paper: the paper's row in
    :data:`~optimizer.report.analysis.TABLE7_COLUMNS` order (|F_Y| N, C_L, C_max m/s, |C_p,min|)."""

    run: Run
    case: Case
    level: str
    evaluations: int
    ours: dict[str, tuple[float, str, int] | None]
    paper: tuple[float, ...]

    def paper_value(self, quantity: str) -> float:
        return self.paper[[q for _, q, _ in TABLE7_COLUMNS].index(quantity)]

    def relative(self, quantity: str) -> float | None:
        """(ours − paper) / paper, or None while the run has no feasible design."""
        v = self.ours[quantity]
        return None if v is None else (v[0] - self.paper_value(quantity)) / self.paper_value(quantity)


def table7_rows(runs: list[Run], pts: list[list[Point]]) -> list[Table7Row]:
    """Table 7 side by side for every paper run, in the order given."""
    return [Table7Row(r, c, mesh_level(r), cfd_evaluations(r), table7(r, p), paper_row(r))
            for r, p in zip(runs, pts, strict=True) if (c := case(r)) is not None]


# ----------------------------------------------------------------------------------------- Fig. 9
def case_colour(c: Case) -> str:
    """A fixed matplotlib colour per case (the same case has the same colour at every mesh level)."""
    return f"C{CONTINUITIES.index(c[1]) * 2 + MODES.index(c[0])}"


def fronts_by_case(runs: list[Run], pts: list[list[Point]]) -> list[tuple[str, Case, str, list[Point]]]:
    """Fig. 9: ``(label, case, mesh level, front)`` of each paper run, the front in the C_L–|C_p,min| plane
    (max C_L, min |C_p,min|) sorted by |C_p,min|."""
    return [(case_label(r), c, mesh_level(r), front(p, "cpmin", "cl"))
            for r, p in zip(runs, pts, strict=True) if (c := case(r)) is not None]


# ------------------------------------------------------------------------------------ Fig. 10–13
@dataclass(frozen=True)
class Pair:
    """One of the designs along the G1 design front and its nearest tool-path design: ``distance`` in the
    normalised (C_L, |C_p,min|) plane (:func:`normaliser`); toolpath None when that front ran out."""

    index: int
    design: Point
    toolpath: Point | None
    distance: float | None


def normaliser(pts: list[Point]) -> Callable[[Point], np.ndarray]:
    """Map a point to (C_L, |C_p,min|) scaled so that ``pts`` span [0, 1] on each axis (an axis without
    spread is left at its offset)."""
    xy = np.array([[p.cl, p.cpmin] for p in pts], float).reshape(-1, 2)
    lo = xy.min(axis=0) if len(xy) else np.zeros(2)
    span = np.ptp(xy, axis=0) if len(xy) else np.ones(2)
    span = np.where(span > 0, span, 1.0)
    return lambda p: (np.array([p.cl, p.cpmin], float) - lo) / span


def spread(f: list[Point], count: int, scale: Callable[[Point], np.ndarray]) -> list[Point]:
    """``count`` designs of the front ``f`` (in front order) evenly spread by arc length in the ``scale``
    plane, ends included: for each of ``count`` equally spaced arc lengths, the nearest design not yet
    taken. All of them when the front has no more than ``count``."""
    if len(f) <= count:
        return list(f)
    xy = np.array([scale(p) for p in f])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    taken: list[int] = []
    for target in np.linspace(0.0, s[-1], count):
        order = np.argsort(np.abs(s - target), kind="stable")
        taken.append(next(int(i) for i in order if i not in taken))
    return [f[i] for i in sorted(taken)]


def pair_fronts(design: list[Point], toolpath: list[Point], count: int = PAIR_COUNT) -> list[Pair]:
    """Fig. 10–13: ``count`` designs spread along the ``design`` front (:func:`spread`), each with a distinct
    design of the ``toolpath`` front, both fronts normalised together (:func:`normaliser`). Pairs are made
    closest first: of all (chosen design, unused tool-path design) couples the nearest is paired, then the
    nearest of the rest, and so on, so each pair is mutually nearest among what is left. Returned in front
    order of the design side."""
    scale = normaliser(design + toolpath)
    chosen = spread(design, count, scale)
    if not chosen:
        return []
    a = np.array([scale(p) for p in chosen])
    b = np.array([scale(p) for p in toolpath]).reshape(-1, 2)
    dist = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    match: dict[int, tuple[int, float]] = {}
    for flat in np.argsort(dist, axis=None, kind="stable"):
        i, j = np.unravel_index(flat, dist.shape)
        if i not in match and j not in {m for m, _ in match.values()}:
            match[int(i)] = (int(j), float(dist[i, j]))
    return [Pair(k + 1, p, toolpath[match[k][0]] if k in match else None, match[k][1] if k in match else None)
            for k, p in enumerate(chosen)]


@dataclass(frozen=True)
class G1Pairs:
    """Fig. 10–13 at one mesh level: the G1 design and tool-path runs, their C_L–|C_p,min| fronts and the
    pairs (:func:`pair_fronts`)."""

    level: str
    design: Run
    toolpath: Run
    design_front: list[Point]
    toolpath_front: list[Point]
    pairs: list[Pair]


def g1_pairs(level: StudyLevel, count: int = PAIR_COUNT) -> G1Pairs | None:
    """The G1 design and tool-path runs of ``level`` with their fronts and pairs, or None when the level
    lacks one of them."""
    d, t = level.cases.get(("design", "G1")), level.cases.get(("toolpath", "G1"))
    if d is None or t is None:
        return None
    fd, ft = front(d[1], "cpmin", "cl"), front(t[1], "cpmin", "cl")
    return G1Pairs(level.level, d[0], t[0], fd, ft, pair_fronts(fd, ft, count))


def kept_fields(run: Run, p: Point) -> Path | None:
    """The design's fields file (``RUN/fields/<key>.npz``) when the campaign kept it."""
    from optimizer.campaign.fields import fields_path

    path = fields_path(run.directory, p.design.key)
    return path if path.is_file() else None


# ---------------------------------------------------------------------------------------- claims
def steadiness(p: Point, quantity: str = "fy") -> str:
    """The convergence class of a design as the claims table shows it: ``steady`` (converged or stationary),
    ``oscillating ±A`` (A: the amplitude of ``quantity`` in its unit) or ``excluded (status)`` for a design
    whose values were rejected."""
    if p.status != EvaluationStatus.OK:
        return f"excluded ({p.status})"
    if p.design.row.convergence == ConvergenceClass.OSCILLATING:
        unit = {"fy": " N", "cmax": " m/s"}.get(quantity, "")
        return f"oscillating ±{p.value('d' + quantity):.3g}{unit}"
    return "steady"


@dataclass(frozen=True)
class Used:
    """A design a verdict rests on: its run and case, design number, value of the compared quantity (N for
    |F_Y|, m/s for C_max), convergence class (:func:`steadiness`) and ``beyond``: the best rejected design
    of that run whose value would have beaten it (number, class, value), or None."""

    run: str
    case: str
    number: int
    value: float
    convergence: str
    beyond: tuple[int, str, float] | None = None

    def describe(self) -> str:
        text = f"{self.case}: {self.run} #{self.number} ({self.convergence})"
        if self.beyond:
            text += f"; beaten only by excluded #{self.beyond[0]} ({self.beyond[1]}, {self.beyond[2]:.4g})"
        return text


@dataclass(frozen=True)
class Claim:
    """One of the paper's statements at one mesh level: ``ours`` and ``paper`` the figures it rests on
    (ours from the runs, the paper's from its Table 7 for the same classes), the verdict and the designs
    used."""

    key: str
    statement: str
    level: str
    ours: str
    paper: str
    verdict: Verdict
    used: tuple[Used, ...] = field(default=())


def extreme(pts: list[Point], quantity: str, best_max: bool) -> Point | None:
    """The feasible accepted design with the largest (``best_max``) or smallest value of ``quantity``."""
    feasible = [p for p in pts if p.feasible]
    if not feasible:
        return None
    return (max if best_max else min)(feasible, key=lambda p: p.value(quantity))


def used(run: Run, c: Case, pts: list[Point], quantity: str, best_max: bool) -> Used | None:
    """The design that sets ``quantity``'s extreme in ``run``, with the best excluded design beyond it."""
    p = extreme(pts, quantity, best_max)
    if p is None:
        return None
    better = [x for x in pts if x.status != EvaluationStatus.OK
              and (x.value(quantity) > p.value(quantity) if best_max else x.value(quantity) < p.value(quantity))]
    best = (max if best_max else min)(better, key=lambda x: x.value(quantity)) if better else None
    beyond = (best.design.number, steadiness(best, quantity), best.value(quantity)) if best else None
    return Used(run.name, case_name(c), p.design.number, p.value(quantity), steadiness(p, quantity), beyond)


def decide(low: float, high: float, holds: Callable[[float], bool]) -> Verdict:
    """The verdict of a test on a figure known to lie in [low, high] (a monotone test: checking the ends
    suffices): holds at both ends, fails at both, or cannot tell."""
    a, b = holds(low), holds(high)
    return Verdict.HOLDS if a and b else Verdict.FAILS if not a and not b else Verdict.CANNOT_TELL


def combine(verdicts: list[Verdict], expected: int) -> Verdict:
    """Over the ``expected`` classes a claim speaks of, ``verdicts`` those that could be tested: does not hold
    if any does not; cannot tell if any cannot or one could not be tested (a run is missing); holds."""
    if Verdict.FAILS in verdicts:
        return Verdict.FAILS
    return Verdict.CANNOT_TELL if len(verdicts) < expected or Verdict.CANNOT_TELL in verdicts else Verdict.HOLDS


def _paper(c: Case, quantity: str) -> float:
    """The paper's Table 7 value of ``quantity`` for case ``c``."""
    return PAPER_TABLE7[c][[q for _, q, _ in TABLE7_COLUMNS].index(quantity)]


def _extremes(level: StudyLevel, quantity: str, best_max: bool):
    """Per continuity class with both approaches and a value of ``quantity`` in each: ``(continuity,
    (design run, points, its extreme point), (tool-path run, points, its extreme point))``."""
    for k in CONTINUITIES:
        d, t = level.cases.get(("design", k)), level.cases.get(("toolpath", k))
        if not (d and t):
            continue
        ed, et = extreme(d[1], quantity, best_max), extreme(t[1], quantity, best_max)
        if ed is not None and et is not None:
            yield k, (*d, ed), (*t, et)


def _uncertainty(p: Point, quantity: str) -> float:
    """How far the true value of ``quantity`` of an accepted design may lie from its figure: the oscillation
    amplitude, and at least the :data:`STEADY_TOLERANCE` of the figure (in the figure's unit)."""
    if p.status != EvaluationStatus.OK:
        return 0.0
    return max(p.value("d" + quantity), STEADY_TOLERANCE * abs(p.value(quantity)))


def claim_lift_difference(level: StudyLevel) -> Claim:
    """(a) The lift difference between the two approaches is always below 4 % (module docstring: rule)."""
    verdicts, ours, paper, designs = [], [], [], []
    for k, (rd, pd, fd), (rt, pt, ft) in _extremes(level, "fy", True):
        top, diff = max(fd.fy, ft.fy), abs(fd.fy - ft.fy)
        u = _uncertainty(fd, "fy") + _uncertainty(ft, "fy")
        verdicts.append(decide(max(diff - u, 0.0), diff + u, lambda d, top=top: d / top < LIFT_DIFFERENCE))
        ours.append(f"{k} {100 * diff / top:.1f} % (±{100 * u / top:.1f})" if u else f"{k} {100 * diff / top:.1f} %")
        a, b = _paper(("design", k), "fy"), _paper(("toolpath", k), "fy")
        paper.append(f"{k} {100 * abs(a - b) / max(a, b):.1f} %")
        designs += [used(rd, ("design", k), pd, "fy", True), used(rt, ("toolpath", k), pt, "fy", True)]
    return Claim("a", "The lift difference between the design and tool-path approaches is always below 4 % "
                 "(within the ±5 N fluctuation of the stalled solves).", level.level, _join(ours), _join(paper),
                 combine(verdicts, len(CONTINUITIES)), tuple(designs))


def claim_cmax_toolpath(level: StudyLevel) -> Claim:
    """(b) C_max (and |C_p,min|) is always greater for the tool-path approach (module docstring: rule)."""
    verdicts, ours, paper, designs = [], [], [], []
    for k, (rd, pd, cd), (rt, pt, ct) in _extremes(level, "cmax", False):
        delta, u = ct.cmax - cd.cmax, _uncertainty(cd, "cmax") + _uncertainty(ct, "cmax")
        verdicts.append(decide(delta - u, delta + u, lambda d: d > 0.0))
        ours.append(f"{k} {ct.cmax:.2f} vs {cd.cmax:.2f} m/s (|C_p,min| {ct.cpmin:.2f} vs {cd.cpmin:.2f})")
        paper.append(f"{k} {_paper(('toolpath', k), 'cmax'):.2f} vs {_paper(('design', k), 'cmax'):.2f} m/s")
        designs += [used(rt, ("toolpath", k), pt, "cmax", False), used(rd, ("design", k), pd, "cmax", False)]
    return Claim("b", "C_max (and |C_p,min|) is always greater for the tool-path approach: min C_max(tool path) "
                 "> min C_max(design) in every continuity class.", level.level, _join(ours), _join(paper),
                 combine(verdicts, len(CONTINUITIES)), tuple(designs))


def claim_c2_lift(level: StudyLevel) -> Claim:
    """(c) With C2 continuity the maximum lift is about 15 % lower for both approaches (module docstring:
    rule and band)."""
    verdicts, ours, paper, designs = [], [], [], []
    for mode in MODES:
        c2 = level.cases.get((mode, "C2"))
        others = [(k, level.cases[(mode, k)]) for k in CONTINUITIES[:3] if (mode, k) in level.cases]
        best = [(k, r, p, x) for k, (r, p) in others if (x := extreme(p, "fy", True)) is not None]
        low = extreme(c2[1], "fy", True) if c2 else None
        if low is None or not best:
            continue
        k, r, p, top = max(best, key=lambda b: b[3].fy)
        ul, ut = _uncertainty(low, "fy"), _uncertainty(top, "fy")
        drop = 1.0 - low.fy / top.fy
        lo_end, hi_end = 1.0 - (low.fy + ul) / max(top.fy - ut, 1e-12), 1.0 - max(low.fy - ul, 0.0) / (top.fy + ut)
        verdicts.append(decide(lo_end, hi_end, lambda d: C2_LIFT_DROP[0] <= d <= C2_LIFT_DROP[1]))
        name = "design" if mode == "design" else "tool path"
        ours.append(f"{name} {100 * drop:.1f} % (C2 vs {k})")
        ref = max(CONTINUITIES[:3], key=lambda j, mode=mode: _paper((mode, j), "fy"))
        paper.append(f"{name} {100 * (1 - _paper((mode, 'C2'), 'fy') / _paper((mode, ref), 'fy')):.1f} % "
                     f"(C2 vs {ref})")
        designs += [used(c2[0], (mode, "C2"), c2[1], "fy", True), used(r, (mode, k), p, "fy", True)]
    verdict = combine(verdicts, len(MODES))      # "for both approaches": one alone cannot show it holds
    return Claim("c", "With C2 continuity the maximum lift is about 15 % lower for both approaches: "
                 "1 − F_Y,max(C2) / max over G1, C1, G2 of F_Y,max within 10–20 %.", level.level, _join(ours),
                 _join(paper), verdict, tuple(designs))


def _join(parts: list[str]) -> str:
    return "; ".join(parts) if parts else "no class with the runs it needs"


def claims(runs: list[Run], pts: list[list[Point]]) -> list[Claim]:
    """The three claims at each mesh level that holds finished paper runs (:func:`study_levels`). A run still
    going, or stopped before its end, has a partial front, which would test the claim on an unfinished
    search: it is left out, as if it had not been given."""
    finished = [(r, p) for r, p in zip(runs, pts, strict=True) if r.campaign.state == "finished"]
    out = []
    for level in study_levels([r for r, _ in finished], [p for _, p in finished]):
        out += [claim_lift_difference(level), claim_cmax_toolpath(level), claim_c2_lift(level)]
    return out


# -------------------------------------------------------------------------------- mesh dependence
@dataclass(frozen=True)
class MeshComparison:
    """One case run to its end at two mesh levels (``levels``, coarser first; ``runs`` in the same order):
    at each C_max bound (m/s) of ``bounds``, the design of each run's |F_Y|–C_max front with the largest
    |F_Y| among those with C_max at most the bound (``best[i] = (coarser, finer)``; None where a front has
    none)."""

    case: Case
    levels: tuple[str, str]
    runs: tuple[Run, Run]
    bounds: tuple[float, ...]
    best: tuple[tuple[Point | None, Point | None], ...]

    def gap(self, i: int) -> float | None:
        """finer − coarser |F_Y| (N) at bound ``i``, or None where either front has no design within it."""
        a, b = self.best[i]
        return None if a is None or b is None else b.fy - a.fy

    def difference(self, i: int) -> float | None:
        """The :meth:`gap` as a share of the coarser run's |F_Y|."""
        gap = self.gap(i)
        return None if gap is None else gap / self.best[i][0].fy


def mesh_dependence(runs: list[Run], pts: list[list[Point]], count: int = MESH_BOUNDS) -> list[MeshComparison]:
    """Every case with finished runs at two successive mesh levels (coarse and medium, medium and fine),
    its two fronts read at ``count`` C_max bounds spread evenly from the larger of the two fronts' lowest
    C_max to the smaller of their C_max at the largest |F_Y| (the range both fronts cover). The runs are
    different searches as well as different meshes: a difference mixes the two; a front that moves by
    much more than the runs' scatter is the mesh's doing."""
    finished = [(r, p) for r, p in zip(runs, pts, strict=True) if r.campaign.state == "finished"]
    levels = study_levels([r for r, _ in finished], [p for _, p in finished])
    out = []
    for coarse, fine in zip(levels, levels[1:], strict=False):
        for c in sorted(coarse.cases.keys() & fine.cases.keys(), key=lambda c: (CONTINUITIES.index(c[1]),
                                                                               MODES.index(c[0]))):
            (ra, pa), (rb, pb) = coarse.cases[c], fine.cases[c]
            fa, fb = front(pa), front(pb)
            if not fa or not fb:
                continue
            lo, hi = max(fa[0].cmax, fb[0].cmax), min(fa[-1].cmax, fb[-1].cmax)
            bounds = tuple(float(b) for b in np.linspace(lo, hi, count)) if hi > lo else (lo,)
            best = tuple((_best_within(fa, b), _best_within(fb, b)) for b in bounds)
            out.append(MeshComparison(c, (coarse.level, fine.level), (ra, rb), bounds, best))
    return out


def _best_within(f: list[Point], bound: float) -> Point | None:
    """The design of front ``f`` (sorted by C_max, |F_Y| rising along it) with the largest |F_Y| among those
    with C_max ≤ ``bound``."""
    within = [p for p in f if p.cmax <= bound]
    return within[-1] if within else None
