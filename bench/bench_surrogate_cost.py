"""What the surrogate costs per generation on a blade campaign: model fit and pool screening against the
CFD the batch costs, as the store grows.

The store holds ``--stored`` blade designs of a paper case (default ``configs/paper/toolpath_g1.yaml``:
tool path, the most expensive geometric checks), geometrically feasible, found by small random steps from
feasible random designs. Their objective values are a smooth stand-in function of the parameters (this
measures time, and a Gaussian process's fit time depends on the number of designs and variables, not on
what the values mean); a tenth of them are stored as failed, so that the failure classifier is fitted too.
One surrogate generation is then asked exactly as the driver asks it
(:class:`optimizer.campaign.offspring.SurrogateOffspring`): fit on at most ``algorithm.surrogate.training``
designs, search a pool of ``pool × batch`` candidates (every one checked geometrically), choose the batch;
that is a campaign's first surrogate generation (**cold**: the hyperparameters fitted from their defaults).
Then the batch is stored as evaluated and the next generation asked, its fit warm-started from the
hyperparameters stored with the first, as in every later generation of a campaign (**warm**).

The batch's CFD wall time is ``batch × --cfd-seconds / --workers`` (default 13 s per medium design on 2
workers: below the 13–27 s per design, oscillating ones included, of the medium design G1 paper case's
generations, so the share is if anything overstated). Target: fit + screen below 5 % of it.

    python bench/bench_surrogate_cost.py                          # 500 and 2000 stored designs
    python bench/bench_surrogate_cost.py --stored 2000 --config configs/paper/design_g1.yaml
    python bench/bench_surrogate_cost.py --stored 2000 --training 100 200 400 800   # the cap's cubic cost
    python bench/bench_surrogate_cost.py --stored 2000 --kernel additive            # with the additive term
    python bench/bench_surrogate_cost.py --stored 2000 --set algorithm.surrogate.coordinate_search=true
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def feasible_designs(problem, n: int, seed: int) -> np.ndarray:
    """``n`` geometrically feasible designs: random ones first, then small steps from those found."""
    rng = np.random.default_rng(seed)
    found: list[np.ndarray] = []
    span = problem.upper - problem.lower
    while len(found) < 10:
        X = problem.lower + span * rng.random((2000, problem.n_var))
        ok = problem.prescreen(X)
        found += [x for x, s in zip(X, ok, strict=True) if s and problem.check(x).feasible]
    while len(found) < n:
        parents = np.array(found)[rng.integers(len(found), size=200)]
        X = np.clip(parents + 0.05 * span * rng.standard_normal(parents.shape), problem.lower, problem.upper)
        ok = problem.prescreen(X)
        found += [x for x, s in zip(X, ok, strict=True) if s and problem.check(x).feasible]
    return np.array(found[:n])


def stand_in(z: np.ndarray) -> tuple[float, float]:
    """Smooth objective values of a design scaled to the unit box (timing only, see the docstring)."""
    return -1e4 * (1 + np.sin(3 * z[0]) * z[1] + 0.3 * z[2:].mean()), 20 + 10 * (z[0] - 0.4) ** 2 + 5 * z[3]


def fill_store(store, problem, X: np.ndarray, rng, generation: int | None = None) -> None:
    """Store ``X`` with stand-in values, in generations of 100 (or all in ``generation``)."""
    from optimizer.campaign.record import EvaluationRecord
    from optimizer.campaign.store import EvaluationRow

    span = problem.upper - problem.lower
    for i, x in enumerate(X):
        if rng.random() < 0.1:
            a = problem.failed("diverged", "stand-in failure")
        else:
            f = stand_in((x - problem.lower) / span)
            record = EvaluationRecord("solved", "stand-in", convergence="converged",
                                      figures={"fy": f[0], "c_max": f[1]})
            a = problem._accepted(record.figures, "converged", "stand-in", None)
        store.add(EvaluationRow(key=problem.key(x), generation=i // 100 if generation is None else generation,
                                x=[float(v) for v in x],
                                parameters=problem.stored_parameters(x), status=a.status, reason=a.reason,
                                minimised=a.minimised, constraints=a.constraints, objectives=a.objectives,
                                convergence=a.convergence))


class _Algorithm:
    """What the surrogate step reads of pymoo's NSGA-II: the population's design vectors."""

    is_initialized = True

    def __init__(self, X):
        from pymoo.core.population import Population

        self.pop = Population.new("X", X)


def measure(config_path: Path, stored: int, seed: int, training: int | None = None, kernel: str = "product",
            settings: list[str] = ()) -> dict:
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.offspring import SurrogateOffspring
    from optimizer.campaign.problem import make_problem
    from optimizer.campaign.store import STORE_NAME, GenerationRow, Store

    config = load_campaign(config_path, ["algorithm.method=surrogate", f"algorithm.surrogate.kernel={kernel}",
                                         *([f"algorithm.surrogate.training={training}"] if training else []),
                                         *settings])
    problem = make_problem(config)
    X = feasible_designs(problem, stored, seed)
    with tempfile.TemporaryDirectory() as tmp, Store(Path(tmp) / STORE_NAME, sync="normal") as store:
        store.start_campaign(config.to_yaml(), seed, problem.version)
        fill_store(store, problem, X, np.random.default_rng(seed))
        step = SurrogateOffspring(problem, config, store)
        generation = stored // 100 + 1
        t0 = time.perf_counter()
        offspring, cold = step.ask(_Algorithm(X[-config.algorithm.population:]), generation)
        total = time.perf_counter() - t0
        # the next generation, as a campaign goes on: the batch evaluated, the fit warm-started from the
        # hyperparameters stored with this one
        fill_store(store, problem, offspring.get("X"), np.random.default_rng(seed + 1), generation)
        store.add_generation(GenerationRow(generation, [], [], [], [], 0, None, 0, None, {}, search=cold))
        _, warm = step.ask(_Algorithm(X[-config.algorithm.population:]), generation + 1)
    return {"stored": stored, "batch": len(offspring), "training": cold["training"],
            "drawn": cold["drawn"], "screened": cold["screened"], "fit_s": cold["seconds"]["fit"],
            "screen_s": cold["seconds"]["screen"], "total_s": total, "warm_fit_s": warm["seconds"]["fit"],
            "warm_screen_s": warm["seconds"]["screen"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", type=Path, default=ROOT / "configs" / "paper" / "toolpath_g1.yaml")
    parser.add_argument("--stored", type=int, nargs="+", default=[500, 2000])
    parser.add_argument("--cfd-seconds", type=float, default=13.0, help="wall seconds of one medium evaluation")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--training", type=int, nargs="+", default=[None],
                        help="training-set caps to compare (default: the configuration's)")
    from optimizer.campaign.config import KERNELS

    parser.add_argument("--kernel", choices=KERNELS, default="product",
                        help="algorithm.surrogate.kernel")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
                        help="another configuration key, e.g. algorithm.surrogate.coordinate_search=true")
    args = parser.parse_args()
    print(f"# surrogate cost per generation: {args.config.name}; machine {platform.node()}, {os.cpu_count()} cores")
    print("| stored | trained on | pool drawn | feasible | batch | fit s: cold / warm | screen s: cold / warm "
          "| batch CFD s | share: cold / warm |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, training in ((n, t) for n in args.stored for t in args.training):
        m = measure(args.config, n, args.seed, training, args.kernel, args.settings)
        cfd = m["batch"] * args.cfd_seconds / args.workers
        cold, warm = (m["fit_s"] + m["screen_s"]) / cfd, (m["warm_fit_s"] + m["warm_screen_s"]) / cfd
        print(f"| {n} | {m['training']} | {m['drawn']} | {m['screened']} | {m['batch']} | {m['fit_s']:.2f} / "
              f"{m['warm_fit_s']:.2f} | {m['screen_s']:.2f} / {m['warm_screen_s']:.2f} | {cfd:.0f} "
              f"| {cold:.1%} / {warm:.1%} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
