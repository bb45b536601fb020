"""Where MW2's runs stall: distance variables left in the far basin of its distance function.

MW2 (Ma & Wang 2019, pymoo's ``MW2``) has f1 = x1 and f2 = g - x1 with the distance function
g = 1 + Σᵢ [0.1/n zᵢ² + 1.5 - 1.5 cos(2π zᵢ)], zᵢ = 1 - exp(-10 (xᵢ - i/n)²), i = 1 … n-1. Each distance
variable has two basins: zᵢ = 0 at xᵢ = i/n, where its term is 0, and zᵢ → 1 at the bound far from i/n,
where cos(2π zᵢ) → 1 again and the term is only 0.1/n (0.0067 with n = 15), behind a barrier of 3. A front
found with k variables in the far basin lies about k × 0.0067 above the true one in f2, and a step that
does not clear the barrier's width never reaches the near basin.

For each run: its archive front (every feasible design evaluated, non-dominated), their median distance
excess g - 1 (= f1 + f2 - 1: how far above the true front), the number of distance
variables with zᵢ > 0.5 in each front design (median and largest), which variables are so in most front
designs, which variables were at home (near enough i/n to beat the far basin) in at most 2 % of the designs
evaluated after the initial population, and the archive's hypervolume against (1.1, 1.1).

    python bench/bench_surrogate.py --cases mw2 --failures none --kernel warped --coordinate-search \\
        --recent 50 --stop-at-target --out runs/bench/surrogate
    python bench/mw2_basins.py runs/bench/surrogate/mw2/none/surrogate-warped-coordinate-recent50-*
    python bench/mw2_basins.py runs/bench/surrogate/mw2/none/surrogate-warped-coordinate-recent50-6 --probe 30
    python bench/mw2_basins.py runs/bench/surrogate/mw2/none/surrogate-warped-coordinate-recent50-9 --probe 30 \
        --kernel additive
    python bench/mw2_basins.py runs/bench/surrogate/mw2/none/surrogate-warped-coordinate-recent50-9 --probe 30 \
        --ensemble
    python bench/mw2_basins.py runs/bench/surrogate/mw2/none/surrogate-warped-coordinate-recent50-* --search 30

``--probe GENERATION`` refits a surrogate run's models as the campaign did before that generation (warm-started
from the hyperparameters it stored with the generation before) and asks
them, for every far-basin variable of every front design stored before it, what moving that one variable to
its optimum i/n does to f2: the median predicted and true change, the share of moves predicted to improve
f2, the share that could improve it in the infill's optimistic view (the moved design's mean − κ·std below
the design's mean, κ = ``infill.KAPPA``), and the median predicted standard deviation. ``--kernel`` and
``--recent`` fit them otherwise, on the same data (another kernel from its default starting
hyperparameters: the stored ones are another kernel's). ``--ensemble`` mixes the warm-started fit with one
from the kernel's default start, equally weighted (mean of the means; variance: mean of the variances plus
the variance of the means), the fit-to-fit disagreement turned into predicted uncertainty.

``--search GENERATION`` runs the campaign's coordinate search on the same models, started from the front
designs stored before that generation, and counts for its mean starts and its optimistic ones the far
variables it sends home, those it leaves far, and the variables at home at the start that it sends into the
far basin.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def far_basin(X: np.ndarray) -> np.ndarray:
    """``(designs, n - 1)``: True where a distance variable of MW2 is in its far basin (zᵢ > 0.5)."""
    n = X.shape[1]
    i = np.arange(1, n)
    return 1.0 - np.exp(-10.0 * (X[:, 1:] - i / n) ** 2) > 0.5


def at_home(X: np.ndarray) -> np.ndarray:
    """``(designs, n - 1)``: True where a distance variable of MW2 is in the part of its near basin that beats
    the far one (|xᵢ - i/n| < 0.039: 1.5 (1 - cos 2π zᵢ) < 0.1/n)."""
    n = X.shape[1]
    return np.abs(X[:, 1:] - np.arange(1, n) / n) < 0.039


def summary(run: Path) -> tuple[int, float, float, int, list[int], list[int], float]:
    """(front designs, their median g - 1 (= f1 + f2 - 1), median and largest far-basin count per design,
    variables far in most of them (1-based, x2 … xn), variables at home in at most 2 % of the designs
    evaluated after the initial population, archive hypervolume)."""
    from bench_surrogate import rows_hypervolume

    from optimizer.campaign.store import STORE_NAME, Store

    with Store(run / STORE_NAME, readonly=True) as store:
        front = store.front()
        rows = list(store.evaluations())
    offspring = np.array([r.x for r in rows if r.generation > 0], float)
    if not front:
        return 0, float("nan"), float("nan"), 0, [], [], 0.0
    unvisited = [int(k) + 2 for k in np.flatnonzero(at_home(offspring).mean(axis=0) <= 0.02)]
    excess = float(np.median([sum(r.minimised) - 1.0 for r in front]))
    far = far_basin(np.array([r.x for r in front], float))
    mostly = [int(k) + 2 for k in np.flatnonzero(far.mean(axis=0) > 0.5)]
    counts = far.sum(axis=1)
    return (len(front), excess, float(np.median(counts)), int(counts.max()), mostly, unvisited,
            float(rows_hypervolume(rows)[-1]))


def refit(run: Path, generation: int, kernel: str | None = None, recent: int | None = None, ensemble: bool = False):
    """The models of ``run`` fitted before ``generation`` as the campaign fitted them (warm-started from the
    hyperparameters it stored with the generation before), with what they are asked about: (models — one,
    or with ``ensemble`` two, the second from the kernel's default start —, front designs ``(k, n)`` and
    their minimised objectives stored before ``generation``, the run's hypervolume reference point, the
    problem, its surrogate settings). kernel, recent: fit them so instead of as the run did."""
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.offspring import SurrogateOffspring, training_data
    from optimizer.campaign.problem import make_problem
    from optimizer.campaign.store import STORE_NAME, Store, non_dominated
    from optimizer.campaign.surrogate import Models

    config = load_campaign(run / "config.yaml")
    problem = make_problem(config)
    settings = config.algorithm.surrogate
    with Store(run / STORE_NAME, readonly=True) as store:
        modelled = SurrogateOffspring(problem, config, store).modelled
        data, _, _ = training_data(store, problem, generation, modelled)
        rows = [r for r in store.evaluations() if r.generation < generation and r.feasible]
        before = [g for g in store.generations() if g.generation < generation]
        reference = store.campaign().reference
    # another kernel starts from its default: the stored hyperparameters are the run's kernel's
    theta = (before[-1].search or {}).get("theta") if before and kernel in (None, settings.kernel) else None

    def fitted(start):
        return Models(problem.lower, problem.upper, problem.objective_labels, modelled,
                      kernel=kernel or settings.kernel).fit(data, settings.training, start,
                                                            recent=settings.recent if recent is None else recent)

    models = [fitted(theta)] + ([fitted(None)] if ensemble else [])
    F = np.array([r.minimised for r in rows], float)
    keep = non_dominated(F)
    X = np.array([r.x for r, k in zip(rows, keep, strict=True) if k], float)
    return models, X, F[keep], reference, problem, settings


def probe(run: Path, generation: int, kernel: str | None = None, recent: int | None = None,
          ensemble: bool = False) -> tuple[int, int, float, float, float, float, float]:
    """(front designs, far variables moved, median predicted and true change of f2, share predicted to
    improve, share that could improve at mean − κ·std, median predicted std of f2) for the models fitted
    before ``generation`` (:func:`refit`); with ``ensemble`` their mixture (the module docstring)."""
    from pymoo.problems.multi.mw import MW2

    from optimizer.campaign.infill import KAPPA

    models, X, _, _, _, _ = refit(run, generation, kernel, recent, ensemble)
    n = X.shape[1]
    pairs = []
    for x in X:
        for k in np.flatnonzero(far_basin(x[None])[0]):
            moved = x.copy()
            moved[k + 1] = (k + 1) / n
            pairs += [x, moved]
    if not pairs:
        return len(X), 0, float("nan"), float("nan"), float("nan"), float("nan"), float("nan")
    Y = np.array(pairs)
    fits = [m.predict(Y) for m in models]
    mean = np.mean([p.mean[:, 1] for p in fits], axis=0)
    std = np.sqrt(np.mean([p.std[:, 1] ** 2 for p in fits], axis=0) + np.var([p.mean[:, 1] for p in fits], axis=0))
    true = MW2(n_var=n).evaluate(Y, return_values_of=["F"])
    predicted = mean[1::2] - mean[0::2]
    hopeful = mean[1::2] - KAPPA * std[1::2] < mean[0::2]
    actual = true[1::2, 1] - true[0::2, 1]
    return (len(X), len(predicted), float(np.median(predicted)), float(np.median(actual)),
            float(np.mean(predicted < 0)), float(np.mean(hopeful)), float(np.median(std)))


def search(run: Path, generation: int) -> list[tuple[str, int, int, int, int, int, int]]:
    """Where the campaign's coordinate search (:func:`~optimizer.campaign.infill.search_coordinates`) on the
    models fitted before ``generation`` takes MW2's distance variables, started from the front designs
    stored before it: per view (``mean``: the even starts; ``optimistic``: the odd ones, at mean − κ·std), (view,
    starts, far variables at the starts, of them sent home, of them left in the far basin, variables at home
    at the starts, of them sent into the far basin). The campaign starts it from the inner search's best
    designs on the models instead; the front designs are the ones whose variables a step home would
    improve."""
    from optimizer.campaign.infill import search_coordinates

    models, X, F, reference, problem, settings = refit(run, generation)
    moved = search_coordinates(models[0], X, problem.lower, problem.upper, settings.failure_limit,
                               problem.prescreen, F, reference, np.random.default_rng(generation))
    before, after, home, was_home = far_basin(X), far_basin(moved), at_home(moved), at_home(X)
    out = []
    for parity, view in ((0, "mean"), (1, "optimistic")):
        rows = np.arange(len(X)) % 2 == parity
        b, a, h, w = before[rows], after[rows], home[rows], was_home[rows]
        out.append((view, int(rows.sum()), int(b.sum()), int((b & h).sum()), int((b & a).sum()), int(w.sum()),
                    int((w & a).sum())))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", type=Path, nargs="+", help="MW2 run directories (finished or stopped)")
    parser.add_argument("--probe", type=int, metavar="GENERATION",
                        help="ask the models fitted before this generation about moving far variables home")
    from optimizer.campaign.config import KERNELS

    parser.add_argument("--kernel", choices=KERNELS, help="with --probe: fit with this kernel instead of the run's")
    parser.add_argument("--recent", type=int, help="with --probe: fit with this recent instead of the run's")
    parser.add_argument("--ensemble", action="store_true",
                        help="with --probe: mix the warm-started fit with one from the default start")
    parser.add_argument("--search", type=int, metavar="GENERATION",
                        help="run the coordinate search on the models fitted before this generation from the front")
    args = parser.parse_args()
    from threadpoolctl import threadpool_limits

    if args.search is not None:
        columns = ["run", "generation", "view", "starts", "far variables", "sent home", "left far",
                   "variables at home", "sent far"]
        rows = ([run.name, args.search, *counts] for run in args.runs for counts in search(run, args.search))
    elif args.probe is not None:
        columns = ["run", "generation", "front designs", "far variables moved",
                   "change of f2, median: predicted, true", "predicted to improve", "could improve (mean − κ·std)",
                   "predicted std of f2, median"]

        def probed(run):
            size, moves, predicted, actual, better, hopeful, std = probe(run, args.probe, args.kernel, args.recent,
                                                                         args.ensemble)
            return [run.name, args.probe, size, moves, f"{predicted:+.4f}, {actual:+.4f}", f"{better:.0%}",
                    f"{hopeful:.0%}", f"{std:.4f}"]

        rows = (probed(run) for run in args.runs)
    else:
        columns = ["run", "front designs", "g - 1, median", "far-basin variables per design: median, largest",
                   "far in most", "at home in ≤ 2 % of the offspring", "hypervolume"]

        def summarised(run):
            size, excess, median, largest, mostly, unvisited, hv = summary(run)
            far, rare = (", ".join(f"x{k}" for k in ks) or "-" for ks in (mostly, unvisited))
            return [run.name, size, f"{excess:.4f}", f"{median:.0f}, {largest}", far, rare, f"{hv:.4f}"]

        rows = (summarised(run) for run in args.runs if run.is_dir())
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))
    with threadpool_limits(limits=1):      # the refits are compared across runs: one thread each, as in a campaign
        for row in rows:
            print("| " + " | ".join(map(str, row)) + " |", flush=True)
    return 0

if __name__ == "__main__":
    sys.exit(main())
