"""Surrogate-assisted against plain NSGA-II on the analytic suite: CFD evaluations to reach plain's front.

Every run is an ordinary campaign: the script writes a campaign file per case, method and seed under
``--out`` and runs ``millfoil run FILE --out DIR --quiet`` (the same driver, store and CLI as a blade
campaign); finished stores are kept and reused, so an interrupted benchmark continues where it stopped.

Cases: ZDT1, ZDT2, ZDT3 and two-objective DTLZ2 with 20 variables; the constrained MW1, MW2, MW3, MW7 with
15; each plain and with injected failures (a hidden region of 7 % of the box that fails, plus 2 % random
failures). Methods: plain NSGA-II (population 100, 50 generations: 5 000 evaluations) and the surrogate
(population 100, a batch of 20 per generation, 46 generations: 1 000 evaluations), both with the
configuration's defaults otherwise.

Figures, per case: the hypervolume of every feasible design evaluated so far (the run's archive), against
the reference point (1.1, 1.1), after each evaluation in the order they were stored; the **target** is the
median over seeds of plain NSGA-II's value at 5 000 evaluations; for each surrogate seed, the number of
evaluations it needs to reach the target (failed evaluations count). Pass: median ≤ 1 000 and at least
90 % of seeds get there (``--stop-at-target`` stops each surrogate run there, with SIGTERM as a user would:
the same figure for a fraction of the time, without the hypervolume at 1 000). Also, at pysamoo's budget
(ZDT1, 10 variables, 200 evaluations: an initial population of 50, then batches of 10), the IGD of the
archive's front against ZDT1's true front.

    python bench/bench_surrogate.py                                   # the whole suite, 11 seeds, 2 jobs
    python bench/bench_surrogate.py --cases zdt1 mw3 --seeds 3 --failures none
    python bench/bench_surrogate.py --cases mw1 mw2 --kernel additive       # the surrogate with the additive kernel
    python bench/bench_surrogate.py --cases mw1 --kernel additive --coordinate-search
    python bench/bench_surrogate.py --cases mw1 --kernel warped --coordinate-search
    python bench/bench_surrogate.py --cases mw2 mw3 --kernel warped --coordinate-search --stop-at-target
    python bench/bench_surrogate.py --cases dtlz2 --kernel warped --coordinate-search --recent 50 --stop-at-target
    python bench/bench_surrogate.py --cases mw2 --kernel warped --coordinate-search --recent 50 --training 250
    python bench/bench_surrogate.py --cases mw2 --kernel warped --coordinate-search --initial 100 --stop-at-target
    python bench/bench_surrogate.py --cases mw2 mw1 dtlz2 --kernel warped --coordinate-search --warp-prior-variance 1.25
    python bench/bench_surrogate.py --cases mw1 --kernel warped --coordinate-search --hyperparameter-initial 100
    python bench/bench_surrogate.py --report-only --json docs/figures/surrogate.json
    python bench/bench_surrogate.py --igd-only --kernel additive --coordinate-search   # pysamoo's budget only
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
VARIABLES = {"zdt1": 20, "zdt2": 20, "zdt3": 20, "dtlz2": 20, "mw1": 15, "mw2": 15, "mw3": 15, "mw7": 15}
FAILURES = {"none": None, "injected": {"region": 0.07, "random": 0.02, "seed": 0}}
REFERENCE = (1.1, 1.1)
METHODS = {
    "plain": {"method": "nsga2", "population": 100, "generations": 50},
    "surrogate": {"method": "surrogate", "population": 100, "generations": 46, "offspring": 20},
}
PLAIN_BUDGET, SURROGATE_BUDGET = 5000, 1000
#: How often a run stopped at its target is checked (``--stop-at-target``), seconds.
TARGET_POLL_SECONDS = 15.0


def campaign(case: str, failures: str, method: str, seed: int, variables: int | None = None,
             algorithm: dict | None = None) -> dict:
    analytic = {"problem": case, "variables": variables or VARIABLES[case]}
    if FAILURES[failures]:
        analytic["failures"] = FAILURES[failures]
    return {"analytic": analytic,
            "objectives": [{"figure": "f1", "reference": REFERENCE[0]}, {"figure": "f2", "reference": REFERENCE[1]}],
            "algorithm": {**(algorithm or METHODS[method]), "seed": seed},
            "execution": {"backend": "inline"}, "output": {"sync": "normal"}}


def run_one(directory: Path, config: dict, target: float | None = None) -> float:
    """Run the campaign in ``directory`` unless a finished one is there; seconds it took (0 when reused).

    target: stop the run (SIGTERM, as a user would) once its archive's hypervolume reaches this value; a run
    stopped so counts as done."""
    from optimizer.campaign.store import STORE_NAME, Store

    store = directory / STORE_NAME
    if store.exists():
        with Store(store, readonly=True) as s:
            row = s.campaign()
        if row is not None and (row.state == "finished" or (target is not None and reached(directory, target))):
            return 0.0
        import shutil

        shutil.rmtree(directory)
    directory.parent.mkdir(parents=True, exist_ok=True)
    path = directory.parent / f"{directory.name}.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    t0 = time.perf_counter()
    # this checkout's millfoil, one BLAS thread per run (the jobs are the parallelism)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "optimizer.cli", "run", str(path), "--out", str(directory),
                             "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    stopped = False
    while target is not None and proc.poll() is None:
        time.sleep(TARGET_POLL_SECONDS)
        if proc.poll() is None and store.exists() and reached(directory, target):
            proc.send_signal(signal.SIGTERM)
            stopped = True
            break
    _, stderr = proc.communicate()
    if proc.returncode != 0 and not stopped:
        raise RuntimeError(f"{directory}: millfoil run exited {proc.returncode}: {stderr[-1500:]}")
    return time.perf_counter() - t0


def reached(directory: Path, target: float) -> bool:
    """Whether the archive of the run in ``directory`` has reached the hypervolume ``target``."""
    from pymoo.indicators.hv import HV

    from optimizer.campaign.store import STORE_NAME, Store

    with Store(directory / STORE_NAME, readonly=True) as s:
        F = np.array([r.minimised for r in s.evaluations() if r.feasible], float).reshape(-1, 2)
    F = F[np.all(F < REFERENCE, axis=1)]
    return len(F) > 0 and float(HV(ref_point=np.array(REFERENCE))(F)) >= target


def archive_hypervolume(directory: Path) -> np.ndarray:
    """Hypervolume of the feasible designs evaluated so far, after each evaluation (stored order)."""
    from optimizer.campaign.store import STORE_NAME, Store

    with Store(directory / STORE_NAME, readonly=True) as s:
        return rows_hypervolume(list(s.evaluations()))


def rows_hypervolume(rows) -> np.ndarray:
    """:func:`archive_hypervolume` of evaluation rows already read."""
    from pymoo.indicators.hv import HV

    from optimizer.report.analysis import hypervolume_trace

    rows = sorted(rows, key=lambda r: (r.generation, r.finished))
    inside = (r.minimised if r.feasible and np.all(np.array(r.minimised) < REFERENCE) else None for r in rows)
    return hypervolume_trace(inside, HV(ref_point=np.array(REFERENCE)))


def igd_zdt1(directory: Path) -> float:
    from pymoo.indicators.igd import IGD

    from optimizer.campaign.store import STORE_NAME, Store

    with Store(directory / STORE_NAME, readonly=True) as s:
        front = np.array([r.minimised for r in s.front()])
    f1 = np.linspace(0, 1, 1000)
    return float(IGD(np.column_stack([f1, 1 - np.sqrt(f1)]))(front))


def plain_target(out: Path, case: str, failures: str, seeds) -> float:
    """The case's target: the median over seeds of plain NSGA-II's hypervolume at its budget."""
    plain = [archive_hypervolume(out / case / failures / f"plain-{s}") for s in seeds]
    return float(np.median([h[min(PLAIN_BUDGET, len(h)) - 1] for h in plain]))


def summarise(out: Path, cases, failures, seeds, surrogate: str = "surrogate") -> dict:
    """Per case and failure mode: the target, each seed's evaluations to it, the verdict. A surrogate seed
    counts once it has finished or reached the target; the others (still running, not run) are left out and
    counted, and the case has no verdict until every seed counts."""
    from optimizer.campaign.store import STORE_NAME, Store, stored

    table = {}
    for case in cases:
        for fail in failures:
            target = plain_target(out, case, fail, seeds)
            plain = [archive_hypervolume(out / case / fail / f"plain-{s}") for s in seeds]
            sur = []
            for s in seeds:
                directory = out / case / fail / f"{surrogate}-{s}"
                if not stored(directory / STORE_NAME):
                    continue
                with Store(directory / STORE_NAME, readonly=True) as store:
                    finished = store.campaign().state == "finished"
                h = archive_hypervolume(directory)
                if finished or (len(h) and h[-1] >= target):
                    sur.append(h)
            needed = []
            for h in sur:
                hit = np.flatnonzero(h >= target)
                needed.append(int(hit[0]) + 1 if len(hit) else None)
            reached = [n for n in needed if n is not None]
            median = float(np.median([n if n is not None else np.inf for n in needed])) if needed else np.inf
            complete = len(sur) == len(seeds)
            table[f"{case}/{fail}"] = {
                "target": target, "needed": needed, "median": median, "seeds": len(sur),
                "reached": len(reached) / len(needed) if needed else 0.0,
                "plain_at_1000": float(np.median([h[min(SURROGATE_BUDGET, len(h)) - 1] for h in plain])),
                "surrogate_at_1000": (float(np.median([h[SURROGATE_BUDGET - 1] for h in sur]))
                                      if sur and all(len(h) >= SURROGATE_BUDGET for h in sur) else None),
                "pass": (median <= SURROGATE_BUDGET and len(reached) / len(needed) >= 0.9) if complete else None}
    return table


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(VARIABLES), choices=list(VARIABLES))
    parser.add_argument("--failures", nargs="+", default=list(FAILURES), choices=list(FAILURES))
    parser.add_argument("--seeds", type=int, default=11)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench" / "surrogate")
    parser.add_argument("--report-only", action="store_true", help="summarise the stores already there")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    # the blade benchmark names its runs the same way
    from bench_surrogate_blade import add_rule_arguments, rule_from

    add_rule_arguments(parser)
    parser.add_argument("--stop-at-target", action="store_true",
                        help="stop each surrogate run once it reaches its case's target (the plain runs go first): "
                        "the evaluations to the target are measured, the hypervolume at 1 000 is not")
    parser.add_argument("--igd-only", action="store_true",
                        help="run and report only the pysamoo-budget runs (ZDT1, 10 variables, 200 evaluations)")
    args = parser.parse_args()
    seeds = list(range(1, args.seeds + 1))
    rule = rule_from(args)
    name, settings = rule.name(), rule.settings()
    algorithm = {**METHODS["surrogate"], "surrogate": settings} if settings else METHODS["surrogate"]
    plain = [(args.out / c / f / f"plain-{s}", campaign(c, f, "plain", s)) for f in args.failures
             for c in args.cases for s in seeds if not args.igd_only]
    work = [(args.out / c / f / f"{name}-{s}", campaign(c, f, "surrogate", s, algorithm=algorithm), (c, f))
            for f in args.failures for c in args.cases for s in seeds if not args.igd_only]
    pysamoo = [(args.out / "pysamoo" / f"{name}-{s}",
                campaign("zdt1", "none", "surrogate", s, variables=10,
                         algorithm={**algorithm, "population": 50, "generations": 16, "offspring": 10}))
               for s in seeds]
    if not args.report_only:
        t0 = time.perf_counter()
        with ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(lambda item: run_one(*item), plain))
            targets = {(c, f): plain_target(args.out, c, f, seeds) if args.stop_at_target else None
                       for c in args.cases for f in args.failures if not args.igd_only}
            list(pool.map(lambda item: run_one(*item), pysamoo))
            list(pool.map(lambda item: run_one(item[0], item[1], targets[item[2]]), work))
        print(f"ran in {time.perf_counter() - t0:.0f} s with {args.jobs} jobs", file=sys.stderr)
    table = {} if args.igd_only else summarise(args.out, args.cases, args.failures, seeds, name)
    igd = [igd_zdt1(d) for d, _ in pysamoo]
    print(f"# surrogate vs plain NSGA-II, {len(seeds)} seeds; machine: {platform.node()}, {os.cpu_count()} cores, "
          f"{datetime.now(UTC):%Y-%m-%d}")
    if table:
        print("| case | failures | plain median HV at 5 000 (target) | plain at 1 000 | surrogate at 1 000 "
              "| evaluations to target: median | seeds reaching it | pass |")
        print("|---|---|---|---|---|---|---|---|")
    for key, row in table.items():
        case, fail = key.split("/")
        median = "never" if not np.isfinite(row["median"]) else f"{row['median']:.0f}"
        at_1000 = "stopped at target" if row["surrogate_at_1000"] is None else f"{row['surrogate_at_1000']:.4f}"
        verdict = {True: "yes", False: "no", None: f"not yet: {row['seeds']} of {len(seeds)} seeds"}[row["pass"]]
        needed = ", ".join("never" if n is None else str(n) for n in row["needed"])
        print(f"| {case} | {fail} | {row['target']:.4f} | {row['plain_at_1000']:.4f} | {at_1000} "
              f"| {median} ({needed}) | {row['reached']:.0%} | {verdict} |")
    print(f"\nZDT1, 10 variables, 200 evaluations: IGD median {np.median(igd):.4f} "
          f"(seeds: {', '.join(f'{v:.3f}' for v in igd)}); pysamoo's GPSAF reports 0.038")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"cases": table, "igd_zdt1_10_200": igd, "seeds": seeds}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
