"""What one evaluation of a surrogate's marginal likelihood and its gradient costs, per kernel: the inner
loop of every fit (scikit-learn's L-BFGS-B calls it some 60 times per model and generation).

Random designs in the unit box and a smooth response; the time does not depend on what the values mean.
CPU time per evaluation, the best of five rounds of ten, one BLAS thread (as the driver fits).

    python bench/bench_kernel.py                     # 200 designs (the training cap), 15 variables
    python bench/bench_kernel.py --designs 400 --variables 20
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def seconds_per_evaluation(kernel_name: str, n: int, d: int) -> float:
    from optimizer.campaign.surrogate import _regressor

    X = np.random.default_rng(0).random((n, d))
    y = (X**13).sum(axis=1) + np.sin(3.0 * X[:, 0])
    model = _regressor(d, None, kernel_name)
    model.optimizer = None                  # fitted at the starting hyperparameters: only the set-up
    model.fit(X, y)
    theta = model.kernel_.theta
    best = np.inf
    for _ in range(5):
        start = time.process_time()
        for _ in range(10):
            model.log_marginal_likelihood(theta, eval_gradient=True)
        best = min(best, (time.process_time() - start) / 10)
    return best


def main(argv: list[str] | None = None) -> None:
    from threadpoolctl import threadpool_limits

    from optimizer.campaign.config import KERNELS

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--designs", type=int, default=200)
    parser.add_argument("--variables", type=int, default=15)
    args = parser.parse_args(argv)
    print(f"# marginal likelihood and gradient: {args.designs} designs, {args.variables} variables; "
          f"machine {platform.node()}, {os.cpu_count()} cores")
    print("| kernel | hyperparameters | ms CPU per evaluation |\n|---|---|---|")
    with threadpool_limits(limits=1):
        for name in KERNELS:
            hyperparameters = len(_hyperparameters(name, args.variables))
            ms = 1e3 * seconds_per_evaluation(name, args.designs, args.variables)
            print(f"| {name} | {hyperparameters} | {ms:.1f} |")


def _hyperparameters(kernel_name: str, d: int) -> np.ndarray:
    from optimizer.campaign.surrogate import _regressor

    return _regressor(d, None, kernel_name).kernel.theta


if __name__ == "__main__":
    main()
