"""Which designs the CFD sees in a surrogate-assisted generation: a pool searched on the models, a batch
chosen from it by predicted hypervolume improvement, and a share that bisects towards constraint boundaries
on computed values.

The rule (the reasoning and its evidence: ``docs/decisions/0017-surrogate-infill.md``):

1. **Pool.** NSGA-II runs on the models for a few generations, starting from the campaign's population,
   with the campaign's own operators (SBX, PM): ``pool × batch`` candidates in all. Every candidate first
   meets the **cheap geometric constraints exactly** (:meth:`CampaignProblem.prescreen`: Eq. 21, and
   Eq. 22 on the cutter path in tool-path mode; about a millisecond): one that fails them is never ranked
   by a model. The models rank the rest: predicted objectives, predicted CFD constraints, and the
   predicted probability of failure as a constraint ``p_fail ≤ failure_limit``. The full geometric check
   (:meth:`~CampaignProblem.check`: the machined profile, self-crossing, pieces; 20 ms in tool-path mode)
   runs on each design the choice below reaches, before it is taken: an infeasible design is never sent,
   and the pool costs a few dozen full checks instead of a thousand. With ``coordinate_search`` the
   inner search's best ``batch`` designs also join the pool after a coordinate search on the models
   (:func:`search_coordinates`); with ``front_ends`` too the designs predicted best in each objective, moved
   to minimise that objective alone, so that the front grows beyond its ends.
2. **Boundary** (a quarter of the batch, :data:`BOUNDARY`; only in a run with CFD constraints, a feasible
   front and evaluated designs that violate a constraint yet would improve the front): candidates are the
   midpoints between each front design and the nearest such violating design (:func:`boundary_midpoints`),
   chosen greedily by the hypervolume their predicted objectives add, **without the constraint models**.
   Over generations this bisects onto the constraint boundary the front lies on, which a stationary model
   of the constraint blurs: an evaluated midpoint is either a new front design or the new nearest
   violating one.
3. **Exploitation** (the batch less the other shares): greedily, the candidate whose predicted
   objectives add the most hypervolume to the run's front, the front then taking that prediction as
   if it were computed (the "believer" step of batch Bayesian optimisation), until the share is filled or
   nothing improves.
4. **Exploration** (``exploration·batch``): the same greedy step on the *optimistic* point
   ``mean − κ·std`` (κ = 2): designs whose uncertainty could put them on the front, which is where the
   models learn most. With ``until_feasible: probability``, while no evaluated design meets every
   constraint, the designs most likely to meet them instead (:func:`feasibility_probability`). The
   believer step alone leaves a chosen design's neighbours as optimistic as before, so the share can
   spend several slots on one bet; with ``condition_on_batch`` the models believe every chosen design too
   (:class:`~optimizer.campaign.surrogate.BatchConditioning`): their uncertainty shrinks near it, and so
   do its neighbours' optimism and chance.
5. Slots still empty (nothing is predicted to improve the front) follow NSGA-II's order on the
   predictions: the best constrained non-dominated rank first, within it the candidate farthest from every
   design chosen or evaluated, so a generation always sends a full batch and still moves towards the
   predicted front.

Hypervolume is measured as the run measures it: against the run's reference point, in objectives scaled
so that the front's ideal point is 0 and the reference point 1.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from optimizer.campaign.surrogate import BatchConditioning, Models, Prediction, TrainingData

#: Optimism of the exploration share: the optimistic point is ``mean − KAPPA·std``.
KAPPA = 2.0
#: Share of the batch for the boundary step (midpoints between the front and designs beyond it).
BOUNDARY = 0.25
#: Weight of the sum term in the coordinate search's augmented Chebyshev merit.
AUGMENTED = 0.05


@dataclass
class Proposal:
    """A batch for the CFD. X: ``(batch, d)``; roles: ``boundary``/``exploit``/``explore``/``fill`` per
    design; prediction: the models' output for ``X``; drawn: candidates the search drew, the boundary
    share's included; screened: of those, the distinct ones that meet the cheap necessary conditions (the
    pool); checked: pool designs given the full geometric check on the way to the batch; rejected: of
    those, the infeasible; seconds: ``{"screen"}``."""

    X: np.ndarray
    roles: list[str]
    prediction: Prediction
    drawn: int
    screened: int
    checked: int
    rejected: int
    seconds: dict[str, float] = field(default_factory=dict)


# -------------------------------------------------------------------------------------- hypervolume
def hypervolume_improvement(front: np.ndarray, points: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``(n,)`` hypervolume each of ``points (n, m)`` would add to ``front (k, m)`` (minimisation, against
    ``reference``). Exact and vectorised for two objectives; pymoo's HV per point for more."""
    points = np.atleast_2d(points)
    inside = np.all(points < reference, axis=1)
    out = np.zeros(len(points))
    if not inside.any():
        return out
    front = front[np.all(front < reference, axis=1)] if len(front) else front.reshape(0, points.shape[1])
    if points.shape[1] == 2:
        out[inside] = _improvement_2d(front, points[inside], reference)
        return out
    from pymoo.indicators.hv import HV

    hv = HV(ref_point=reference)
    base = hv(front) if len(front) else 0.0
    for i in np.flatnonzero(inside):
        out[i] = hv(np.vstack([front, points[i]])) - base
    return out


def _improvement_2d(front: np.ndarray, points: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Two objectives: the area under ``reference`` that a point dominates and the front does not. The
    front's attainment surface is a staircase: on ``[b_i, b_{i+1})`` (front f1 values sorted) it stands at
    the lowest f2 of the points with f1 ≤ b_i."""
    if len(front) == 0:
        return np.prod(reference - points, axis=1)
    order = np.argsort(front[:, 0], kind="stable")
    edges = np.append(front[order, 0], reference[0])
    level = np.minimum.accumulate(front[order, 1])
    starts = np.concatenate([[-np.inf], edges[:-1]])
    ends = edges
    levels = np.concatenate([[reference[1]], np.minimum(level, reference[1])])
    lo = np.maximum(starts[None, :], points[:, :1])
    hi = np.minimum(ends[None, :], reference[0])
    width = np.clip(hi - lo, 0.0, None)
    height = np.clip(levels[None, :] - points[:, 1:2], 0.0, None)
    return (width * height).sum(axis=1)


# ------------------------------------------------------------------------------------------- choice
def choose(prediction: Prediction, front: np.ndarray, reference: np.ndarray | None, batch: int, exploration: float,
           failure_limit: float, X: np.ndarray, evaluated: np.ndarray,
           confirm: Callable[[int], bool] = lambda i: True,
           boundary: np.ndarray | None = None, until_feasible: str = "optimistic",
           condition: Callable[[int], tuple[np.ndarray, np.ndarray]] | None = None) -> tuple[np.ndarray, list[str]]:
    """Indices into the pool (rows of ``X``, scaled to the unit box) and their roles (module docstring).

    front: ``(k, m)`` minimised objectives of the run's feasible non-dominated designs; reference: the
    run's hypervolume reference point (minimised; None: from the front and the predictions); evaluated:
    ``(e, d)`` scaled design vectors already evaluated (never chosen again); confirm: the full geometric
    check of a pool row, run on each candidate the choice reaches before it is taken (False: skipped);
    boundary: ``(n,)`` bool, the rows that are boundary candidates (only the boundary share takes them);
    until_feasible: ``probability``: while the run has no feasible design and has modelled constraints, the
    exploration share takes the candidates most likely to meet every constraint and not fail
    (:func:`feasibility_probability`) instead of those with the most optimistic objectives; condition: the
    models taken as observed at a chosen row's predicted values, returning the factors by which every row's
    objective and constraint standard deviations have shrunk since the first choice
    (:meth:`~optimizer.campaign.surrogate.BatchConditioning.condition`); None: only the front believes the
    chosen designs' predictions."""
    n = len(X)
    if n == 0:
        return np.zeros(0, int), []
    lo, hi = _normalisation(front, prediction.mean, reference)
    mean = (prediction.mean - lo) / (hi - lo)
    believed = (front - lo) / (hi - lo) if len(front) else np.zeros((0, mean.shape[1]))
    reference = np.ones(mean.shape[1])
    safe = prediction.p_fail <= failure_limit
    feasible = _predicted_feasible(prediction, failure_limit)
    available = ~_near(X, evaluated)
    boundary = np.zeros(n, bool) if boundary is None else boundary
    chosen: list[int] = []
    roles: list[str] = []
    n_explore = int(round(exploration * batch))
    n_boundary = int(round(BOUNDARY * batch)) if boundary.any() else 0
    seeking = _seeking_feasibility(until_feasible, front, prediction)

    def exploration_view(std: np.ndarray, g_std: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """What the exploration share ranks by, for the models' standard deviations: the optimistic
        points, the candidates it may take, and (while seeking feasibility) their chance of feasibility."""
        optimistic = (prediction.mean - KAPPA * std - lo) / (hi - lo)
        if seeking:
            sure = Prediction(prediction.mean, std, prediction.g_mean, g_std, prediction.p_fail)
            return optimistic, safe, feasibility_probability(sure)
        return optimistic, safe & np.all(prediction.g_mean - KAPPA * g_std <= 0.0, axis=1), None

    optimistic, hopeful, chance = exploration_view(prediction.std, prediction.g_std)
    for role, slots in (("boundary", n_boundary), ("exploit", None), ("explore", n_explore)):
        slots = batch - n_explore - len(chosen) if slots is None else slots
        taken = 0
        while taken < slots:
            points, allowed = {"boundary": (mean, safe & boundary), "exploit": (mean, feasible & ~boundary),
                               "explore": (optimistic, hopeful & ~boundary)}[role]
            candidates = np.flatnonzero(available & allowed)
            if len(candidates) == 0:
                break
            if seeking and role == "explore":
                gain = chance[candidates]
            else:
                gain = hypervolume_improvement(believed, points[candidates], reference)
            if gain.max() <= 0.0:
                break
            pick = int(candidates[int(np.argmax(gain))])
            if not confirm(pick):
                available[pick] = False
                continue
            taken += 1
            chosen.append(pick)
            roles.append(role)
            believed = np.vstack([believed, mean[pick]])
            available &= ~_near(X, X[pick][None])
            if condition is not None:           # the models believe it too: less uncertainty near it
                shrink, g_shrink = condition(pick)
                optimistic, hopeful, chance = exploration_view(prediction.std * shrink, prediction.g_std * g_shrink)
    # empty slots: NSGA-II's order on the predictions (constrained non-dominated rank; within the best rank
    # left, the candidate farthest from every design chosen or evaluated)
    rank = _predicted_rank(prediction, failure_limit)
    while len(chosen) < batch:
        candidates = np.flatnonzero(available & ~boundary)
        if len(candidates) == 0:
            break
        candidates = candidates[rank[candidates] == rank[candidates].min()]
        taken = np.vstack([evaluated, X[chosen]]) if chosen else evaluated
        distance = _min_distance(X[candidates], taken)
        pick = int(candidates[int(np.argmax(distance))])
        if not confirm(pick):
            available[pick] = False
            continue
        chosen.append(pick)
        roles.append("fill")
        available &= ~_near(X, X[pick][None])
    return np.array(chosen, int), roles


def feasibility_probability(prediction: Prediction) -> np.ndarray:
    """``(n,)`` the models' probability that each design meets every modelled constraint and does not fail:
    ``Π Φ(−g_mean/g_std) · (1 − p_fail)``, the constraints taken as independent."""
    from scipy.stats import norm

    log = norm.logcdf(-prediction.g_mean / np.maximum(prediction.g_std, 1e-12)).sum(axis=1)
    return np.exp(log) * (1.0 - prediction.p_fail)


def _predicted_feasible(prediction: Prediction, failure_limit: float) -> np.ndarray:
    """``(n,)`` bool: designs the models' means predict to meet every constraint and not to fail."""
    return (prediction.p_fail <= failure_limit) & np.all(prediction.g_mean <= 0.0, axis=1)


def _seeking_feasibility(until_feasible: str, front: np.ndarray, prediction: Prediction) -> bool:
    """Whether exploration aims at feasibility: asked for, the run has modelled constraints and no design
    has yet met them all."""
    return until_feasible == "probability" and len(front) == 0 and prediction.g_mean.shape[1] > 0


def _predicted_rank(prediction: Prediction, failure_limit: float) -> np.ndarray:
    """Constrained non-dominated rank of the predictions (pymoo's sorting): predicted-feasible designs by
    their predicted objectives first, then the rest by their predicted violation (constraints and the
    failure probability above its limit)."""
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    violation = np.clip(prediction.g_mean, 0.0, None).sum(axis=1) + np.clip(prediction.p_fail - failure_limit, 0.0,
                                                                            None)
    rank = np.empty(len(violation))
    ok = violation <= 0.0
    if ok.any():
        for r, members in enumerate(NonDominatedSorting().do(prediction.mean[ok])):
            rank[np.flatnonzero(ok)[members]] = r
    rank[~ok] = len(violation) + np.argsort(np.argsort(violation[~ok]))
    return rank


def _normalisation(front: np.ndarray, mean: np.ndarray, reference: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The box mapped to the unit square: from the front's ideal point (the predictions' while the run has
    no feasible design) to the run's hypervolume reference point, so that improvements are valued as the
    run's hypervolume values them — a design that extends the front counts as much as one that pushes it
    forward. Where the front reaches beyond the reference point (early in a run) the box grows to hold it
    (its worst values plus a tenth of its range): improving a front nobody has yet brought inside the
    reference point still counts. Without a reference point: the worst of front and predictions plus a
    tenth of their range."""
    base = front if len(front) else mean
    lo = base.min(axis=0)
    worst = np.vstack([base, mean]).max(axis=0) if reference is None or not len(front) else front.max(axis=0)
    grown = worst + 0.1 * np.maximum(worst - lo, 1e-12)
    hi = grown if reference is None else np.maximum(np.asarray(reference, float), grown if len(front) else -np.inf)
    span = np.where(hi > lo, hi - lo, np.maximum(np.abs(hi), 1.0))
    return lo, lo + span


def _near(X: np.ndarray, Y: np.ndarray, tolerance: float = 1e-9) -> np.ndarray:
    """``(len(X),)`` bool: rows of ``X`` within ``tolerance`` (max norm, unit box) of a row of ``Y``."""
    if len(Y) == 0:
        return np.zeros(len(X), bool)
    near = np.zeros(len(X), bool)
    for i in range(0, len(Y), 512):
        near |= (np.abs(X[:, None, :] - Y[None, i:i + 512, :]).max(axis=2) <= tolerance).any(axis=1)
    return near


def _min_distance(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    if len(Y) == 0:
        return np.full(len(X), np.inf)
    out = np.full(len(X), np.inf)
    for i in range(0, len(Y), 512):
        d = np.sqrt(((X[:, None, :] - Y[None, i:i + 512, :]) ** 2).sum(axis=2))
        out = np.minimum(out, d.min(axis=1))
    return out


# --------------------------------------------------------------------------------------------- pool
def _on_models(problem, models: Models, failure_limit: float, feasible: Callable[[np.ndarray], np.ndarray]):
    """The pymoo problem the inner NSGA-II optimises: predicted objectives; constraints: the cheap geometric
    conditions (exact), the predicted CFD constraints, ``p_fail − failure_limit``. It keeps every candidate
    it is asked about after the starting population (``drawn``) and those meeting the cheap conditions
    (``pool``)."""
    from pymoo.core.problem import Problem

    class OnModels(Problem):
        def __init__(self):
            super().__init__(n_var=problem.n_var, n_obj=len(models.objectives),
                             n_ieq_constr=len(models.constraints) + 2, xl=problem.lower, xu=problem.upper)
            self.started, self.drawn, self.pool = False, 0, []

        def _evaluate(self, X, out, *args, **kwargs):
            ok = feasible(X)
            prediction = models.predict(X)
            out["F"] = prediction.mean
            out["G"] = np.column_stack([np.where(ok, -1.0, 1.0), prediction.g_mean,
                                        prediction.p_fail - failure_limit])
            if self.started:                # the starting population is the campaign's own: not drawn
                self.drawn += len(X)
                self.pool.append(X[ok])
            self.started = True

    return OnModels()


def propose(problem, models: Models, population_X: np.ndarray, *, batch: int, pool: int, exploration: float,
            failure_limit: float, front: np.ndarray, reference: np.ndarray | None, evaluated_X: np.ndarray, seed: int,
            crossover, mutation, population_size: int, boundary_X: np.ndarray | None = None,
            coordinate_search: bool = False, until_feasible: str = "optimistic", front_ends: bool = False,
            condition_on_batch: bool = False) -> Proposal:
    """The batch of one surrogate-assisted generation (module docstring).

    problem: the :class:`CampaignProblem`; models: fitted on the store; population_X: the campaign's
    population (the inner search starts there); front: minimised objectives of the run's feasible
    non-dominated designs; reference: the run's hypervolume reference point (minimised); evaluated_X:
    every design already evaluated; seed: of the inner search;
    crossover, mutation: the campaign's settings (``eta``, ``prob``); boundary_X: candidates of the
    boundary share (:func:`boundary_midpoints`, problem units), which meet the cheap geometric conditions
    and the full check like every other candidate; coordinate_search: add the inner search's best designs,
    moved by :func:`search_coordinates` on the models, to the pool; until_feasible: what exploration aims at
    while the run has no feasible design (:func:`choose`, :func:`search_coordinates`); front_ends: the
    coordinate search also moves the ends of the predicted front outwards (:func:`search_coordinates`);
    condition_on_batch: the choice conditions the regressions on each design it takes
    (:class:`~optimizer.campaign.surrogate.BatchConditioning`), so that later designs of the batch are
    ranked by models that already expect it."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.optimize import minimize

    t0 = time.perf_counter()
    cache: dict[bytes, bool] = {}

    def feasible(X: np.ndarray) -> np.ndarray:
        """The cheap necessary conditions (Eq. 21; Eq. 22 in tool-path mode), once per distinct design."""
        todo = [i for i, x in enumerate(X) if x.tobytes() not in cache]
        if todo:
            for i, ok in zip(todo, problem.prescreen(X[todo]), strict=True):
                cache[X[i].tobytes()] = bool(ok)
        return np.array([cache[x.tobytes()] for x in X], bool)

    inner = _on_models(problem, models, failure_limit, feasible)
    generations = max(1, int(np.ceil(pool * batch / population_size)))
    algorithm = NSGA2(pop_size=population_size, sampling=np.asarray(population_X, float),
                      crossover=SBX(eta=crossover.eta, prob=crossover.prob),
                      mutation=PM(eta=mutation.eta, prob_var=mutation.prob), eliminate_duplicates=True)
    result = minimize(inner, algorithm, ("n_gen", generations + 1), seed=seed, verbose=False)
    if coordinate_search and result.pop is not None:
        polished = search_coordinates(models, result.pop.get("X")[:batch], problem.lower, problem.upper,
                                      failure_limit, feasible, front, reference, np.random.default_rng(seed),
                                      until_feasible=until_feasible, front_ends=front_ends)
        inner.pool.append(polished)
        inner.drawn += len(polished)
    pool_X = np.vstack(inner.pool) if inner.pool else np.zeros((0, problem.n_var))
    pool_X = np.unique(pool_X, axis=0)
    boundary = np.zeros(len(pool_X), bool)
    if boundary_X is not None and len(boundary_X):
        extra = boundary_X[feasible(boundary_X)]
        extra = np.unique(extra[~_near(models.scale(extra), models.scale(pool_X))], axis=0) if len(extra) else extra
        pool_X = np.vstack([pool_X, extra])
        boundary = np.append(boundary, np.ones(len(extra), bool))
    prediction = models.predict(pool_X)
    scaled = models.scale(pool_X)
    checks = {"checked": 0, "rejected": 0}

    def confirm(i: int) -> bool:
        """The full geometric check (the machined profile in tool-path mode), only where the choice reaches."""
        checks["checked"] += 1
        ok = problem.check(pool_X[i]).feasible
        checks["rejected"] += not ok
        return ok

    index, roles = choose(prediction, front, reference, batch, exploration, failure_limit, scaled,
                          models.scale(evaluated_X) if len(evaluated_X) else np.zeros((0, problem.n_var)), confirm,
                          boundary, until_feasible,
                          BatchConditioning(models, pool_X).condition if condition_on_batch and len(pool_X) else None)
    chosen = Prediction(*(getattr(prediction, f)[index] for f in ("mean", "std", "g_mean", "g_std", "p_fail")))
    drawn = inner.drawn + (len(boundary_X) if boundary_X is not None else 0)
    return Proposal(pool_X[index], roles, chosen, drawn, len(pool_X), checks["checked"], checks["rejected"],
                    {"screen": time.perf_counter() - t0})


def boundary_midpoints(data: TrainingData, reference: np.ndarray | None, lower: np.ndarray,
                       upper: np.ndarray) -> np.ndarray:
    """Candidates for the boundary step: for every feasible front design, the midpoint (design space) between
    it and the nearest (unit box) evaluated design that violates a modelled constraint and whose computed
    objectives would still improve the run's front. Repeated over generations this is a bisection on
    computed values: the midpoint, once evaluated, is either a new front design or the new nearest violating
    one, so a front that lies on a constraint boundary is approached at the rate a stationary model of the
    constraint cannot give.

    data: what the models learn from (every design that reached a worker); reference: the run's hypervolume
    reference point (minimised). Returns ``(n, d)`` design vectors (problem units); none without both kinds."""
    d = data.X.shape[1]
    ok = ~data.failed
    if data.G.shape[1] == 0 or not ok.any():
        return np.zeros((0, d))
    violation = np.clip(np.nan_to_num(data.G, nan=0.0), 0.0, None).sum(axis=1)
    on_front = ok & (violation <= 0.0) & (data.rank == 0)
    beyond = ok & (violation > 0.0)
    if not on_front.any() or not beyond.any():
        return np.zeros((0, d))
    front = data.F[on_front]
    lo, hi = _normalisation(front, data.F[beyond], reference)
    gain = hypervolume_improvement((front - lo) / (hi - lo), (data.F[beyond] - lo) / (hi - lo),
                                   np.ones(front.shape[1]))
    b = np.flatnonzero(beyond)[gain > 0.0]
    if len(b) == 0:
        return np.zeros((0, d))
    scale = np.where(upper > lower, upper - lower, 1.0)
    a = np.flatnonzero(on_front)
    Xa, Xb = (data.X[a] - lower) / scale, (data.X[b] - lower) / scale
    distance = ((Xa[:, None, :] - Xb[None, :, :]) ** 2).sum(axis=2)
    nearest = b[np.argmin(distance, axis=1)]
    return 0.5 * (data.X[a] + data.X[nearest])


def search_coordinates(models: Models, starts: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                      failure_limit: float, feasible: Callable[[np.ndarray], np.ndarray], front: np.ndarray,
                      reference: np.ndarray | None, rng: np.random.Generator, grid: int = 17,
                      sweeps: int = 3, until_feasible: str = "optimistic", front_ends: bool = False) -> np.ndarray:
    """Each of ``starts`` moved, one variable at a time, to the best value of the models' merit on a grid.

    The merit of a design is the augmented Chebyshev distance (Knowles's ParEGO scalarisation, ρ =
    :data:`AUGMENTED`) of its predicted objectives, scaled as :func:`choose` scales them, from a point a
    tenth of the box beyond the ideal point, weighted along the ray through the start's own prediction:
    each start moves towards the front without crowding onto one point, and an objective that does not set
    the maximum still counts. A predicted constraint violation or a failure probability above
    ``failure_limit`` outweighs any objective. Every second start is moved on the optimistic predictions
    instead (objectives and constraints at mean − κ·std, κ = :data:`KAPPA`, the exploration share's view):
    where the models know nothing of part of a variable's range, that start goes to look. With
    ``until_feasible = "probability"``, while the run has no feasible design and has modelled constraints,
    those starts maximise the probability of meeting every constraint and not failing
    (:func:`feasibility_probability`) instead: a move into an unknown range is made only where it is
    likely to pay, so each such start changes the few variables the models are least sure hold it back,
    rather than every variable at once.

    With ``front_ends``, the start predicted best in each objective (among those predicted feasible, where
    any is) is moved twice more, on the mean and on the optimistic predictions, to minimise that objective
    alone (the others weighted 10⁻³ of it): a ray through a start's own prediction keeps every start where
    it is along the front, so without these moves nothing is aimed beyond the front's ends, where the
    hypervolume gains most and where a constraint model fitted on the front's side is least reliable.

    The first sweep tries ``grid`` values over each variable's whole range, the next ones a grid as wide as
    one step of the previous, centred on the value kept (variables in a random order each sweep). A move
    that breaks the cheap geometric conditions is not made. The whole-range sweep crosses the barriers
    between one variable's basins, which SBX and PM steps around the population rarely cross, wherever the
    models have learnt them (the additive kernel's one-variable terms). Returns the moved designs, problem
    units: ``(n, d)``, and with ``front_ends`` two more per objective after them."""
    X = np.array(starts, float)
    n, d = X.shape
    if n == 0:
        return X
    start = models.predict(X)
    lo, hi = _normalisation(front, start.mean, reference)
    utopia = lo - 0.1 * (hi - lo)                     # so that a start at the ideal point still has a ray
    weight = (start.mean - utopia) / (hi - lo)
    optimistic = np.arange(n) % 2 == 1
    if front_ends:
        X, weight, optimistic = _with_front_ends(X, start, weight, optimistic, failure_limit)
        n = len(X)
    weight = np.repeat(weight, grid + 1, axis=0)
    optimistic = np.repeat(optimistic, grid + 1)
    kappa = np.where(optimistic, KAPPA, 0.0)[:, None]
    seeking = _seeking_feasibility(until_feasible, front, start)

    def merit(Y: np.ndarray) -> np.ndarray:
        p = models.predict(Y)
        scaled = (p.mean - kappa * p.std - utopia) / (hi - lo) / np.maximum(weight, 1e-3)
        risk = (np.clip(p.g_mean - kappa * p.g_std, 0.0, None).sum(axis=1)
                + np.clip(p.p_fail - failure_limit, 0.0, None))
        value = scaled.max(axis=1) + AUGMENTED * scaled.sum(axis=1) + 1e3 * risk
        if seeking:
            chance = -np.log(np.maximum(feasibility_probability(p), 1e-300))
            value = np.where(optimistic, chance + 1e3 * np.clip(p.p_fail - failure_limit, 0.0, None), value)
        return value

    steps = np.linspace(-1.0, 1.0, grid)
    for sweep in range(sweeps):
        # half-width of the grid, in units of the variable's range: the whole range, then one step of the
        # previous grid on either side of the value kept
        half = 0.5 if sweep == 0 else (2.0 / (grid - 1)) ** sweep
        for j in rng.permutation(d):
            span = upper[j] - lower[j]
            if span <= 0.0:
                continue
            centre = np.full(n, 0.5) if sweep == 0 else (X[:, j] - lower[j]) / span
            unit = np.clip(centre[:, None] + half * steps[None, :], 0.0, 1.0)
            trial = np.repeat(X[:, None, :], grid + 1, axis=1)      # column 0 keeps the current value (ties)
            trial[:, 1:, j] = lower[j] + span * unit
            best = np.argmin(merit(trial.reshape(-1, d)).reshape(n, grid + 1), axis=1)
            moved = trial[np.arange(n), best]
            keep = best > 0
            keep[keep] = feasible(moved[keep])
            X[keep] = moved[keep]
    return X


def _with_front_ends(X: np.ndarray, start: Prediction, weight: np.ndarray, optimistic: np.ndarray,
                     failure_limit: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The starts of :func:`search_coordinates` with each objective's end added twice (on the mean and on the
    optimistic predictions), weighted so that its merit is that objective alone."""
    ok = _predicted_feasible(start, failure_limit)
    among = np.flatnonzero(ok) if ok.any() else np.arange(len(X))
    m = weight.shape[1]
    ends = [int(among[np.argmin(start.mean[among, k])]) for k in range(m)]
    alone = np.where(np.eye(m, dtype=bool), 1.0, 1e3)   # merit ≈ objective k: the others divided by 10³
    return (np.vstack([X, X[np.repeat(ends, 2)]]), np.vstack([weight, np.repeat(alone, 2, axis=0)]),
            np.concatenate([optimistic, np.tile([False, True], m)]))
