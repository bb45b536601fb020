"""Which designs the surrogate's models should learn from: the campaign's rule against one that keeps the newest.

A surrogate campaign fits its models on at most ``algorithm.surrogate.training`` designs (200), those of best
constrained non-dominated rank. A design the models predicted well and that turned out far worse ranks low,
so once the store holds more designs than the cap the models never learn from their own mistakes, and the
infill can go on sending batches to a region they keep misjudging. This script refits the models of a
finished run at the given generations exactly as the campaign did (same training data, kernel and cap) and
with the newest ``--recent`` designs kept whatever their rank (``algorithm.surrogate.recent``; the rest of
the cap by rank) and, with ``--initial``, the first designs stored (``algorithm.surrogate.initial``: the
initial population, spread over the box), and asks each about the batch the run evaluated at that
generation: the error the campaign made, and the ones it would have made.

Figures per generation and rule, for each objective: the mean signed error of the prediction (predicted −
computed, in units of the objective's spread over the designs stored before that generation: negative
is optimistic), and the
median standardised error |predicted − computed| / predicted std (about 0.67 for a calibrated model).

    python bench/bench_surrogate.py --cases dtlz2 --failures none --kernel warped --coordinate-search \\
        --stop-at-target --out runs/bench/surrogate
    python bench/bench_training_set.py runs/bench/surrogate/dtlz2/none/surrogate-warped-coordinate-3 \\
        --generations 10 20 30 40
    python bench/bench_training_set.py runs/bench/surrogate/dtlz2/none/surrogate-warped-coordinate-3 \
        --generations 20 30 40 --initial 100
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def refit(run: Path, generations: list[int], recent: int, initial: int = 0):
    """Per generation and rule: (generation, name, mean signed error per objective in units of the spread of
    the designs stored before it, median |z| per objective)."""
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.problem import make_problem
    from optimizer.campaign.store import STORE_NAME, Store

    config = load_campaign(run / "config.yaml")
    problem = make_problem(config)
    with Store(run / STORE_NAME, readonly=True) as store:
        for generation in generations:
            for name, bias, z in _refit_at(config, problem, store, generation, recent, initial):
                yield generation, name, bias, z


def _refit_at(config, problem, store, generation: int, recent: int, initial: int):
    from optimizer.campaign.offspring import SurrogateOffspring, training_data
    from optimizer.campaign.surrogate import Models

    settings = config.algorithm.surrogate
    modelled = SurrogateOffspring(problem, config, store).modelled
    data, _, _ = training_data(store, problem, generation, modelled)
    batch = [r for r in store.evaluations(generation) if r.ok]
    if not batch:
        raise SystemExit(f"generation {generation} has no evaluated design with values")
    X = np.array([r.x for r in batch], float)
    F = np.array([r.minimised for r in batch], float)

    spread = np.nanstd(data.F[~data.failed], axis=0)
    out = []
    rules = [(f"the run's ({settings.initial} first + {settings.recent} newest + best-ranked)", settings.recent,
              settings.initial),
             (f"{recent} newest + best-ranked", recent, 0)]
    if initial:
        rules.append((f"{initial} first + best-ranked", 0, initial))
    for name, newest, first in rules:
        models = Models(problem.lower, problem.upper, problem.objective_labels, modelled,
                        kernel=settings.kernel).fit(data, settings.training, recent=newest, initial=first)
        p = models.predict(X)
        error = p.mean - F
        out.append((name, error.mean(axis=0) / spread, np.median(np.abs(error) / p.std, axis=0)))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run", type=Path, help="a finished or stopped surrogate run directory")
    parser.add_argument("--generations", type=int, nargs="+", default=[10, 20, 30, 40])
    parser.add_argument("--recent", type=int, default=50, help="designs kept for being the newest (default 50)")
    parser.add_argument("--initial", type=int, default=0,
                        help="also refit with this many of the first designs stored kept (the initial population)")
    args = parser.parse_args()
    from threadpoolctl import threadpool_limits

    print(f"# {args.run}")
    print("| generation | training set | mean signed error / spread, per objective | median \\|z\\|, per objective |")
    print("|---|---|---|---|")
    with threadpool_limits(limits=1):
        for g, name, bias, z in refit(args.run, args.generations, args.recent, args.initial):
            print(f"| {g} | {name} | {', '.join(f'{v:+.3f}' for v in bias)} | "
                  f"{', '.join(f'{v:.2f}' for v in z)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
