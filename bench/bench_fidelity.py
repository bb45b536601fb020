"""Does the coarse mesh rank designs as the medium mesh does? Paired evaluations of random designs.

Draws ``--designs`` geometrically feasible random designs (seeded, uniform in the box, rejection-sampled as
a campaign's initial population is) of each paper case given, evaluates each at the coarse and at the
medium mesh level through the campaign's own worker function and judgement
(:func:`optimizer.campaign.record.evaluate_payload`, :meth:`CampaignProblem.assess`: the same convergence
policy, oscillating designs accepted below the amplitude limit), and reports

* Spearman's and Kendall's rank correlation of |F_Y| and of C_max between the levels, over the designs
  with values at both (oscillating ones included where the policy accepts them);
* how often the two levels disagree on whether a design has values at all;
* the cost ratio: mean wall seconds of a medium evaluation over a coarse one.

Results are appended to ``--out`` (JSON lines) as they come, so an interrupted study continues where it
stopped.

    python bench/bench_fidelity.py                                    # design_g1 and toolpath_g1, 30 each
    python bench/bench_fidelity.py --cases design_g1 --designs 50 --report-only
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

LEVELS = ("coarse", "medium")


def evaluate(problem, x) -> dict:
    from optimizer.campaign.record import evaluate_payload

    t0 = time.perf_counter()
    record = evaluate_payload(problem.payload(x))
    wall = time.perf_counter() - t0
    a = problem.assess(record, problem.check(x))
    return {"status": str(a.status), "class": None if a.convergence is None else str(a.convergence),
            "objectives": a.objectives, "wall_s": wall, "reason": a.reason}


def run(cases, designs: int, seed: int, out: Path) -> None:
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.problem import initial_population, make_problem

    done = {(r["case"], r["index"], r["level"]) for r in read(out)}
    for case in cases:
        path = ROOT / "configs" / "paper" / f"{case}.yaml"
        problems = {level: make_problem(load_campaign(path, [f"mesh.level={level}"])) for level in LEVELS}
        X, _ = initial_population(problems["medium"], designs, seed, 100000)
        for i, x in enumerate(X):
            for level in LEVELS:
                if (case, i, level) in done:
                    continue
                result = evaluate(problems[level], x)
                with out.open("a") as fh:
                    fh.write(json.dumps({"case": case, "index": i, "level": level, "x": [float(v) for v in x],
                                         **result}) + "\n")
                print(f"{case} {i + 1}/{designs} {level}: {result['status']} {result['class']} "
                      f"{result['objectives']} {result['wall_s']:.1f} s", file=sys.stderr, flush=True)


def read(out: Path) -> list[dict]:
    if not out.exists():
        return []
    return [json.loads(line) for line in out.read_text().splitlines() if line.strip()]


def report(out: Path) -> dict:
    from scipy.stats import kendalltau, spearmanr

    rows = read(out)
    pairs: dict[tuple, dict] = {}
    for r in rows:
        pairs.setdefault((r["case"], r["index"]), {})[r["level"]] = r
    complete = [p for p in pairs.values() if all(level in p for level in LEVELS)]
    both = [p for p in complete if all(p[level]["objectives"] for level in LEVELS)]
    disagree = sum(1 for p in complete if bool(p["coarse"]["objectives"]) != bool(p["medium"]["objectives"]))
    figures = {"pairs": len(complete), "with_values_at_both": len(both), "values_disagree": disagree}
    for label in ("|fy|", "c_max"):
        coarse = [p["coarse"]["objectives"][label] for p in both]
        medium = [p["medium"]["objectives"][label] for p in both]
        if len(both) > 2:
            figures[label] = {"spearman": float(spearmanr(coarse, medium).statistic),
                              "kendall": float(kendalltau(coarse, medium).statistic)}
    wall = {level: float(np.mean([p[level]["wall_s"] for p in complete])) for level in LEVELS} if complete else {}
    figures["mean_wall_s"] = wall
    figures["cost_ratio"] = wall["medium"] / wall["coarse"] if wall else None
    classes = {}
    for p in complete:
        key = f"{p['coarse']['class'] or p['coarse']['status']} / {p['medium']['class'] or p['medium']['status']}"
        classes[key] = classes.get(key, 0) + 1
    figures["classes_coarse_medium"] = classes
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=["design_g1", "toolpath_g1"])
    parser.add_argument("--designs", type=int, default=30, help="random designs per case")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench" / "fidelity.jsonl")
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if not args.report_only:
        run(args.cases, args.designs, args.seed, args.out)
    print(f"# coarse against medium; machine {platform.node()}, {os.cpu_count()} cores")
    print(json.dumps(report(args.out), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
