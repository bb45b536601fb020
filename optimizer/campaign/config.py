"""Campaign configuration: today's configuration file plus the sections of an optimisation campaign.

A campaign file is a configuration file (``blade:``, ``mesh:``, ``flow:``, ``solver:``, see
:mod:`optimizer.config`) with these further sections, every one optional:

``objectives:``
    a list of ``{figure, sense, abs, reference}``; ``figure`` is any figure :func:`optimizer.evaluate`
    reports (:data:`FIGURES`), ``sense`` ``min`` or ``max``, ``abs`` takes the magnitude first,
    ``reference`` the hypervolume reference value in the figure's unit (default: from the first
    generation). Default: maximise |F_Y| and minimise C_max (the paper's pair).
``constraints:``
    a list of ``{figure, upper, lower, abs}``: the design is feasible only if ``lower <= figure <= upper``.
``convergence:``
    what a solve that did not converge is worth (the objective policy, ``docs/explanation/campaigns.md``):
    ``oscillating`` = ``accept_below_amplitude`` (default; values are the window means, accepted while the
    amplitude of every objective's monitor is at most ``max_amplitude`` = 0.01 of its mean), ``accept_mean``
    or ``fail``. A ``not_converged`` solve (drifting monitors) always fails. The class is judged on the
    monitors of the chosen objectives and constraints where they have one.
``algorithm:``
    ``method``: ``nsga2`` (plain) or ``surrogate`` (offspring chosen on models fitted from the store, with
    its ``surrogate:`` settings); ``population``, ``generations`` (including the initial one),
    ``offspring`` (designs sent to the CFD per generation; default: the population, a fifth of it with the
    surrogate), ``seed``, ``crossover: {eta, prob}`` (pymoo SBX), ``mutation: {eta, prob}`` (pymoo PM;
    ``prob`` null: 1 / number of design variables), ``initial_draws`` (rejection-sampling budget per member
    of the feasible initial population).
``execution:``
    where evaluations run (:class:`optimizer.campaign.runner.ExecutionConfig`, beside the registry of backends
    whose names it takes).
``output:``
    ``directory``: the run directory (store, resolved config), relative to the working directory.
``analytic:``
    an analytic test problem instead of the blade (``problem``: zdt1–3, dtlz2, mw1, mw2, mw3, mw7;
    ``variables``; ``delay`` seconds per evaluation; injected ``failures``): the whole loop, store, runner
    and CLI without CFD (tests, optimiser benchmarks, cluster checks).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar, Literal

import yaml
from pydantic import Field, ValidationError, field_validator, model_validator

from geometry import Continuity, Mode
from geometry.parameters import parameters_of
from optimizer.campaign.runner import ClusterOptions, ExecutionConfig, walltime_seconds
from optimizer.config import (
    Config,
    ConfigError,
    ConfigWarning,
    Section,
    apply_overrides,
    explain,
    load_config,
    override_items,
    set_values,
    shorten,
)
from optimizer.yamlsource import Source

__all__ = ["ANALYTIC", "ANALYTIC_CONSTRAINTS", "FIGURES", "METHODS", "MONITOR_OF", "AlgorithmConfig",
           "AnalyticConfig", "CampaignConfig", "ClusterOptions", "ConvergencePolicy", "Crossover", "ExecutionConfig",
           "FigureConstraint", "InjectedFailures", "Mutation", "Objective", "OutputConfig", "SurrogateSettings",
           "check_campaign", "load_campaign", "walltime_seconds"]

#: Figures of :class:`optimizer.evaluate.Evaluation` that can be objectives or constraints, with units.
FIGURES: dict[str, str] = {
    "fx": "N/m", "fy": "N/m", "fx_span": "N", "fy_span": "N", "c_l": "-", "c_max": "m/s", "cp_min": "-",
    "cp_wall_min": "-", "yplus_max": "-", "yplus_mean": "-",
}
#: The solver monitor behind each figure (its convergence class and window mean decide the value).
MONITOR_OF: dict[str, str] = {
    "fx": "fx:blade", "fx_span": "fx:blade", "fy": "fy:blade", "fy_span": "fy:blade", "c_l": "fy:blade",
    "c_max": "c_max", "cp_min": "c_max",
}
#: Analytic test problems (pymoo's, all on the unit box) and their objective names.
ANALYTIC: dict[str, tuple[str, ...]] = {name: ("f1", "f2") for name in
                                        ("zdt1", "zdt2", "zdt3", "dtlz2", "mw1", "mw2", "mw3", "mw7")}
#: The inequality constraints (G ≤ 0 feasible) each analytic problem carries itself.
ANALYTIC_CONSTRAINTS: dict[str, tuple[str, ...]] = {"mw1": ("g1",), "mw2": ("g1",), "mw3": ("g1", "g2"),
                                                    "mw7": ("g1", "g2")}

DEFAULT_OBJECTIVES = ({"figure": "fy", "sense": "max", "abs": True}, {"figure": "c_max", "sense": "min"})

# Limits of a campaign's size (docs/reference/errors.md, "Campaign values"). A week-long cluster campaign
# (1 000 workers, 10 minutes per evaluation) is about a million evaluations: the limits leave that room and
# refuse the typo that asks for a billion before anything is allocated or stored.
#: Largest ``algorithm.population`` and ``algorithm.offspring``.
MAX_POPULATION = 10_000
#: Largest ``algorithm.generations``.
MAX_GENERATIONS = 10_000
#: Largest number of evaluations a campaign may ask for: population + (generations - 1) * offspring.
MAX_EVALUATIONS = 1_000_000
#: Largest ``algorithm.seed``: the store keeps it as an SQLite integer (signed 64-bit).
MAX_SEED = 2**63 - 1
#: Largest ``algorithm.initial_draws``.
MAX_INITIAL_DRAWS = 100_000


class Objective(Section):
    """One objective: ``figure`` (see :data:`FIGURES`), ``sense``, ``abs`` (magnitude first) and the
    hypervolume ``reference`` value in the figure's unit (null: from the first generation)."""

    figure: str = Field(description="the figure to optimise, one of FIGURES (fx, fy, c_max...; the analytic "
                        "problem's f1, f2)")
    sense: Literal["min", "max"] = Field("min", description="minimise or maximise the figure")
    abs: bool = Field(False, description="take the figure's magnitude first (|fy|)")
    reference: float | None = Field(None, description="hypervolume reference value, in the figure's unit; null: "
                                    "from the first generation")

    @property
    def label(self) -> str:
        """``|fy|`` or ``c_max``: the name of the value as the user states it."""
        return f"|{self.figure}|" if self.abs else self.figure

    @property
    def unit(self) -> str:
        """The figure's unit (``N/m``, ``m/s``), or ``""`` for a dimensionless or analytic one."""
        return FIGURES.get(self.figure, "").strip("-")


class FigureConstraint(Section):
    """``lower <= figure <= upper`` (either bound may be left out; ``abs``: on the magnitude)."""

    figure: str = Field(description="the constrained figure, one of FIGURES")
    upper: float | None = Field(None, description="largest allowed value, in the figure's unit; null: none")
    lower: float | None = Field(None, description="smallest allowed value, in the figure's unit; null: none")
    abs: bool = Field(False, description="constrain the figure's magnitude")

    @model_validator(mode="after")
    def _one_bound(self) -> FigureConstraint:
        if self.upper is None and self.lower is None:
            raise ValueError("a constraint needs 'upper' or 'lower' (or both)")
        if self.upper is not None and self.lower is not None and self.lower > self.upper:
            raise ValueError(f"lower {self.lower} > upper {self.upper}")
        return self

    @property
    def names(self) -> list[str]:
        """Constraint names, one per bound: ``c_max<=25``, ``c_l>=0.5``."""
        label = f"|{self.figure}|" if self.abs else self.figure
        out = []
        if self.upper is not None:
            out.append(f"{label}<={self.upper:g}")
        if self.lower is not None:
            out.append(f"{label}>={self.lower:g}")
        return out


class ConvergencePolicy(Section):
    """``convergence:`` — what an unsettled solve is worth (see the module docstring)."""

    oscillating: Literal["accept_below_amplitude", "accept_mean", "fail"] = Field(
        "accept_below_amplitude", description="what an oscillating solve is worth: its window means while every "
        "objective's amplitude is at most max_amplitude (accept_below_amplitude), its window means always "
        "(accept_mean), or a failed evaluation (fail)")
    max_amplitude: float = Field(0.01, gt=0, description="largest accepted oscillation amplitude, relative to the "
                                 "monitor's mean (0.01 is 1 %)")


class Crossover(Section):
    """pymoo SBX: distribution index ``eta`` and probability ``prob`` of crossing a pair."""

    eta: float = Field(15.0, gt=0, description="SBX distribution index: larger keeps children nearer their parents")
    prob: float = Field(0.9, ge=0, le=1, description="probability of crossing a pair")


class Mutation(Section):
    """pymoo PM: distribution index ``eta``; ``prob`` per variable (null: 1 / number of variables)."""

    eta: float = Field(20.0, gt=0, description="PM distribution index: larger makes smaller mutations")
    prob: float | None = Field(None, ge=0, le=1, description="probability of mutating each design variable; null: "
                               "1 / number of design variables")


#: Search methods of ``algorithm.method``.
METHODS = ("nsga2", "surrogate")
#: Kernels of ``algorithm.surrogate.kernel`` (:mod:`optimizer.campaign.surrogate`).
KERNELS = ("product", "additive", "warped")
#: Aims of the exploration share before the first feasible design (``algorithm.surrogate.until_feasible``).
UNTIL_FEASIBLE = ("optimistic", "probability")


class SurrogateSettings(Section):
    """``algorithm.surrogate:`` — the surrogate-assisted search (used with ``method: surrogate``; the rule is
    in :mod:`optimizer.campaign.infill`, the models in :mod:`optimizer.campaign.surrogate`)."""

    pool: int = Field(50, ge=1, le=1000, description="candidates the search on the models draws per design sent "
                      "to the CFD (the pool is pool × offspring; 10 to 50 is usual)")
    exploration: float = Field(0.25, ge=0, le=1, description="share of each batch chosen where the models are "
                               "uncertain (optimistic hypervolume improvement) rather than where they predict "
                               "the most improvement")
    training: int = Field(200, ge=10, le=5000, description="largest number of stored designs each model is fitted "
                          "on (a Gaussian process costs O(n³)): those nearest the front")
    failure_limit: float = Field(0.5, gt=0, le=1, description="candidates whose predicted probability of failing "
                                 "(no mesh, diverged, unsettled, timeout) is above this are not sent")
    kernel: Literal[KERNELS] = Field("warped", description="the Gaussian processes' kernel. product: constant × "
                                     "Matérn 5/2 with a length scale per design variable, plus noise; additive: "
                                     "the same plus a Matérn 5/2 term per variable (one-variable effects), which "
                                     "ranks many-variable problems better; warped: the additive terms on each "
                                     "variable's range warped by a fitted monotone map (a prior keeps it near the "
                                     "identity unless the data ask), for effects that are flat over most of a "
                                     "range and steep in a corner of it (decision 0017)")
    recent: int = Field(0, ge=0, le=5000, description="of the training designs, how many are the newest "
                        "evaluated, whatever their rank (the rest: those nearest the front), so that the models "
                        "learn from the batches they misjudged; 0: all by rank (decision 0017)")
    recent_share: float = Field(1.0, ge=0, le=1, description="with recent > 0, the share of each batch chosen on "
                                "models that learn from the newest designs; the rest is chosen on models fitted on "
                                "the best-ranked alone (two sets of models each generation); 1: every design "
                                "on the models with the newest (decision 0017)")
    initial: int = Field(0, ge=0, le=5000, description="of the training designs, how many are the first stored "
                         "(the initial population, spread over the box), whatever their rank, so that the "
                         "models keep seeing the whole box once the best-ranked designs crowd near the front; "
                         "0: none kept (decision 0017)")
    hyperparameter_initial: int = Field(0, ge=0, le=5000, description="fit the models' hyperparameters (length "
                                        "scales, variances, warpings) on a training set of the same size that "
                                        "keeps this many of the first stored designs (the initial population, "
                                        "spread over the box), the rest by rank; the models then predict from "
                                        "the usual training set with them; 0: both from the usual set "
                                        "(decision 0017)")
    coordinate_search: bool = Field(True, description="also move the best designs of the search on the models "
                                    "one variable at a time over its whole range, to the best predicted value "
                                    "(crosses the barriers between a variable's basins that NSGA-II's steps "
                                    "rarely cross; pays with the additive and warped kernels, decision 0017)")
    warp_prior_variance: float = Field(1.0, gt=0, le=100, description="with kernel: warped, the variance of the "
                                       "normal prior on the logarithms of the warping exponents (a log-normal "
                                       "prior of median 1, no warping): smaller keeps the maps nearer the "
                                       "identity, larger lets the fit take steep ones (decision 0017)")
    until_feasible: Literal[UNTIL_FEASIBLE] = Field("probability", description="what the exploration share (and the "
                                                    "optimistic half of the coordinate search) aims at while no "
                                                    "evaluated design meets every CFD constraint. optimistic: the "
                                                    "optimistic objectives and constraints (mean − 2 std), as "
                                                    "afterwards; probability: the models' probability that a design "
                                                    "meets every constraint and does not fail (decision 0017)")
    front_ends: bool = Field(True, description="with coordinate_search, also move the designs predicted best in "
                             "each objective to minimise that objective alone (on the mean and on the optimistic "
                             "predictions), so that the search extends the front beyond its ends; without "
                             "coordinate_search it changes nothing (decision 0017)")
    condition_on_batch: bool = Field(True, description="the batch's choice also takes each design it has chosen "
                                     "as observed at its predicted values in the models, so that their uncertainty "
                                     "shrinks near it and the exploration share spreads over distinct designs "
                                     "(exact for a Gaussian process with its hyperparameters fixed); false: only "
                                     "the front takes the predictions (decision 0017)")


class AlgorithmConfig(Section):
    """``algorithm:`` — the optimiser (the paper: NSGA-II, population 100, 50 generations)."""

    method: Literal[METHODS] = Field("nsga2", description="nsga2: plain NSGA-II, every offspring to the CFD; "
                                     "surrogate: NSGA-II whose offspring are chosen on Gaussian-process models "
                                     "fitted from the store (docs/explanation/campaigns.md: where it reaches the "
                                     "same front with a fifth of the CFD and where not yet)")
    population: int = Field(100, ge=2, le=MAX_POPULATION, description="designs per generation",
                            json_schema_extra={"why": "the paper uses 100; a generation of 10 000 CFD designs is "
                                               "a day of a 1 000-worker cluster"})
    generations: int = Field(50, ge=1, le=MAX_GENERATIONS, description="generations, the initial one included",
                             json_schema_extra={"why": "the paper uses 50; the evaluations of the whole campaign "
                                                f"are limited to {MAX_EVALUATIONS:,} too"})
    offspring: int | None = Field(None, ge=1, le=MAX_POPULATION, description="new designs sent to the CFD per "
                                  "generation (a multiple of the workers keeps them busy); null: the population "
                                  "(nsga2), a fifth of it rounded up (surrogate)",
                                  json_schema_extra={"why": "10 000 keep 10 000 workers busy; more only queue"})
    surrogate: SurrogateSettings = Field(SurrogateSettings(), description="the surrogate-assisted search "
                                         "(method surrogate)")
    seed: int = Field(1, ge=0, le=MAX_SEED, description="random seed: the same seed and configuration give the same "
                      "campaign", json_schema_extra={"why": "the store keeps it as a signed 64-bit SQLite integer "
                                                     "(at most 2**63 - 1 = 9223372036854775807)"})
    crossover: Crossover = Field(Crossover(), description="pymoo SBX crossover")
    mutation: Mutation = Field(Mutation(), description="pymoo polynomial mutation")
    initial_draws: int = Field(1000, ge=1, le=MAX_INITIAL_DRAWS, description="rejection-sampling budget per "
                               "member of the feasible initial population",
                               json_schema_extra={"why": "a space where fewer than one random design in 100 000 "
                                                  "is feasible is better narrowed (blade.bounds, `millfoil space`)"})

    @property
    def batch(self) -> int:
        """New designs sent to the CFD per generation (``offspring`` resolved)."""
        if self.offspring is not None:
            return self.offspring
        return self.population if self.method == "nsga2" else -(-self.population // 5)

    @property
    def evaluations(self) -> int:
        """Most evaluations the campaign asks for: the initial population and every generation's offspring."""
        return self.population + (self.generations - 1) * self.batch


class OutputConfig(Section):
    """``output:`` — ``directory``: the run directory (relative paths: to the working directory).
    ``sync``: ``full`` (default): every stored evaluation survives even a power cut of the driver's machine
    (one fsync per evaluation, about 1 ms on this machine's disk); ``normal``: it survives the driver's
    death (SIGKILL, an exception) but possibly not a power cut — for fast analytic runs."""

    directory: Path = Field(Path("runs/campaign"), description="the run directory (store, resolved "
                            "configuration); relative paths: to the working directory; not empty")
    sync: Literal["full", "normal"] = Field("full", description="full: every stored evaluation survives a power "
                                            "cut (one fsync per evaluation); normal: it survives the driver's death "
                                            "but possibly not a power cut")

    @field_validator("directory", mode="before")
    @classmethod
    def _not_empty(cls, v: Any) -> Any:
        if v is None or (isinstance(v, str) and not v.strip()):
            raise ValueError("the run directory is empty: give one, e.g. runs/campaign ('.' for the working "
                             "directory)")
        return v


class InjectedFailures(Section):
    """``analytic.failures:`` — designs of an analytic problem that fail as a CFD solve can, so that an
    optimiser's handling of failures is tested where the answer is known. A failed design has no values
    (status ``diverged`` in the hidden region, ``solve_failed`` for a random failure)."""

    region: float = Field(0.0, ge=0, lt=1, description="volume share of the box taken by a hidden box over two "
                          "design variables whose designs all fail (0.05 is 5 %); 0: none")
    random: float = Field(0.0, ge=0, lt=1, description="probability that any design fails, drawn from its content "
                          "hash (the same design always fails or always passes); 0: none")
    seed: int = Field(0, ge=0, le=MAX_SEED, description="chooses the hidden region's two variables and its place")

    @property
    def any(self) -> bool:
        return self.region > 0 or self.random > 0


class AnalyticConfig(Section):
    """``analytic:`` — an analytic problem in place of the blade: the whole loop, store, runner and CLI
    without CFD (tests, benchmarks of the optimisers, cluster checks).

    problem: pymoo's ZDT1–3 (Zitzler, Deb & Thiele 2000), DTLZ2 with two objectives (Deb et al. 2002),
    or the constrained MW1, MW2, MW3, MW7 (Ma & Wang 2019), all on the unit box. variables: number of
    design variables. delay: seconds each evaluation sleeps (to test parallel execution, timeouts and
    interruption). failures: injected failures (:class:`InjectedFailures`).
    """

    problem: Literal[tuple(ANALYTIC)] = Field("zdt1", description="the analytic problem: zdt1, zdt2, zdt3 and "
                                              "dtlz2 (two objectives), or mw1, mw2, mw3, mw7 (two objectives with "
                                              "their own constraints g1, g2 <= 0)")
    variables: int = Field(6, ge=2, le=100, description="number of design variables, each in [0, 1]")
    delay: float = Field(0.0, ge=0, le=3600, description="seconds each evaluation sleeps (to test parallel "
                         "execution, timeouts and interruption), s",
                         json_schema_extra={"unit": "s", "why": "a test of timeouts needs seconds, not hours"})
    failures: InjectedFailures = Field(InjectedFailures(), description="designs that fail as a CFD solve can "
                                       "(a hidden region, random failures)")


class CampaignConfig(Config):
    """A whole campaign file (see the module docstring)."""

    objectives: tuple[Objective, ...] = Field((), description="what the campaign optimises (at least one); left "
                                              "out: maximise |F_Y| and minimise C_max (the paper's pair), or the "
                                              "analytic problem's f1 and f2")
    constraints: tuple[FigureConstraint, ...] = Field((), description="bounds on figures that a feasible design "
                                                      "meets")
    convergence: ConvergencePolicy = Field(ConvergencePolicy(), description="what a solve that did not converge "
                                           "is worth")
    algorithm: AlgorithmConfig = Field(AlgorithmConfig(), description="the NSGA-II optimiser's settings")
    execution: ExecutionConfig = Field(ExecutionConfig(), description="where and how the evaluations run")
    output: OutputConfig = Field(OutputConfig(), description="where the campaign's results go")
    analytic: AnalyticConfig | None = Field(None, description="an analytic problem in place of the blade (loop "
                                            "tests without CFD); null: the blade")

    #: A bare ``--set NAME=VALUE`` is a blade parameter only if NAME is one (of any family); any other bare name
    #: is an unknown campaign key (``objectivs=[]`` is a typo, not a parameter).
    bare_parameter_names: ClassVar[frozenset[str] | None] = frozenset(
        name for mode in Mode for continuity in Continuity for name in parameters_of(mode, continuity))

    @model_validator(mode="before")
    @classmethod
    def _default_objectives(cls, data: Any) -> Any:
        if isinstance(data, dict) and "objectives" not in data:
            analytic = data.get("analytic")
            if isinstance(analytic, dict | AnalyticConfig):
                name = analytic.get("problem", "zdt1") if isinstance(analytic, dict) else analytic.problem
                data = {**data, "objectives": [{"figure": f} for f in ANALYTIC.get(name, ())]}
            else:
                data = {**data, "objectives": list(DEFAULT_OBJECTIVES)}
        return data

    @field_validator("objectives", mode="before")
    @classmethod
    def _at_least_one(cls, v: Any) -> Any:
        if v is None or (isinstance(v, list | tuple) and not v):
            raise ValueError("there is no objective: list at least one ({figure: fy, sense: max, abs: true}), or "
                             "leave the key out for the default pair (max |F_Y|, min C_max; an analytic problem's "
                             "f1 and f2)")
        return v

    @field_validator("objectives")
    @classmethod
    def _distinct(cls, v: tuple[Objective, ...]) -> tuple[Objective, ...]:
        labels = [o.label for o in v]
        if len(set(labels)) != len(labels):
            raise ValueError(f"an objective is given twice: {', '.join(labels)}")
        return v

    @property
    def figures(self) -> dict[str, str]:
        """The figures allowed in ``objectives`` and ``constraints`` for this campaign."""
        if self.analytic is not None:
            return {f: "-" for f in ANALYTIC[self.analytic.problem]}
        return FIGURES

    @classmethod
    def from_mapping(cls, raw: Mapping[str, Any], overrides: Sequence[str] = (), *,
                     values: Mapping[str, Any] | None = None, blade_values: bool = False,
                     source: Source | None = None) -> CampaignConfig:
        """As :meth:`optimizer.config.Config.from_mapping`, with the campaign's checks across sections.
        A campaign needs no single blade (``blade.parameters`` may be left out: the space is what counts)."""
        data = set_values(apply_overrides(raw, overrides, cls), (values or {}).items(), cls)
        source = (source or Source("<defaults>")).with_overrides(override_items(overrides, cls))
        try:
            config = cls.model_validate(data)
        except ValidationError as exc:
            raise ConfigError(explain(exc, cls, source)) from None
        if blade_values:
            config.blade.blade_spec()
        return check_campaign(config, source)

    def to_yaml(self) -> str:
        """The resolved campaign (every value, defaults included); reading it back gives the same one."""
        if self.analytic is None:
            return super().to_yaml()
        data = self.model_dump(mode="json")
        # an analytic campaign has no blade: the one filled in for a blade section left out (Table 4's) is
        # not written, so that reading the file back does not warn of blade.parameters no campaign uses
        data["blade"]["parameters"] = {}
        return yaml.safe_dump(data, sort_keys=False)


def load_campaign(path: str | Path | None, overrides: Sequence[str] = ()) -> CampaignConfig:
    """Read a campaign file, apply ``KEY=VALUE`` overrides, validate; errors name key, file and line
    (:func:`optimizer.config.load_config` with this schema)."""
    return load_config(path, overrides, schema=CampaignConfig, blade_values=False)


def check_campaign(config: CampaignConfig, source: Any) -> CampaignConfig:
    """Checks across sections (figure names, the blade space, the mesh), errors located in ``source``; a
    :class:`~optimizer.config.ConfigWarning` for ``blade.parameters``, which a campaign does not use."""
    given = [n for n in config.blade.parameters if source.gives(("blade", "parameters", n))]
    if given:
        names = ", ".join(sorted(given))
        warnings.warn(f"{source.where(('blade', 'parameters', given[0]))}: blade.parameters ({names}) is not used by a "
                      "campaign: each design takes its values from the space (`millfoil space`); to hold a "
                      "parameter, set blade.fixed.NAME, to narrow one, blade.bounds.NAME", ConfigWarning, stacklevel=2)
    allowed = config.figures
    for section, items in (("objectives", config.objectives), ("constraints", config.constraints)):
        for i, item in enumerate(items):
            if item.figure not in allowed:
                raise ConfigError(f"{source.where((section, i, 'figure'))}: '{section}.{i}.figure' = "
                                  f"{item.figure!r} is not allowed; allowed: {', '.join(allowed)}")
    if config.analytic is None:
        for where, check in ((("blade", "bounds"), config.blade.space), (("mesh",), config.mesh_spec)):
            try:
                check()
            except ConfigError as exc:
                raise ConfigError(f"{source.where(_located(exc, where, config))}: {exc}") from None
        _check_design_variables(config, source)
    _check_evaluations(config, source)
    _check_execution(config, source)
    s = config.algorithm.surrogate
    for key in ("recent", "initial", "hyperparameter_initial"):
        if getattr(s, key) > s.training:
            path = ("algorithm", "surrogate", key)
            raise ConfigError(f"{source.where(path)}: 'algorithm.surrogate.{key}' = {getattr(s, key)} is more "
                              f"than algorithm.surrogate.training ({s.training}): the designs it keeps are part "
                              "of the training set; allowed: 0 to the training size")
    if s.recent + s.initial > s.training:
        path = ("algorithm", "surrogate", "initial")
        raise ConfigError(f"{source.where(path)}: 'algorithm.surrogate.recent' + 'algorithm.surrogate.initial' "
                          f"= {s.recent + s.initial} is more than algorithm.surrogate.training ({s.training}): "
                          "both are part of the training set; allowed: a sum of 0 to the training size")
    if s.recent_share < 1.0 and s.recent == 0:
        path = ("algorithm", "surrogate", "recent_share")
        raise ConfigError(f"{source.where(path)}: 'algorithm.surrogate.recent_share' = {s.recent_share:g} splits the "
                          "batch between models with and without the newest designs, but algorithm.surrogate.recent "
                          "is 0; allowed: recent_share 1 (the default) or recent above 0")
    if s.warp_prior_variance != SurrogateSettings.model_fields["warp_prior_variance"].default and s.kernel != "warped":
        path = ("algorithm", "surrogate", "warp_prior_variance")
        raise ConfigError(f"{source.where(path)}: 'algorithm.surrogate.warp_prior_variance' = "
                          f"{s.warp_prior_variance:g} sets the prior of the warped kernel's exponents, but "
                          f"algorithm.surrogate.kernel is {s.kernel!r}; allowed: kernel 'warped', or the default "
                          "variance")
    return config


def _check_design_variables(config: CampaignConfig, source: Any) -> None:
    """A blade campaign needs at least one design variable: a parameter that ``blade.fixed`` leaves free."""
    space = config.blade.space()
    if not space.names:
        b = config.blade
        raise ConfigError(f"{source.where(('blade', 'fixed'))}: 'blade.fixed': every parameter of {b.mode.value} "
                          f"{b.continuity.value} blades is fixed, so there is nothing to optimise: a campaign needs "
                          "at least one design variable (remove a name from blade.fixed; `millfoil space` lists "
                          "them); to compute one blade, use `millfoil evaluate`")


def _check_evaluations(config: CampaignConfig, source: Any) -> None:
    """The campaign's evaluations (population and every generation's offspring) within :data:`MAX_EVALUATIONS`."""
    a = config.algorithm
    if a.evaluations > MAX_EVALUATIONS:
        raise ConfigError(f"{source.where(('algorithm',))}: 'algorithm': population + (generations - 1) x offspring "
                          f"= {a.population:,} + {a.generations - 1:,} x {a.batch:,} = {a.evaluations:,} "
                          f"evaluations, more than the limit of {MAX_EVALUATIONS:,} (a week of a 1 000-worker "
                          "cluster at 10 minutes per evaluation): lower generations, population or offspring")


# Upper limits of the ``execution:`` section's values (their lower ones are those of the fields in
# :mod:`optimizer.campaign.runner`), in docs/reference/errors.md, "Campaign values": ``{path: (range, upper,
# unit, why)}``.
EXECUTION_LIMITS: dict[tuple[str, ...], tuple[str, float, str, str]] = {
    ("execution", "workers"): ("[1, 10000]", 10_000, "", "worker processes on this machine or jobs on a "
                               "cluster; more than a week-long campaign of a million evaluations needs"),
    ("execution", "timeout"): ("(0, 604800] s", 604_800, " s", "an evaluation on the fine mesh takes hours, "
                               "not a week"),
    ("execution", "retries"): ("[0, 100]", 100, "", "a design that has lost its worker 100 times kills workers; "
                               "it is recorded worker_lost"),
    ("execution", "timeout_grace"): ("[0, 86400] s", 86_400, " s", "a worker still busy a day after its "
                                     "deadline is restarted"),
    ("execution", "cluster", "cores"): ("[1, 1024]", 1024, "", "the cores of one job on one node: the largest "
                                        "nodes have a few hundred"),
}
#: Memory of one job (``execution.cluster.memory``), bytes: at least this much per worker process, at most
#: :data:`MAX_JOB_MEMORY` per job.
MIN_WORKER_MEMORY = 256 * 2**20
MAX_JOB_MEMORY = 64 * 2**40
#: ``execution.cluster`` keys written into the job script's directives: one word each.
_CLUSTER_WORDS = ("queue", "account", "job_name", "interface")
#: ``execution.cluster`` keys written into the job script as they are (paths, lines): one line each.
_CLUSTER_LINES = ("python", "local_directory", "log_directory", "job_extra_directives", "job_script_prologue")


def _check_execution(config: CampaignConfig, source: Any) -> None:
    """The ``execution:`` values within :data:`EXECUTION_LIMITS`, the cluster's memory a size the schedulers
    accept, its names one word and its lines one line (a newline would end a job-script directive)."""
    e = config.execution

    def fail(path: tuple, text: str) -> None:
        raise ConfigError(f"{source.where(path)}: '{'.'.join(path)}' {text}")

    for path, (text, upper, unit, why) in EXECUTION_LIMITS.items():
        value = getattr(e.cluster, path[-1]) if path[1] == "cluster" else getattr(e, path[-1])
        if value is not None and value > upper:
            fail(path, f"= {value:g}{unit} is outside {text}: {why}" if isinstance(value, float)
                 else f"= {value}{unit} is outside {text}: {why}")
    c = e.cluster
    memory = _bytes(c.memory)
    if memory is None:
        fail(("execution", "cluster", "memory"), f"= {shorten(c.memory)} is not a memory size: a number and a unit, "
             "such as 4GiB, 500MB or 16GB (kB, MB, GB, TB in powers of 1000; KiB, MiB, GiB, TiB in powers of 1024)")
    if not c.worker_processes * MIN_WORKER_MEMORY <= memory <= MAX_JOB_MEMORY:
        fail(("execution", "cluster", "memory"), f"= {shorten(c.memory)} ({_size(memory)}) is outside "
             f"[{_size(c.worker_processes * MIN_WORKER_MEMORY)}, {_size(MAX_JOB_MEMORY)}] for "
             f"{c.worker_processes} worker process(es) per job: a worker needs about 256 MiB (the solver, and "
             "~5 kB per cell of its mesh); no node has more than 64 TiB")
    for name in _CLUSTER_WORDS + _CLUSTER_LINES:
        value = getattr(c, name)
        for i, text in enumerate(value if isinstance(value, tuple) else (value,)):
            if text is None:
                continue
            path = ("execution", "cluster", name, i) if isinstance(value, tuple) else ("execution", "cluster", name)
            words = name in _CLUSTER_WORDS
            if not text.strip() or (words and len(text.split()) != 1) or any(ch in text for ch in "\n\r\0"):
                fail(path, f"= {shorten(text)} is not {'one word' if words else 'one line'}: it is written into "
                     f"the job script {'as a directive' if words else 'as it is'}"
                     + ("; leave the key out for the scheduler's default" if words and not text.strip() else ""))
    if e.address is not None and (not e.address.strip() or len(e.address.split()) != 1):
        fail(("execution", "address"), f"= {shorten(e.address)} is not a scheduler address such as "
             "tcp://10.0.0.1:8786")


def _bytes(text: str) -> int | None:
    """Bytes of a memory size as dask-jobqueue reads it (``4GiB``, ``500MB``, ``16 GB``), or None."""
    from dask.utils import parse_bytes

    if not isinstance(text, str) or not any(ch.isdigit() for ch in text):
        return None
    try:
        return int(parse_bytes(text))
    except (ValueError, TypeError, OverflowError):
        return None


def _size(n: float) -> str:
    """``256 MiB``, ``64 TiB``: a byte count for a message."""
    for unit in ("B", "KiB", "MiB", "GiB"):
        if abs(n) < 1024:
            return f"{n:.4g} {unit}"
        n /= 1024
    return f"{n:.4g} TiB"


def _located(exc: ConfigError, default: tuple, config: CampaignConfig) -> tuple:
    """The path of the parameter a check's message names first (``parameter 'alpha'``, ``bounds of
    'alpha'``) in ``blade.bounds`` or ``blade.fixed``, else ``default``."""
    m = re.search(r"(?:parameter(?:\(s\))?|bounds of) '?([A-Za-z_0-9]+)", str(exc))
    if m and default[:1] == ("blade",):
        name = m.group(1)
        return ("blade", "fixed", name) if name in config.blade.fixed else ("blade", "bounds", name)
    return default
