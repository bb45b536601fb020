"""How well the surrogate's Gaussian processes rank the designs a search goes on to evaluate: the product
kernel alone against the product plus the additive term, plain or warped (``optimizer/campaign/additive.py``;
``--kernels`` chooses among them).

Protocol, per run: the models are fitted as a campaign fits them (at most 200 designs, those of best
constrained non-dominated rank, scaled to the unit box, ``normalize_y``, the bounded L-BFGS-B fit) on the
**first fifth** of the run's evaluations, and asked about the **rest** (at most 500 of them, evenly spread
in evaluation order): where the search went next, which is where the infill relies on them. Figure: the
Spearman rank correlation of predicted against computed values, per objective and constraint, and the log
marginal likelihood of the fit (higher: the data favour the kernel).

Runs: plain NSGA-II (pymoo, population 100, 50 generations, seed 1) on the analytic problems of the
surrogate benchmark, and the blade stores kept in ``runs/examples/surrogate-coarse`` (coarse design G1,
plain NSGA-II to 5 000; coarse tool path G1, the surrogate's 1 080).

    python bench/bench_surrogate_model.py                        # every analytic case and both blade stores
    python bench/bench_surrogate_model.py --cases mw1 mw2 --no-blade
    python bench/bench_surrogate_model.py --cases mw1 --no-blade --kernels additive warped
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

VARIABLES = {"zdt1": 20, "dtlz2": 20, "mw1": 15, "mw2": 15, "mw3": 15, "mw7": 15}
BLADE = {"design_g1": "runs/examples/surrogate-coarse/design_g1/nsga2-1",
         "toolpath_g1": "runs/examples/surrogate-coarse/toolpath_g1/surrogate-1"}
CAP = 200
TEST = 500


def analytic_run(case: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Every design plain NSGA-II evaluates on ``case``, in order: X (unit box), F, G, target labels."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.callback import Callback
    from pymoo.optimize import minimize
    from pymoo.problems import get_problem

    problem = get_problem(case, n_var=VARIABLES[case], **({"n_obj": 2} if case == "dtlz2" else {}))
    seen: list[tuple] = []

    class Keep(Callback):
        def notify(self, algorithm):
            off = algorithm.off if algorithm.off is not None else algorithm.pop
            G = off.get("G") if problem.n_ieq_constr else np.zeros((len(off), 0))
            seen.append((off.get("X"), off.get("F"), G))

    minimize(problem, NSGA2(pop_size=100), ("n_gen", 50), seed=1, callback=Keep(), verbose=False)
    X, F, G = (np.vstack([s[i] for s in seen]) for i in range(3))
    X = (X - problem.xl) / (problem.xu - problem.xl)
    return X, F, G, [f"f{i + 1}" for i in range(F.shape[1])] + [f"g{i + 1}" for i in range(G.shape[1])]


def blade_run(directory: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """The designs of a kept blade store that gave values, in evaluation order: X (unit box), F (minimised)."""
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.packed import unpacked_copy
    from optimizer.campaign.problem import make_problem
    from optimizer.campaign.store import Store

    problem = make_problem(load_campaign(directory / "config.yaml"))
    with Store(unpacked_copy(directory / "campaign.sqlite.xz"), readonly=True) as store:
        rows = [r for r in store.evaluations() if r.ok]
    rows.sort(key=lambda r: (r.generation, r.key))
    X = (np.array([r.x for r in rows]) - problem.lower) / (problem.upper - problem.lower)
    F = np.array([r.minimised for r in rows])
    return X, F, np.zeros((len(rows), 0)), list(problem.objective_labels)


def training_rows(F: np.ndarray, G: np.ndarray) -> np.ndarray:
    """The ``CAP`` rows a campaign would train on: best constrained non-dominated rank first."""
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    violation = np.clip(G, 0.0, None).sum(axis=1)
    rank = np.full(len(F), np.inf)
    ok = violation <= 0.0
    for r, members in enumerate(NonDominatedSorting().do(F[ok]) if ok.any() else []):
        rank[np.flatnonzero(ok)[members]] = r
    rank[~ok] = 1e5 + violation[~ok]
    return np.lexsort((-np.arange(len(F)), rank))[:CAP]


def compare(name: str, X, F, G, labels, kernels) -> None:
    from optimizer.campaign.surrogate import _regressor

    split = len(X) // 5
    train = training_rows(F[:split], G[:split])
    test = split + np.unique(np.linspace(0, len(X) - split - 1, TEST).astype(int))
    Y = np.column_stack([F, G])
    for j, label in enumerate(labels):
        cells = []
        for kernel in kernels:                  # the campaign's own regressor, cold (no stored hyperparameters)
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                gp = _regressor(X.shape[1], None, kernel).fit(X[train], Y[train, j])
            seconds = time.perf_counter() - t0
            rho = spearmanr(gp.predict(X[test]), Y[test, j])[0]
            cells.append(f"{rho:.3f} | {gp.log_marginal_likelihood_value_:.1f} | {seconds:.1f}")
        print(f"| {name} | {label.replace('|', chr(92) + '|')} | {' | '.join(cells)} |", flush=True)


def main() -> None:
    from optimizer.campaign.config import KERNELS

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(VARIABLES), choices=list(VARIABLES))
    parser.add_argument("--no-blade", action="store_true", help="leave out the kept blade stores")
    parser.add_argument("--kernels", nargs="+", default=["product", "additive"], choices=KERNELS,
                        help="algorithm.surrogate.kernel values to compare")
    args = parser.parse_args()
    print(f"# surrogate models out of sample; machine {platform.node()}, {len(__import__('os').sched_getaffinity(0))} "
          f"cores; train: best {CAP} of the first fifth, test: up to {TEST} of the rest")
    print("| run | target | " + " | ".join(f"{k}: Spearman | log-likelihood | fit s" for k in args.kernels) + " |")
    print("|---|---|" + "---|---|---|" * len(args.kernels))
    for case in args.cases:
        compare(case, *analytic_run(case), args.kernels)
    if not args.no_blade:
        for case, path in BLADE.items():
            compare(case, *blade_run(ROOT / path), args.kernels)


if __name__ == "__main__":
    main()
