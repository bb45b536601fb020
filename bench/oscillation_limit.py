"""How many of a campaign's oscillating designs each oscillation limit would accept.

For every run directory given, reads the store and, among the designs whose solve ended ``oscillating`` on
the campaign's chosen figures, takes each design's worst relative amplitude over those figures' monitors
(amplitude / |window mean|, the quantity ``convergence.max_amplitude`` limits). It prints how many of them
each limit in ``--limits`` accepts, and how many the run's own limit accepted. Nothing is solved: a store
can be judged again under another limit because the limit is not part of an evaluation's key.

    python bench/oscillation_limit.py runs/paper/medium/design_g1
    python bench/oscillation_limit.py runs/examples/paper/coarse/* --limits 0.01 0.03 0.06 0.1
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def worst_amplitudes(directory: Path) -> tuple[list[float], float, int]:
    """Worst relative amplitudes of the run's oscillating designs, the run's own limit, and its CFD count."""
    import yaml

    from optimizer.campaign.problem import worst_amplitude
    from optimizer.campaign.status import EvaluationStatus
    from optimizer.campaign.store import STORE_NAME, Store

    with Store(directory / STORE_NAME, readonly=True) as store:
        config = yaml.safe_load(store.campaign().config)
        rows = [r for r in store.evaluations() if r.status != EvaluationStatus.INFEASIBLE]
    figures = [o["figure"] for o in config.get("objectives", [])]
    figures += [c["figure"] for c in config.get("constraints", []) or []]
    worst = [worst_amplitude(row.monitors or {}, figures)[0] for row in rows if str(row.convergence) == "oscillating"]
    worst = [w for w in worst if not np.isnan(w)]
    return sorted(worst), float(config.get("convergence", {}).get("max_amplitude", 0.01)), len(rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories (hold campaign.sqlite)")
    parser.add_argument("--limits", nargs="+", type=float, default=[0.01, 0.02, 0.04, 0.06, 0.1, 0.2],
                        help="relative amplitudes to count against (default: %(default)s)")
    args = parser.parse_args(argv)
    from optimizer.campaign.store import STORE_NAME, stored

    missing = [str(d) for d in args.runs if not stored(d / STORE_NAME)]
    if missing:
        parser.error(f"no campaign store in {', '.join(missing)}")
    print("| run | CFD evaluations | oscillating | own limit: accepted | "
          + " | ".join(f"≤ {limit:.0%}" for limit in args.limits) + " |")
    print("|---" * (4 + len(args.limits)) + "|")
    for directory in args.runs:
        worst, own, evaluations = worst_amplitudes(directory)
        counts = [sum(w <= limit for w in worst) for limit in args.limits]
        print(f"| {directory} | {evaluations} | {len(worst)} | {own:.0%}: {sum(w <= own for w in worst)} | "
              + " | ".join(str(c) for c in counts) + " |")


if __name__ == "__main__":
    main()
