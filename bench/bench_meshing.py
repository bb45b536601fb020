"""Robustness and speed of the hybrid mesher over random blades of the Table 6 space.

For each (mode, continuity), draws ``--samples`` seeded random parameter sets, meshes every geometrically
feasible one at ``--level`` and checks the quality thresholds. Prints, per combination, the number of
feasible blades, meshing failures (with their reasons), median and worst meshing time, cell counts and the
worst quality figures; writes every record to ``--out`` (JSON lines) so that failures can be reproduced.

    python bench/bench_meshing.py --samples 200 --level medium --workers 2 --out runs/bench_meshing.jsonl

``--half-height`` sets the channel half-height (chords; default: the MeshSpec default, 5) to sweep narrow
channels, e.g. ``--half-height 1``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from geometry import ParameterSpace, evaluate_blade
from meshing import MeshSpec, build_mesh, check_quality

COMBINATIONS = [(m, c) for m in ("design", "toolpath") for c in ("G0", "G1", "C1", "G2", "C2")]


def mesh_one(task: tuple[str, str, list[float], str, dict]) -> dict:
    """Mesh one blade; never raises: the outcome and its reason are in the record."""
    mode, continuity, x, level, overrides = task
    spec = ParameterSpace.default(mode, continuity).spec(np.array(x))
    record = {"mode": mode, "continuity": continuity, "parameters": dict(spec.values), "level": level,
              "mesh": overrides}
    result = evaluate_blade(spec)
    if not result.feasible:
        return {**record, "status": "infeasible", "reason": "; ".join(c.name for c in result.violations)}
    start = time.perf_counter()
    try:
        mesh = build_mesh(result.profile, MeshSpec.for_level(level, **overrides))
        quality = check_quality(mesh).summary()
    except Exception as exc:  # noqa: BLE001 - a sweep records every failure, whatever its type
        return {**record, "status": "failed", "reason": f"{type(exc).__name__}: {exc}",
                "seconds": time.perf_counter() - start}
    return {**record, "status": "ok", "seconds": time.perf_counter() - start, "cells": mesh.n_cells,
            "min_angle": quality["min_angle_min"], "scaled_jacobian": quality["scaled_jacobian_min"],
            "non_orthogonality": quality["non_orthogonality_max"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200, help="random parameter sets per combination")
    parser.add_argument("--level", default="medium", choices=["coarse", "medium", "fine"])
    parser.add_argument("--seed", type=int, default=2013)
    parser.add_argument("--workers", type=int, default=2, help="processes (gmsh is one per process)")
    parser.add_argument("--half-height", type=float, default=None,
                        help="channel half-height, chords (default: the MeshSpec default)")
    parser.add_argument("--out", type=Path, default=Path("runs/bench_meshing.jsonl"))
    parser.add_argument("--modes", nargs="+", default=["design", "toolpath"], choices=["design", "toolpath"],
                        help="restrict the sweep (tool paths are rarely feasible: sweep them with more samples)")
    args = parser.parse_args()
    combinations = [(m, c) for m, c in COMBINATIONS if m in args.modes]

    overrides = {} if args.half_height is None else {"half_height": args.half_height}
    rng = np.random.default_rng(args.seed)
    tasks = [(m, c, x.tolist(), args.level, overrides)
             for m, c in combinations for x in ParameterSpace.default(m, c).sample(args.samples, rng)]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool, args.out.open("w") as out:
        records = []
        for record in pool.map(mesh_one, tasks, chunksize=4):
            out.write(json.dumps(record) + "\n")
            records.append(record)
    wall = time.perf_counter() - start

    print(f"# {args.level}, {args.samples} samples per combination, seed {args.seed}, {args.workers} workers, "
          f"half_height {overrides.get('half_height', MeshSpec().half_height)}, "
          f"{platform.machine()} Python {platform.python_version()}, wall {wall:.0f} s")
    print(f"{'combination':14s} {'feasible':>8s} {'failed':>6s} {'median s':>8s} {'worst s':>7s} "
          f"{'cells':>13s} {'min angle':>9s} {'min sJ':>6s}")
    for mode, continuity in combinations + [("all", "")]:
        rows = [r for r in records if mode == "all" or (r["mode"], r["continuity"]) == (mode, continuity)]
        done = [r for r in rows if r["status"] == "ok"]
        failed = [r for r in rows if r["status"] == "failed"]
        if not done:
            print(f"{mode + ' ' + continuity:14s} {len(done) + len(failed):8d} {len(failed):6d}")
            continue
        seconds = [r["seconds"] for r in done]
        cells = [r["cells"] for r in done]
        print(f"{mode + ' ' + continuity:14s} {len(done) + len(failed):8d} {len(failed):6d} "
              f"{np.median(seconds):8.2f} {max(seconds):7.2f} {min(cells):6d}-{max(cells):6d} "
              f"{min(r['min_angle'] for r in done):9.1f} {min(r['scaled_jacobian'] for r in done):6.3f}")
    for r in records:
        if r["status"] == "failed":
            print(f"FAILED {r['mode']} {r['continuity']}: {r['reason']}")


if __name__ == "__main__":
    main()
