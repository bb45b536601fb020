"""The campaign loop: NSGA-II generation by generation (pymoo ask/tell), evaluations through a runner,
every result stored the moment it arrives, resumable from the store alone.

One generation::

    offspring = ask()                                 # SBX + PM from the population (seeded), redrawn until
                                                      # geometrically feasible; or the surrogate's batch
                                                      # (optimizer.campaign.offspring)
    for each design: key = content hash               # parameters, mesh, flow, solver, version
        stored already?          -> its stored values (never evaluated twice)
        geometrically infeasible -> stored as "infeasible" with the violated constraints, never meshed
        otherwise                -> a runner task
    for each result as completed: judge it (convergence policy), store it
    algorithm.tell(offspring with F, G)               # rank-and-crowding survival
    store the generation: members (keys, rank, crowding), offspring, feasible share, hypervolume,
                          the optimiser's random state

**Resume.** The algorithm is rebuilt, not unpickled: a fresh NSGA-II on the same problem, its population
set from the last stored generation (designs, objective and constraint values from the evaluations
table, rank and crowding distance as stored) and its random generator set to the stored state. The next
``ask()`` then draws exactly the offspring an uninterrupted run would draw; those already stored (the
part of the interrupted generation that finished) come from the store. Given the store, the loop is
deterministic: results are used in ask order whatever order they arrive in, so the final population
equals that of an uninterrupted run with the same seed.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optimizer.campaign.config import CampaignConfig
from optimizer.campaign.fields import prune_fields, with_fields
from optimizer.campaign.lock import DriverLock
from optimizer.campaign.offspring import make_offspring
from optimizer.campaign.packed import packed_path, unpack
from optimizer.campaign.problem import Assessment, CampaignProblem, Feasibility, initial_population, make_problem
from optimizer.campaign.record import EvaluationRecord
from optimizer.campaign.status import EvaluationStatus
from optimizer.campaign.store import STORE_NAME, EvaluationRow, GenerationRow, Store, check_values, now, stored

#: pymoo never stops the loop itself: the driver counts generations.
_NO_TERMINATION = ("n_gen", 10**9)


class CampaignError(RuntimeError):
    """A campaign that cannot start or continue (existing run directory, no store to resume...)."""


@dataclass
class GenerationProgress:
    """What the progress display shows while generation ``generation`` runs (counts of its offspring).

    total: offspring asked. cached: found in the store. infeasible: rejected by geometry. submitted:
    handed to the runner. done: finished with usable values. failed: finished without (any status but
    ``ok`` and ``infeasible``). workers: the runner's workers. best: ``{objective label: best value}``
    over the run so far; units: ``{objective label: unit}`` (``""``: none). hypervolume: of the
    population's feasible front after the previous generation.
    eta_s: estimated seconds to the end of the campaign (None while unknown). search: how the offspring
    were found (:mod:`optimizer.campaign.offspring`; the models' error once the generation is finished).
    """

    generation: int
    generations: int
    total: int = 0
    cached: int = 0
    infeasible: int = 0
    submitted: int = 0
    done: int = 0
    failed: int = 0
    workers: int = 0
    best: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    hypervolume: float | None = None
    feasible_share: float | None = None
    eta_s: float | None = None
    finished: bool = False
    search: dict | None = None

    @property
    def running(self) -> int:
        """Tasks started and not finished (at most one per worker)."""
        pending = self.submitted - self.done - self.failed
        return min(pending, self.workers) if self.workers else pending


@dataclass(frozen=True)
class Outcome:
    """The end of :func:`run_campaign` / :func:`resume_campaign`: the run directory, the state
    (``finished``), generations done, and the non-dominated feasible designs of the whole run."""

    directory: Path
    state: str
    generations: int
    front: list[EvaluationRow]
    labels: tuple[str, ...]


Progress = Callable[[GenerationProgress], None]


# -------------------------------------------------------------------------------------------- entry
def run_campaign(config: CampaignConfig, directory: str | Path | None = None, *, runner=None,
                 fn: Callable[[dict], dict] | None = None, progress: Progress | None = None,
                 log: Callable[[str], None] | None = None) -> Outcome:
    """Start a new campaign in ``directory`` (default ``config.output.directory``).

    runner: a runner (default ``make_runner(config.execution)``); fn: the worker function (default
    :func:`optimizer.campaign.record.evaluate_payload`); progress: called with a
    :class:`GenerationProgress` on each event; log: called with one line at each phase.
    """
    directory = Path(directory if directory is not None else config.output.directory)
    path = directory / STORE_NAME
    created = not directory.exists()
    with DriverLock(directory, "run", log) as lock:
        if packed_path(path).exists() and not path.exists():
            raise CampaignError(f"{directory} already holds a campaign, packed: continue it with `millfoil resume "
                                f"{directory}` or choose another output directory")
        if path.exists():
            with Store(path, readonly=True) as existing:
                started = existing.campaign() is not None
                evaluated = started and bool(existing.count_by_status())
            if evaluated:
                raise CampaignError(f"{directory} already holds a campaign: continue it with `millfoil resume "
                                    f"{directory}` or choose another output directory")
            if started and log:
                log(f"{directory} holds a campaign that never evaluated a design: starting afresh")
            _remove_store(directory)
        (directory / "config.yaml").write_text(config.to_yaml())
        problem = make_problem(config)
        try:
            with Store(path, sync=config.output.sync) as store:
                store.start_campaign(config.to_yaml(), config.algorithm.seed, problem.version)
                return _run(config, problem, store, directory, runner, fn, progress, log)
        except BaseException:
            # a run refused or stopped before its first evaluation leaves nothing that blocks a corrected one
            if _never_evaluated(path):
                _remove_store(directory)
                if created:           # nothing of the run is left: neither is its directory
                    lock.release()
                    lock.path.unlink(missing_ok=True)
                    _remove_if_empty(directory)
            raise


def _never_evaluated(path: Path) -> bool:
    try:
        with Store(path, readonly=True) as store:
            return not store.count_by_status()
    except Exception:        # unreadable: not ours to judge, leave it
        return False


def _remove_if_empty(directory: Path) -> None:
    try:
        directory.rmdir()
    except OSError:
        pass


def _remove_store(directory: Path) -> None:
    """Remove a run directory's store (with SQLite's side files) and saved configuration."""
    for name in (STORE_NAME, f"{STORE_NAME}-wal", f"{STORE_NAME}-shm", f"{STORE_NAME}-journal", "config.yaml"):
        (directory / name).unlink(missing_ok=True)


def resume_campaign(directory: str | Path, *, runner=None, fn: Callable[[dict], dict] | None = None,
                    progress: Progress | None = None, execution: dict | None = None,
                    log: Callable[[str], None] | None = None, overrides: Sequence[str] = ()) -> Outcome:
    """Continue the campaign stored in ``directory`` with its saved configuration (``execution``: changes
    to the ``execution:`` section, e.g. another backend for the rest of the run, ``{key: value}``;
    ``overrides``: the same as ``execution.KEY=VALUE`` texts, as ``--set`` gives them; see
    :func:`saved_config`)."""
    directory = Path(directory)
    path = directory / STORE_NAME
    if not stored(path):
        raise CampaignError(f"no campaign store in {directory} (expected {path})")
    with DriverLock(directory, "resume", log):
        with Store(path, readonly=True) as store:      # refused without writing a byte (a packed store too)
            row = store.campaign()
            if row is None:
                raise CampaignError(f"{store.path} holds no campaign (it never started)")
            config = saved_config(row.config, execution, overrides)
            _check_readable(store, store.path, config)
        if not path.exists():          # packed: a campaign continues in its store
            packing = unpack(path, locked=True)
            (log or (lambda _line: None))(f"unpacked {packed_path(path).name} ({packing.before:,} bytes) into "
                                          f"{path.name} ({packing.after:,} bytes)")
        with Store(path) as store:
            return _resume(config, row, store, directory, runner, fn, progress, log)


def _check_readable(store: Store, path: Path, config: CampaignConfig) -> None:
    """SQLite's integrity check passes and every stored row parses (damage raises
    :class:`~optimizer.campaign.store.StoreDamaged`), and the last
    stored population's designs are all in the evaluations table (the resumed algorithm starts from them;
    a store that lost some is damaged): both before the store is opened for writing, so that a damaged
    store is refused (exit status 2) exactly as it was."""
    from optimizer.config import ConfigError

    store.verify()
    rows = list(store.evaluations())
    check_values(path, rows, [o.label for o in config.objectives])
    keys = {r.key for r in rows}
    generations = store.generations()
    if not generations:
        return
    last = generations[-1]
    missing = set(last.members) - keys
    if missing:
        raise ConfigError(f"{path} is damaged: generation {last.generation + 1} lists {len(missing)} of its "
                          f"{len(set(last.members))} designs that the evaluations table does not hold; the "
                          "campaign cannot continue from it (`millfoil status` shows what can be read)")


def _resume(config, row, store, directory, runner, fn, progress, log) -> Outcome:
    store.set_sync(config.output.sync)
    problem = make_problem(config)
    if problem.version != row.version and log:
        log(f"the campaign started with millfoil {row.version}, this is {problem.version}: its stored "
            "evaluations are kept and the rest run with this version")
    problem.version = row.version       # the keys of the stored evaluations stay valid
    store.start_campaign(row.config, row.seed, row.version)
    return _run(config, problem, store, directory, runner, fn, progress, log)


def saved_config(text: str, execution: dict | None = None, overrides: Sequence[str] = ()) -> CampaignConfig:
    """The campaign configuration saved in a store (its resolved YAML). Changes of its ``execution:``
    section — ``execution`` (``{key: value}``) or ``overrides`` (``execution.KEY=VALUE``, as ``--set`` gives
    them) — are validated as ``millfoil run`` validates a campaign (:meth:`CampaignConfig.from_mapping`):
    a bad one is a :class:`~optimizer.config.ConfigError` naming its ``--set`` (exit status 2)."""
    import yaml
    from pydantic import ValidationError

    from optimizer.config import ConfigError, shorten
    from optimizer.yamlsource import Source

    data = yaml.safe_load(text)
    if not isinstance(data, dict):
        raise ConfigError(f"the stored campaign configuration is a YAML {type(data).__name__}, not a mapping of "
                          "sections: the store is damaged")
    _with_earlier_defaults(data)
    if not execution and not overrides:
        try:
            return CampaignConfig.model_validate(data)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(part) for part in first["loc"]) or "the campaign"
            raise ConfigError(f"the stored campaign configuration is not valid for this millfoil: {where}: "
                              f"{shorten(first['msg'])}") from None
    for item in overrides:
        if not item.partition("=")[0].strip().startswith("execution."):
            raise ConfigError(f"--set {shorten(item)}: resume changes only execution.KEY=VALUE (the rest of the "
                              "campaign is fixed by its store)")
    values = {f"execution.{key}": value for key, value in (execution or {}).items()}
    return CampaignConfig.from_mapping(data, overrides, values=values, source=Source("the saved campaign"))


#: Settings whose default has changed, with the value a stored configuration that lacks the key ran with.
#: A store keeps its campaign's resolved configuration, every key written out, so a key is absent only from a
#: store written before the key existed, whose campaign ran as the key's first default says.
EARLIER_DEFAULTS = {("algorithm", "surrogate", "kernel"): "product",
                    ("algorithm", "surrogate", "coordinate_search"): False,
                    ("algorithm", "surrogate", "warp_prior_variance"): 2.0,
                    ("algorithm", "surrogate", "until_feasible"): "optimistic",
                    ("algorithm", "surrogate", "front_ends"): False,
                    ("algorithm", "surrogate", "condition_on_batch"): False}


def _with_earlier_defaults(data: dict) -> None:
    """Fill the keys of :data:`EARLIER_DEFAULTS` that a stored configuration lacks, in place, so that a resumed
    campaign goes on with the settings it started with (only in sections the configuration has)."""
    for (*sections, key), value in EARLIER_DEFAULTS.items():
        section = data
        for name in sections:
            section = section.get(name) if isinstance(section, dict) else None
        if isinstance(section, dict):
            section.setdefault(key, value)


# --------------------------------------------------------------------------------------------- loop
def _run(config, problem, store, directory, runner, fn, progress, log) -> Outcome:
    if runner is None:
        from optimizer.campaign.runner import make_runner

        runner = make_runner(config.execution)
    if log is not None:
        runner.log = log
    if fn is None:
        from optimizer.campaign.record import evaluate_payload

        fn = evaluate_payload
    loop = _Loop(config, problem, store, runner, fn, progress or (lambda _p: None), log or (lambda _line: None))
    try:
        with _terminate_as_interrupt(), runner:
            loop.run()
    except KeyboardInterrupt:
        store.end_campaign("interrupted", f"continue with `millfoil resume {directory}`")
        raise
    except BaseException as exc:
        store.end_campaign("failed", f"{type(exc).__name__}: {exc}")
        raise
    store.end_campaign("finished")
    return Outcome(directory, "finished", len(store.generations()), store.front(),
                   problem.objective_labels)


@contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM (a batch system's wall time, ``kill``) ends the loop like Ctrl-C: the store is marked
    ``interrupted`` and the run can be resumed."""
    def handler(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:       # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class _Loop:
    """The generation loop of one driver session (see the module docstring)."""

    def __init__(self, config: CampaignConfig, problem: CampaignProblem, store: Store, runner, fn, progress, log):
        self.config, self.problem, self.store, self.runner, self.fn = config, problem, store, runner, fn
        self.progress, self.log = progress, log
        self.pymoo = problem.pymoo_problem()
        self.algorithm_config = config.algorithm
        self.offspring = make_offspring(problem, config, store)
        self.generation_seconds: list[float] = []
        self.evaluation_seconds: list[float] = []
        self.best: dict[str, float] = {}
        for row in store.evaluations():
            self._note(row)

    # ------------------------------------------------------------------------------------- pymoo
    def _algorithm(self, sampling):
        from pymoo.algorithms.moo.nsga2 import NSGA2
        from pymoo.operators.crossover.sbx import SBX
        from pymoo.operators.mutation.pm import PM

        a = self.algorithm_config
        algorithm = NSGA2(pop_size=a.population, n_offsprings=a.batch, sampling=sampling,
                          crossover=SBX(eta=a.crossover.eta, prob=a.crossover.prob),
                          mutation=PM(eta=a.mutation.eta, prob_var=a.mutation.prob),
                          eliminate_duplicates=self.offspring.eliminate_duplicates())
        algorithm.setup(self.pymoo, seed=a.seed, termination=_NO_TERMINATION, verbose=False)
        return algorithm

    def _start(self):
        """A fresh algorithm (feasible initial population) or one rebuilt from the last stored generation."""
        last = self.store.last_generation()
        if last is None:
            a = self.algorithm_config
            self.log(f"drawing a geometrically feasible initial population of {a.population} (seed {a.seed})")
            X0, draws = initial_population(self.problem, a.population, a.seed, a.initial_draws)
            self.offspring.initial_draws = draws
            self.log(f"initial population: {a.population} feasible of {draws} random designs "
                     f"({a.population / draws:.1%})")
            return self._algorithm(X0), 0
        self.log(f"continuing after generation {last.generation + 1} of {self.algorithm_config.generations} "
                 "(population and random state from the store)")
        algorithm = self._algorithm(np.zeros((1, self.problem.n_var)))
        rows = self.store.get_many(last.members)
        pop = self._population([rows[k] for k in last.members])
        # infeasible members have no rank or crowding (None): NSGA-II compares them by violation only
        pop.set("rank", _objects(last.rank), "crowding", _objects(last.crowding))
        algorithm.pop = pop
        algorithm.is_initialized = True
        algorithm.n_iter = last.generation + 2     # pymoo counts the initial generation as 1, then advances
        algorithm.random_state.bit_generator.state = last.rng_state
        return algorithm, last.generation + 1

    def _population(self, rows: Sequence[EvaluationRow]):
        from pymoo.core.population import Population

        pop = Population.new("X", np.array([r.x for r in rows], float))
        self._set_values(pop, rows)
        return pop

    def _set_values(self, pop, rows: Sequence[EvaluationRow]) -> None:
        from pymoo.core.evaluator import Evaluator
        from pymoo.problems.static import StaticProblem

        F = np.array([r.minimised for r in rows], float)
        G = np.array([[r.constraints[n] for n in self.problem.constraint_names] for r in rows], float)
        Evaluator(skip_already_evaluated=False).eval(StaticProblem(self.pymoo, F=F, G=G), pop)

    # -------------------------------------------------------------------------------------- loop
    def run(self) -> None:
        algorithm, start = self._start()
        for g in range(start, self.algorithm_config.generations):
            t0 = time.perf_counter()
            offspring, search = self.offspring.ask(algorithm, g)
            if offspring is None or len(offspring) == 0:    # duplicates left no new design: nothing to do
                break
            rows, counts = self._evaluate(offspring.get("X"), g, search)
            self._set_values(offspring, rows)
            algorithm.tell(infills=offspring)
            self.generation_seconds.append(time.perf_counter() - t0)
            self._store_generation(algorithm, g, rows, counts, self.offspring.review(search, rows))

    def _evaluate(self, X: np.ndarray, g: int, search: dict | None = None) -> tuple[list[EvaluationRow], dict]:
        """One row per design of ``X`` (in order): stored, infeasible, or evaluated now."""
        keys = [self.problem.key(x) for x in X]
        known = self.store.get_many(keys)
        state = GenerationProgress(g, self.algorithm_config.generations, total=len(X), search=search,
                                   cached=sum(1 for k in keys if k in known and known[k].generation < g),
                                   workers=getattr(self.runner, "workers", 0) or 0, **self._summary())
        feasibility: dict[str, Feasibility] = {}
        tasks, submitted = [], {}
        for k, x in zip(keys, X, strict=True):
            if k in known or k in feasibility:
                continue
            feasibility[k] = f = self.problem.check(x)
            if not f.feasible:
                known[k] = self._row(k, g, x, self.problem.infeasible(f))
                self.store.add(known[k])
                self._note(known[k])
                state.infeasible += 1
                continue
            tasks.append(_task(k, with_fields(self.problem.payload(x), self.store.path.parent, k), g))
            submitted[k] = (x, now())
        state.feasible_share = _feasible_share(keys, known, submitted)
        state.submitted = len(tasks)
        state.eta_s = self._eta(g, len(tasks), state.workers)
        self.progress(state)
        if tasks:
            for result in self.runner.run(self.fn, tasks):
                x, at = submitted[result.key]
                assessment = self._assess(result, feasibility[result.key])
                row = self._row(result.key, g, x, assessment, result=result, submitted=at)
                self.store.add(row)
                self._note(row)
                known[result.key] = row
                self.evaluation_seconds.append(result.seconds)
                if row.ok:
                    state.done += 1
                else:
                    state.failed += 1
                state.best = dict(self.best)
                state.eta_s = self._eta(g, len(tasks) - state.done - state.failed, state.workers)
                self.progress(state)
        rows = [known[k] for k in keys]
        feasible = sum(1 for k in keys if known[k].status != EvaluationStatus.INFEASIBLE)
        counts = {"cached": state.cached, "feasible": feasible}
        return rows, counts

    def _assess(self, result, feasibility: Feasibility) -> Assessment:
        if result.status != "done" or result.record is None:
            return self.problem.failed(result.status, result.reason or result.status, feasibility)
        try:
            return self.problem.assess(result.record, feasibility)
        except Exception as exc:    # a malformed record is a bug in the worker: recorded, not fatal
            return self.problem.failed(EvaluationStatus.ERROR, f"cannot judge the record: {type(exc).__name__}: {exc}",
                                       feasibility)

    def _row(self, key: str, g: int, x: np.ndarray, a: Assessment, *, result=None, submitted=None) -> EvaluationRow:
        record = result.record if result is not None and result.record is not None else None
        if record is not None:
            record = EvaluationRecord.of(record)
        return EvaluationRow(
            key=key, generation=g, x=[float(v) for v in x], parameters=self.problem.stored_parameters(x),
            status=a.status,
            reason=a.reason, minimised=a.minimised, constraints=a.constraints, convergence=a.convergence,
            objectives=a.objectives, figures=None if record is None else record.figures,
            monitors=None if record is None else record.monitors, cells=None if record is None else record.cells,
            iterations=None if record is None else record.iterations,
            seconds=None if record is None else record.seconds,
            wall_seconds=None if result is None else result.seconds,
            worker=None if result is None else result.worker, submitted=submitted)

    # ------------------------------------------------------------------------------- generation
    def _store_generation(self, algorithm, g: int, rows: list[EvaluationRow], counts: dict,
                          search: dict | None = None) -> None:
        pop = algorithm.pop
        X = pop.get("X")
        members = [self.problem.key(x) for x in X]
        hv = self._hypervolume(pop)
        self.store.add_generation(GenerationRow(
            generation=g, members=members, rank=[_maybe(int, r) for r in pop.get("rank")],
            crowding=[_maybe(float, c) for c in pop.get("crowding")], offspring=[r.key for r in rows],
            feasible_offspring=counts["feasible"], feasible_share=counts["feasible"] / len(rows) if rows else None,
            cache_hits=counts["cached"], hypervolume=hv, rng_state=algorithm.random_state.bit_generator.state,
            search=search))
        prune_fields(self.store)      # fields files are kept for the front's designs only
        state = GenerationProgress(g, self.algorithm_config.generations, total=len(rows), cached=counts["cached"],
                                   infeasible=len(rows) - counts["feasible"], finished=True,
                                   workers=getattr(self.runner, "workers", 0) or 0, **self._summary(),
                                   feasible_share=counts["feasible"] / len(rows) if rows else None, search=search)
        state.hypervolume = hv
        by_status = self.store.count_by_status(g)
        state.done = by_status.get(EvaluationStatus.OK, 0)
        state.failed = sum(n for s, n in by_status.items() if EvaluationStatus.parse(s).failed)
        state.eta_s = self._eta(g, 0, state.workers)
        self.progress(state)

    def _hypervolume(self, pop) -> float | None:
        """Hypervolume of the population's feasible designs against the run's reference point."""
        F, CV = pop.get("F"), pop.get("CV")[:, 0]
        feasible = F[CV <= 0.0]
        if len(feasible) == 0:
            return None
        reference = self._reference(feasible)
        inside = feasible[np.all(feasible < reference, axis=1)]
        if len(inside) == 0:
            return 0.0
        from pymoo.indicators.hv import HV

        return float(HV(ref_point=reference)(inside))

    def _reference(self, feasible: np.ndarray) -> np.ndarray:
        """The run's hypervolume reference (minimised space): from the config where given, else the worst
        value of the first feasible generation plus a tenth of its range; fixed once stored."""
        stored = self.store.campaign().reference
        if stored is not None:
            return np.asarray(stored, float)
        worst, best = feasible.max(axis=0), feasible.min(axis=0)
        span = np.where(worst > best, worst - best, np.maximum(np.abs(worst), 1.0))
        reference = worst + 0.1 * span
        for i, o in enumerate(self.config.objectives):
            if o.reference is not None:
                reference[i] = -o.reference if o.sense == "max" else o.reference
        self.store.set_reference(reference)
        return reference

    def _note(self, row: EvaluationRow) -> None:
        """Keep the best value per objective over the run's feasible designs."""
        if not row.feasible or row.objectives is None:
            return
        for o in self.config.objectives:
            v, best = row.objectives[o.label], self.best.get(o.label)
            if best is None or (v > best if o.sense == "max" else v < best):
                self.best[o.label] = v

    def _summary(self) -> dict:
        """Best value per objective so far and the last generation's hypervolume."""
        last = self.store.last_generation()
        return {"best": dict(self.best), "units": {o.label: o.unit for o in self.config.objectives},
                "hypervolume": None if last is None else last.hypervolume}

    def _eta(self, g: int, remaining_tasks: int, workers: int) -> float | None:
        """Seconds to the end while generation ``g`` has ``remaining_tasks`` evaluations to go: those at the
        mean evaluation time over the workers, then the generations after ``g`` at the mean generation time
        of this session (or, before one has finished, a full generation of evaluations each)."""
        if not self.evaluation_seconds and not self.generation_seconds:
            return None
        per = float(np.mean(self.evaluation_seconds)) / max(workers, 1) if self.evaluation_seconds else 0.0
        after = self.algorithm_config.generations - g - 1
        if self.generation_seconds:
            per_generation = float(np.mean(self.generation_seconds))
        else:
            per_generation = per * self.algorithm_config.batch
        return per * remaining_tasks + per_generation * max(after, 0)


def _maybe(kind, v):
    """``kind(v)``, or None for None (pymoo leaves rank and crowding unset on infeasible members)."""
    return None if v is None else kind(v)


def _objects(values: list) -> np.ndarray:
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def _task(key: str, payload: dict, generation: int):
    from optimizer.campaign.runner import Task

    return Task(key=key, payload=payload, generation=generation)


def _feasible_share(keys, known, submitted) -> float | None:
    if not keys:
        return None
    feasible = sum(1 for k in keys if k in submitted or (k in known and known[k].status != EvaluationStatus.INFEASIBLE))
    return feasible / len(keys)


# ------------------------------------------------------------------------------------------ results
def final_population(store: Store) -> list[str]:
    """Keys of the last stored population (in order)."""
    last = store.last_generation()
    return [] if last is None else list(last.members)

