"""Where a generation's offspring come from: plain NSGA-II mating, or the surrogate-assisted search.

Both send only **geometrically feasible** designs to the CFD. Plain mode redraws an offspring that fails
a cheap constraint (Eq. 21, Eq. 22, self-crossing, a tool path that machines into pieces): the check runs
inside pymoo's mating loop, beside its duplicate elimination, so the operators draw again until the
generation is full (pymoo's mating gives up after 100 rounds; a generation then has fewer offspring).
The surrogate mode (:mod:`optimizer.campaign.infill`) checks its whole candidate pool the same way.

Each step returns the offspring and a ``search`` record stored with the generation::

    method     "nsga2" or "surrogate"; "initial" for the initial population (drawn uniformly in the box,
               rejection-sampled to geometric feasibility: the draws are logged when it is drawn)
    drawn      candidates drawn by the operators (plain: the mating; surrogate: the search on the models)
    screened   of those, the geometrically feasible ones
    batch      designs sent to the CFD
    fallback   (surrogate campaigns) why this generation took NSGA-II's own offspring instead
  surrogate only (where "screened" counts the distinct candidates meeting the cheap necessary conditions,
  Eq. 21 and, in tool-path mode, Eq. 22, and the full check runs only where the choice reaches):
    checked, rejected  pool designs given the full geometric check, and of those the infeasible
    training   designs the regressions were fitted on; theta: {model: log-hyperparameters}
               (theta_recent: the same for the models that learn from the newest designs, where
               :func:`portfolio` splits the batch)
    predicted  {key: {"mean": [...], "std": [...], "p_fail": p, "role": boundary|exploit|explore|fill,
               and "models": ranked|recent where the batch is split}}
    error      after the batch is evaluated: {objective label: RMSE / standard deviation of the training
               values} over the batch's designs with values (out of sample: none was in the training set)
    failures   {"predicted": mean p_fail, "observed": share of the batch without values}
    seconds    {"fit", "screen"}
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from optimizer.campaign.status import EvaluationStatus
from optimizer.campaign.store import EvaluationRow, Store

#: Designs with values the models need before they choose offspring; before that (a run whose initial
#: designs nearly all failed) a generation takes NSGA-II's own offspring and its search record says why.
MIN_TRAINING = 4

#: The portfolio's members (see :func:`portfolio`) and the search-record key of each one's hyperparameters.
MEMBERS = ("ranked", "recent")
THETA_KEYS = ("theta", "theta_recent")


def portfolio(batch: int, settings) -> list[tuple[int, int]]:
    """How a generation's batch is chosen: ``[(recent, designs), ...]``, one entry per set of models.

    With ``recent`` newest designs in the training set and a ``recent_share`` below 1, the batch is split:
    models fitted on the best-ranked designs alone choose ``1 - recent_share`` of it, and models that also
    learn from the newest choose the rest (at least one design each). The best-ranked models are optimistic
    away from the front, which carries a search across the barriers between a variable's basins; the
    models that learn from the newest are calibrated, which keeps a search from chasing a region they
    misjudge (decision 0017)."""
    recent, share = settings.recent, settings.recent_share
    if recent == 0 or share >= 1.0 or batch < 2:
        return [(recent, batch)]
    if share <= 0.0:
        return [(0, batch)]
    with_recent = min(batch - 1, max(1, round(share * batch)))
    return [(0, batch - with_recent), (recent, with_recent)]


class FeasibleOffspring:
    """pymoo's duplicate elimination followed by the problem's exact geometric check: the mating loop
    keeps drawing until it has enough offspring that pass both. Counts what it was shown."""

    def __init__(self, problem):
        from pymoo.core.duplicate import DefaultDuplicateElimination

        self.problem = problem
        self.duplicates = DefaultDuplicateElimination()
        self.drawn = self.screened = 0

    def do(self, pop, *args, **kwargs):
        pop = self.duplicates.do(pop, *args, **kwargs)
        if kwargs.get("return_indices") or len(pop) == 0:
            return pop
        X = pop.get("X")
        ok = self.problem.prescreen(X)
        ok = np.array([bool(s) and self.problem.check(x).feasible for s, x in zip(ok, X, strict=True)], bool)
        self.drawn += len(X)
        self.screened += int(ok.sum())
        return pop[ok]


class PlainOffspring:
    """NSGA-II's own offspring, redrawn until geometrically feasible."""

    method = "nsga2"

    def __init__(self, problem):
        self.filter = FeasibleOffspring(problem)

    def eliminate_duplicates(self):
        return self.filter

    #: Random designs drawn for the initial population (set by the driver when it draws one).
    initial_draws: int | None = None

    def ask(self, algorithm, g: int):
        self.filter.drawn = self.filter.screened = 0
        offspring = algorithm.ask()
        n = 0 if offspring is None else len(offspring)
        if not algorithm.is_initialized:
            return offspring, {"method": "initial", "drawn": self.initial_draws or n, "screened": n, "batch": n}
        return offspring, {"method": self.method, "drawn": self.filter.drawn, "screened": self.filter.screened,
                           "batch": n}

    def review(self, search: dict, rows: Sequence[EvaluationRow]) -> dict:
        return search


class SurrogateOffspring(PlainOffspring):
    """Offspring chosen by :func:`optimizer.campaign.infill.propose` on models fitted from the store."""

    method = "surrogate"

    def __init__(self, problem, config, store: Store):
        super().__init__(problem)
        self.problem, self.config, self.store = problem, config, store
        self.modelled = [n for n in problem.constraint_names[len(problem.geometric_names):] if n != "evaluation"]

    def ask(self, algorithm, g: int):
        if not algorithm.is_initialized:           # the initial population: drawn as in plain mode
            return super().ask(algorithm, g)
        from pymoo.core.population import Population
        from threadpoolctl import threadpool_limits

        from optimizer.campaign.infill import boundary_midpoints, propose
        from optimizer.campaign.surrogate import Models

        a = self.config.algorithm
        t0 = time.perf_counter()
        data, front, evaluated = training_data(self.store, self.problem, g, self.modelled)
        with_values = int((~data.failed).sum())
        if with_values < MIN_TRAINING:
            return self._fallback(algorithm, g, f"the models need {MIN_TRAINING} designs with values, the store "
                                               f"has {with_values}")
        last = self.store.last_generation()
        warm = (last.search or {}) if last is not None else {}
        reference = self.store.campaign().reference
        boundary_X = boundary_midpoints(data, reference, self.problem.lower, self.problem.upper)
        # reading the store counts with the fit: both are the price of choosing on models
        fitted, proposals, fit_seconds = [], [], time.perf_counter() - t0
        taken = evaluated
        for k, (recent, count) in enumerate(portfolio(a.batch, a.surrogate)):
            t_fit = time.perf_counter()
            models = Models(self.problem.lower, self.problem.upper, self.problem.objective_labels, self.modelled,
                            kernel=a.surrogate.kernel, warp_prior_variance=a.surrogate.warp_prior_variance)
            # one BLAS thread: the matrices are small, and a thread count's summation order would otherwise
            # change the fitted models in their last bits between a run and its resumption on another machine
            with threadpool_limits(limits=1):
                models.fit(data, a.surrogate.training, warm.get(THETA_KEYS[k]), recent=recent,
                           initial=a.surrogate.initial, hyperparameter_initial=a.surrogate.hyperparameter_initial)
                fit_seconds += time.perf_counter() - t_fit
                # each member searches as long as one choosing the whole batch would (the inner search's
                # length is pool × batch draws), and never proposes what another member already took
                proposal = propose(self.problem, models, algorithm.pop.get("X"), batch=count,
                                   pool=-(-a.surrogate.pool * a.batch // count),
                                   exploration=a.surrogate.exploration, failure_limit=a.surrogate.failure_limit,
                                   front=front, reference=reference, evaluated_X=taken, seed=_seed(a.seed, g, k),
                                   crossover=a.crossover, mutation=a.mutation, population_size=a.population,
                                   boundary_X=boundary_X, coordinate_search=a.surrogate.coordinate_search,
                                   until_feasible=a.surrogate.until_feasible,
                                   front_ends=a.surrogate.front_ends,
                                   condition_on_batch=a.surrogate.condition_on_batch)
            fitted.append(models)
            proposals.append(proposal)
            taken = np.vstack([taken, proposal.X]) if len(proposal.X) else taken
        X = np.vstack([p.X for p in proposals])
        if len(X) == 0:
            return self._fallback(algorithm, g, f"none of the {sum(p.drawn for p in proposals)} candidates drawn "
                                               "on the models is geometrically feasible")
        predicted = {}
        for k, proposal in enumerate(proposals):
            p = proposal.prediction
            for i, x in enumerate(proposal.X):
                predicted[self.problem.key(x)] = {"mean": [float(v) for v in p.mean[i]],
                                                  "std": [float(v) for v in p.std[i]],
                                                  "p_fail": float(p.p_fail[i]), "role": proposal.roles[i],
                                                  **({"models": MEMBERS[k]} if len(proposals) > 1 else {})}
        search = {"method": self.method, "drawn": sum(p.drawn for p in proposals),
                  "screened": sum(p.screened for p in proposals), "checked": sum(p.checked for p in proposals),
                  "rejected": sum(p.rejected for p in proposals), "batch": len(X),
                  "training": fitted[0].training_size, "predicted": predicted, "scale": _training_scale(data),
                  "seconds": {"fit": fit_seconds, "screen": sum(p.seconds["screen"] for p in proposals)}}
        search.update({THETA_KEYS[k]: models.theta() for k, models in enumerate(fitted)})
        return Population.new("X", X), search

    def _fallback(self, algorithm, g: int, why: str):
        """NSGA-II's own offspring for this generation (the batch size is the same), saying why."""
        offspring, search = super().ask(algorithm, g)
        return offspring, {**search, "method": "nsga2", "fallback": why}

    def review(self, search: dict, rows: Sequence[EvaluationRow]) -> dict:
        """Add the out-of-sample error of the models on the batch just evaluated (see the module docstring)."""
        predicted = search.get("predicted")
        if not predicted:
            return search
        batch = [r for r in rows if r.key in predicted]
        ok = [r for r in batch if r.ok]
        scale = search.get("scale") or []
        error = {}
        for i, label in enumerate(self.problem.objective_labels):
            if ok and i < len(scale) and scale[i] > 0:
                residual = [predicted[r.key]["mean"][i] - r.minimised[i] for r in ok]
                error[label] = float(np.sqrt(np.mean(np.square(residual))) / scale[i])
        failures = {"predicted": float(np.mean([predicted[r.key]["p_fail"] for r in batch])) if batch else None,
                    "observed": (len(batch) - len(ok)) / len(batch) if batch else None}
        return {**search, "error": error, "failures": failures}


def make_offspring(problem, config, store: Store) -> PlainOffspring:
    """The offspring step of ``config.algorithm.method``."""
    if config.algorithm.method == "surrogate":
        return SurrogateOffspring(problem, config, store)
    return PlainOffspring(problem)


def training_data(store: Store, problem, generation: int, modelled: Sequence[str]):
    """What the models learn from: every design that reached a worker before ``generation`` (rows in the
    deterministic order generation, key — the store's own order depends on which worker finished first).
    Returns the :class:`~optimizer.campaign.surrogate.TrainingData`, the minimised objectives of the run's
    feasible non-dominated designs, and every evaluated design vector (infeasible ones included)."""
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    from optimizer.campaign.surrogate import TrainingData

    rows = sorted((r for r in store.evaluations() if r.generation < generation), key=lambda r: (r.generation, r.key))
    evaluated = np.array([r.x for r in rows], float).reshape(len(rows), problem.n_var)
    reached = [r for r in rows if r.status != EvaluationStatus.INFEASIBLE]
    m = len(problem.objective_labels)
    X = np.array([r.x for r in reached], float).reshape(len(reached), problem.n_var)
    failed = np.array([not r.ok for r in reached], bool)
    F = np.array([r.minimised if r.ok else [np.nan] * m for r in reached], float).reshape(len(reached), m)
    G = np.array([[r.constraints.get(n, np.nan) if r.ok else np.nan for n in modelled] for r in reached],
                 float).reshape(len(reached), len(modelled))
    rank = np.full(len(reached), 10**6, float)
    violation = np.array([sum(max(v, 0.0) for v in r.constraints.values()) for r in reached], float)
    good = ~failed & (violation <= 0.0)
    if good.any():
        rank[good] = _ranks(F[good], NonDominatedSorting())
    bad = ~failed & ~good
    if bad.any():
        rank[bad] = 10**5 + violation[bad] / max(violation[bad].max(), 1e-300)
    front = F[good][_ranks(F[good], NonDominatedSorting()) == 0] if good.any() else np.zeros((0, m))
    data = TrainingData(X, failed, F, G, rank, np.arange(len(reached), dtype=float))
    return data, front, evaluated


def _ranks(F: np.ndarray, sorter) -> np.ndarray:
    rank = np.empty(len(F))
    for r, front in enumerate(sorter.do(F)):
        rank[front] = r
    return rank


def _training_scale(data) -> list[float]:
    """Standard deviation of each objective over the designs with values (the error's unit)."""
    F = data.F[~data.failed]
    return [float(v) for v in F.std(axis=0)] if len(F) > 1 else []


def _seed(seed: int, generation: int, member: int = 0) -> int:
    """The inner search's seed: a function of the campaign's seed, the generation and the portfolio member
    only, so that a resumed run searches exactly as an uninterrupted one."""
    key = [seed, generation] if member == 0 else [seed, generation, member]
    return int(np.random.default_rng(key).integers(2**31 - 1))
