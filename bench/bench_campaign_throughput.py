"""Campaign throughput: evaluations per hour with 1 and 2 local workers, and the runner's overhead per task.

Real evaluations: the benchmark blade of ``configs/examples/bench_g1_design.yaml`` at the coarse level (or
``--level``), run through the campaign's worker function
(:func:`optimizer.campaign.record.evaluate_payload`, the same code a campaign runs) on the ``local``
backend (:mod:`optimizer.campaign.runner`: one single-threaded worker process per core). Every worker gets
``--per-worker`` evaluations, so both runs do the same work per worker; the speed-up is the ratio of the
rates (target: >= 1.8 with 2 workers on 2 cores).

Overhead: ``--noop`` tasks of a function that returns at once, on 2 workers. ``overhead per task`` is the
time a worker slot spends per task on everything but the evaluation (submission, scheduling, transfer,
the result loop): wall time x workers / tasks. Compared with the mean coarse evaluation time (target:
below 1 %).

Cluster start-up is not counted (it happens once per campaign). The machine's load average is printed
with the figures: other processes on the cores lengthen each evaluation and make the speed-up meaningless;
the workers' utilisation (time spent in evaluations / (workers x wall time)) is what the runner itself
controls.

    python bench/bench_campaign_throughput.py                        # 1 and 2 workers, 2 evaluations each
    python bench/bench_campaign_throughput.py --per-worker 1 --noop 500 --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optimizer.campaign.record import evaluate_payload  # noqa: E402
from optimizer.campaign.runner import Task, make_runner  # noqa: E402
from optimizer.config import load_config  # noqa: E402


def noop(payload: dict) -> dict:
    """A task that costs nothing: what remains of its time is the runner's."""
    return {}


def blade_payload(config_path: Path, level: str, max_iter: int | None) -> dict:
    """The campaign payload of the benchmark blade (``kind: blade``, resolved config, parameters)."""
    overrides = [f"mesh.level={level}"] + ([f"solver.max_iter={max_iter}"] if max_iter else [])
    data = load_config(config_path, overrides).model_dump(mode="json")
    return {"kind": "blade", "config": yaml.safe_dump(data), "parameters": data["blade"]["parameters"]}


def run_batch(workers: int, fn, payloads: list[dict], timeout: float) -> dict:
    """Run the payloads on a fresh local cluster of ``workers``; wall time excludes the cluster start."""
    tasks = [Task(f"b{i}", p, 0) for i, p in enumerate(payloads)]
    with make_runner({"backend": "local", "workers": workers, "timeout": timeout, "retries": 0}) as runner:
        load_before = os.getloadavg()[0]
        t0 = time.perf_counter()
        results = list(runner.run(fn, tasks))
        wall = time.perf_counter() - t0
    statuses = [r.status if r.record is None else r.record.status for r in results]
    busy = sum(r.seconds for r in results) / (workers * wall)  # share of the wall time workers spent on tasks
    return {"workers": workers, "tasks": len(tasks), "wall_s": wall, "per_hour": len(tasks) / wall * 3600,
            "utilisation": busy,
            "task_s": [r.seconds for r in results], "statuses": statuses,
            "load_before": load_before, "load_after": os.getloadavg()[0]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", type=Path, default=ROOT / "configs/examples/bench_g1_design.yaml")
    ap.add_argument("--level", default="coarse")
    ap.add_argument("--max-iter", type=int, default=None, help="cap the solver iterations (default: config's)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--per-worker", type=int, default=2, help="evaluations per worker (0: overhead only)")
    ap.add_argument("--noop", type=int, default=400, help="no-op tasks for the overhead (0: skip)")
    ap.add_argument("--timeout", type=float, default=3600.0)
    ap.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = ap.parse_args(argv)

    print(f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC  {platform.node()}  {os.cpu_count()} cores  "
          f"python {platform.python_version()}  load {os.getloadavg()[0]:.1f}")
    out: dict = {"date": datetime.now(UTC).isoformat(timespec="minutes"), "cores": os.cpu_count(),
                 "level": args.level, "max_iter": args.max_iter, "runs": []}

    if args.noop:
        noop_run = run_batch(2, noop, [{}] * args.noop, args.timeout)
        overhead = noop_run["wall_s"] * 2 / args.noop
        out["overhead_s_per_task"] = overhead
        print(f"runner overhead: {args.noop} no-op tasks on 2 workers in {noop_run['wall_s']:.2f} s -> "
              f"{overhead * 1e3:.1f} ms of a worker slot per task "
              f"(median latency {statistics.median(noop_run['task_s']) * 1e3:.1f} ms)")

    payload = blade_payload(args.config, args.level, args.max_iter)
    for workers in args.workers if args.per_worker else ():
        run = run_batch(workers, evaluate_payload, [payload] * (workers * args.per_worker), args.timeout)
        out["runs"].append(run)
        print(f"{workers} worker(s): {run['tasks']} {args.level} evaluations in {run['wall_s']:.1f} s -> "
              f"{run['per_hour']:.1f} evaluations/hour; mean evaluation {statistics.mean(run['task_s']):.1f} s; "
              f"workers busy {run['utilisation'] * 100:.0f} % of the time; statuses {sorted(set(run['statuses']))}; "
              f"load {run['load_before']:.1f} -> {run['load_after']:.1f}")

    rates = {r["workers"]: r["per_hour"] for r in out["runs"]}
    if 1 in rates and 2 in rates:
        out["speedup_2"] = rates[2] / rates[1]
        print(f"speed-up with 2 workers: {out['speedup_2']:.2f}x (target >= 1.8)")
    if args.noop and out["runs"]:
        solve = statistics.mean(s for r in out["runs"] for s in r["task_s"])
        out["overhead_fraction"] = out["overhead_s_per_task"] / solve
        print(f"overhead per task / mean {args.level} evaluation: {out['overhead_fraction'] * 100:.3f} % "
              f"(target < 1 %)")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
