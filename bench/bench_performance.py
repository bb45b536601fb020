"""Performance of one blade evaluation (geometry → mesh → solve → figures) at the configured solver settings.

For the benchmark blade (``configs/examples/bench_g1_design.yaml``) and ``--blades`` random Table 6 blades
(the first ones of ``bench/bench_robustness.py``'s seeded draw), at each ``--levels`` level, ``--repeats``
times, prints per case the medians of:

* cells, status, outer iterations, time per iteration (wall, and CPU of this process);
* iterations and time to lift within 0.5 % and 0.1 % of its final value (the last ``fy:blade`` monitor;
  for a solve that does not settle, the final value is only the last iterate's);
* the stage times (geometry, mesh, solve, post) and the total, wall and CPU seconds; C_L and C_max.

Time with one BLAS/OpenMP thread (``OMP_NUM_THREADS=1``, the solver also limits BLAS to one thread); the
machine's load average is printed, as other jobs inflate wall times (CPU times much less so).

    OMP_NUM_THREADS=1 python bench/bench_performance.py --levels coarse medium --blades 2 --repeats 3
    OMP_NUM_THREADS=1 python bench/bench_performance.py --levels medium --blades 0 --set algorithm=simple \\
        --set alpha_u=0.7 --set alpha_p=0.3 --set pressure_gradient=least_squares  # SIMPLE, the alternative of
        decision 0010
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from geometry.draws import draw_blades

ROOT = Path(__file__).parents[1]

BENCHMARK = ROOT / "configs" / "examples" / "bench_g1_design.yaml"


def iterations_within(history: np.ndarray, tol: float) -> int:
    """First iteration (1-based) from which ``history`` stays within ``tol`` (relative) of its last value."""
    ref = history[-1]
    off = np.flatnonzero(np.abs(history - ref) > tol * abs(ref))
    return 1 if off.size == 0 else int(off[-1]) + 2


def run_case(raw: dict, overrides: list[str]) -> dict:
    """One evaluation of the blade configuration ``raw`` (a mapping) with ``solver.<key>=value`` overrides."""
    from optimizer.config import Config, apply_overrides
    from optimizer.pipeline import evaluate

    raw = apply_overrides(raw, [f"solver.{item}" for item in overrides])
    c0, t0 = time.process_time(), time.perf_counter()
    ev = evaluate(Config.from_mapping(raw))
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    flow = ev.artifacts.flow
    row = {"status": ev.status, "message": ev.message, "cells": ev.cells, "iterations": ev.iterations, "c_l": ev.c_l,
           "c_max": ev.c_max, "total_s": wall, "total_cpu_s": cpu, **{f"{k}_s": v for k, v in ev.seconds.items()}}
    if flow is not None and flow.iterations:
        per_it = flow.wall_time / flow.iterations
        fy = np.asarray(flow.monitors["fy:blade"])
        row.update(ms_per_iteration=1e3 * per_it, lift_0_5=iterations_within(fy, 5e-3),
                   lift_0_1=iterations_within(fy, 1e-3))
        row.update(s_lift_0_5=row["lift_0_5"] * per_it, s_lift_0_1=row["lift_0_1"] * per_it)
    return row


def cases(n_random: int, levels: list[str]) -> list[tuple[str, dict]]:
    """``(name, raw configuration)`` of the benchmark blade and the first ``n_random`` random blades."""
    import yaml

    bench = yaml.safe_load(BENCHMARK.read_text())
    blades = [("benchmark", bench)]
    if n_random:
        for i, (mode, cont, params) in enumerate(draw_blades(n_random, 2013)):
            blades.append((f"random{i} {mode} {cont}",
                           {"blade": {"mode": mode, "continuity": cont, "parameters": params}}))
    return [(f"{name} {level}", {**raw, "mesh": {**raw.get("mesh", {}), "level": level}})
            for level in levels for name, raw in blades]


def median_row(rows: list[dict]) -> dict:
    """Medians of the numeric entries over repeats; the other entries from the first repeat."""
    out = dict(rows[0])
    for key, value in rows[0].items():
        values = [r.get(key) for r in rows]
        if isinstance(value, int | float) and not isinstance(value, bool) and all(v is not None for v in values):
            out[key] = statistics.median(values)
    return out


COLUMNS = [("cells", "{:.0f}"), ("status", "{}"), ("iterations", "{:.0f}"), ("ms_per_iteration", "{:.1f}"),
           ("lift_0_5", "{:.0f}"), ("lift_0_1", "{:.0f}"), ("s_lift_0_5", "{:.1f}"), ("s_lift_0_1", "{:.1f}"),
           ("mesh_s", "{:.1f}"), ("solve_s", "{:.1f}"), ("total_s", "{:.1f}"), ("total_cpu_s", "{:.1f}"),
           ("c_l", "{:.4f}"), ("c_max", "{:.3f}")]


def print_table(results: list[tuple[str, dict]]) -> None:
    head = ["case"] + [c for c, _ in COLUMNS]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for name, row in results:
        cells = [fmt.format(row[c]) if row.get(c) is not None else "—" for c, fmt in COLUMNS]
        print("| " + " | ".join([name] + cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["coarse", "medium"])
    parser.add_argument("--blades", type=int, default=2, help="random Table 6 blades besides the benchmark blade")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="solver setting override (SimpleSettings field), repeatable")
    parser.add_argument("--out", type=Path, help="JSON lines of every run")
    args = parser.parse_args()
    print(f"# {platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, "
          f"{time.strftime('%Y-%m-%d %H:%M')}, settings {args.set or 'defaults'}")
    results = []
    for name, raw in cases(args.blades, args.levels):
        rows = []
        for rep in range(args.repeats):
            row = run_case(raw, args.set)
            rows.append(row)
            print(f"# {name} repeat {rep + 1}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                                           for k, v in row.items()), flush=True)
            if args.out:
                with args.out.open("a") as fh:
                    fh.write(json.dumps({"case": name, "repeat": rep, "settings": args.set, **row}) + "\n")
        results.append((name, median_row(rows)))
    print(f"# load average at the end {os.getloadavg()[0]:.1f}; medians of {args.repeats} repeat(s)")
    print_table(results)


if __name__ == "__main__":
    main()
