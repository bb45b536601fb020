"""Robustness of one evaluation (geometry → mesh → RANS solve) over random blades of the Table 6 space.

Draws seeded random feasible blades (:func:`geometry.draws.draw_blades`: round robin over the ten families, both
modes) until ``--blades`` blades are collected, evaluates each with
``optimizer.pipeline.evaluate`` in the paper's flow (the embedded defaults: water, C0 = 10 m/s, 5 %
inlet turbulence, k-ω SST) at ``--level``, and prints:

* the share of each outcome (``converged``, ``stationary``, ``oscillating``, ``not_converged``,
  ``diverged``, ``failed``) and the solve time spent per outcome;
* the lift amplitude and period of the ``oscillating`` ones (relative to their mean lift);
* a check that no figure is NaN or infinite.

Every record (blade index, parameters, status, figures, classification) goes to ``--out`` as JSON lines as
soon as it is done, so that any blade can be re-run on its own (``millfoil evaluate`` with its parameters).
A sweep that is stopped resumes: blades already in ``--out`` are not evaluated again. ``--shard K/N`` takes
every N-th blade from K (0-based), for splitting one sweep over processes or machines; ``--report FILE ...``
prints the summary of finished record files without evaluating anything. ``--save-monitors DIR`` writes
the full per-iteration histories of each solved blade to ``DIR/blade_<index>.npz`` (every monitor of
``FlowResults.monitors`` as ``monitor:<name>``, every scaled residual as ``residual:<name>``), for
replaying stop rules offline, e.g. with ``--set early_classify=false`` to the cap.

    python bench/bench_robustness.py --blades 50 --level medium --workers 2 --out runs/bench_robustness.jsonl
    python bench/bench_robustness.py --blades 50 --level medium --workers 1 --shard 0/2 --out runs/r0.jsonl
    python bench/bench_robustness.py --report runs/r0.jsonl runs/r1.jsonl
    python bench/bench_robustness.py --retry runs/r0.jsonl runs/r1.jsonl --max-iter 4000 --out runs/retry.jsonl
    python bench/bench_robustness.py --blades 50 --set alpha_u=0.95 --out runs/alpha095.jsonl   # settings trial
    python bench/bench_robustness.py --blades 20 --level coarse --mesh-set half_height=1.0 --out runs/channel.jsonl
    python bench/bench_robustness.py --blades 50 --set early_classify=false --save-monitors runs/hist --out runs/h.jsonl

``--retry FILE ...`` evaluates again the blades of those records whose status is ``--retry-status``
(default ``not_converged``), at their level, e.g. with a larger ``--max-iter``. ``--set KEY=VALUE``
(repeatable) overrides a key of the ``solver:`` section (the value read as JSON where it parses), e.g. to
sweep the blades with other solver settings before changing a default. ``--mesh-set KEY=VALUE`` does the
same for the ``mesh:`` section: the default domain is open (``half_height`` 5 chords), the campaigns and the
paper's configs use the confined channel (``half_height: 1.0``), where coarse meshes need the solver's start-up
relaxation (docs/decisions/0011-start-up-relaxation.md: this sweep with and without it).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from geometry.draws import draw_blades
from optimizer.campaign.runner import make_runner

#: The fields of a sweep task's payload, in :func:`task` order.
TASK_FIELDS = ("index", "mode", "continuity", "parameters", "level", "max_iter", "solver", "mesh", "save_dir")


def task(*values):
    """The campaign runner's :class:`~optimizer.campaign.runner.Task` of one blade (keyed by its index);
    ``values`` in :data:`TASK_FIELDS` order."""
    from optimizer.campaign.runner import Task

    payload = dict(zip(TASK_FIELDS, values, strict=True))
    return Task(key=str(payload["index"]), payload=payload, generation=0)


def evaluate_one(payload: dict) -> dict:
    """Evaluate one blade (a :func:`task`'s payload; the runner's ``deadline_s`` is not used); never raises:
    the outcome is in the record. With a save directory (``save_dir``), the monitor and residual histories of
    the solve go to ``blade_<index>.npz`` there."""
    from optimizer.config import Config
    from optimizer.pipeline import evaluate

    index, mode, cont, params, level, max_iter, solver, mesh, save_dir = (payload[k] for k in TASK_FIELDS)
    raw = {"blade": {"mode": mode, "continuity": cont, "parameters": params}, "mesh": {**mesh, "level": level},
           "solver": {**solver, **({"max_iter": max_iter} if max_iter else {})}}
    record = {"index": index, "mode": mode, "continuity": cont, "parameters": params, "level": level,
              **({"solver": solver} if solver else {}), **({"mesh": mesh} if mesh else {})}
    start = time.perf_counter()
    try:
        ev = evaluate(Config.from_mapping(raw))
    except Exception as exc:  # noqa: BLE001 - a sweep records every failure, whatever its type
        return {**record, "status": "failed", "stage": "?", "message": f"{type(exc).__name__}: {exc}",
                "seconds": time.perf_counter() - start}
    flow = getattr(ev.artifacts, "flow", None)
    if save_dir and flow is not None:
        save_histories(Path(save_dir) / f"blade_{index}.npz", flow)
    return {**record, **ev.summary(), "seconds_total": time.perf_counter() - start}


def save_histories(path: Path, flow) -> None:
    """The per-iteration histories of ``flow`` (a :class:`solver.FlowResults`) to the .npz ``path``:
    ``monitor:<name>`` for each monitor, ``residual:<name>`` for each scaled residual, and ``status``."""
    arrays = {f"monitor:{k}": np.asarray(v, dtype=float) for k, v in flow.monitors.items()}
    arrays.update({f"residual:{k}": np.asarray(v, dtype=float) for k, v in flow.residuals.items()})
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, status=np.asarray(flow.status), **arrays)


def _finite(x) -> bool:
    if isinstance(x, dict):
        return all(_finite(v) for v in x.values())
    if isinstance(x, list | tuple):
        return all(_finite(v) for v in x)
    return not isinstance(x, float) or math.isfinite(x)


def report(records: list[dict]) -> None:
    n = len(records)
    by = defaultdict(list)
    for r in records:
        by[r["status"]].append(r)
    print(f"{n} blades")
    print(f"  {'status':14s} {'share':>7s} {'solve s (median)':>17s} {'solve s (total)':>16s}")
    for status, rs in sorted(by.items(), key=lambda kv: -len(kv[1])):
        t = [r.get("seconds", {}).get("solve", 0.0) if isinstance(r.get("seconds"), dict) else 0.0 for r in rs]
        print(f"  {status:14s} {len(rs) / n:7.1%} {np.median(t):17.1f} {np.sum(t):16.1f}")
    osc = by.get("oscillating", [])
    for r in osc:
        c = r.get("classification") or {}
        amp = (c.get("amplitude") or {}).get("fy:blade")
        mean = (c.get("mean") or {}).get("fy:blade")
        per = (c.get("period") or {}).get("fy:blade")
        rel = abs(amp / mean) if amp is not None and mean else None
        print(f"  oscillating {r['mode']} {r['continuity']}: F_Y mean {mean} N/m, amplitude {amp} N/m"
              f" ({'-' if rel is None else f'{rel:.1%}'}), period {per} iterations")
    bad = [r for r in records if not _finite(r)]
    print(f"non-finite values in {len(bad)} records")
    for r in by.get("failed", []) + by.get("diverged", []):
        print(f"  {r['status']} {r['mode']} {r['continuity']} at {r.get('stage')}: {r.get('message')}")


def read_records(paths: list[Path]) -> list[dict]:
    """The records of finished blades in ``paths`` (missing files are empty), one per blade index."""
    records = {}
    for path in paths:
        if path.exists():
            for line in path.read_text().splitlines():
                if line.strip():
                    rec = json.loads(line)
                    records[rec.get("index", len(records))] = rec
    return [records[k] for k in sorted(records)]


def parse_shard(text: str) -> tuple[int, int]:
    k, n = (int(v) for v in text.split("/"))
    if not 0 <= k < n:
        raise argparse.ArgumentTypeError(f"--shard K/N needs 0 <= K < N, got {text!r}")
    return k, n


def overrides(items: list[str], section: str = "solver") -> dict:
    """``{key: value}`` of ``KEY=VALUE`` items of one configuration section, read by the configuration's own
    ``--set`` parser (:func:`optimizer.config.apply_overrides`: YAML values, its limits and messages)."""
    from optimizer.config import ConfigError, apply_overrides

    try:
        return apply_overrides({}, [f"{section}.{item}" for item in items]).get(section, {})
    except ConfigError as exc:
        raise SystemExit(str(exc)) from None


def check_overrides(solver: dict, mesh: dict, level: str) -> None:
    """Exit with the configuration's own message if the ``--set`` / ``--mesh-set`` overrides are not valid
    (a bad key would otherwise fail every blade of the sweep, one by one)."""
    from optimizer.config import Config, ConfigError

    try:
        Config.from_mapping({"mesh": {**mesh, "level": level}, "solver": solver}, blade_values=False)
    except ConfigError as exc:
        raise SystemExit(f"bench_robustness: {exc}") from None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blades", type=int, default=50)
    parser.add_argument("--level", default="medium", choices=["coarse", "medium", "fine"])
    parser.add_argument("--seed", type=int, default=2013)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--max-iter", type=int, default=0, help="override solver.max_iter (0: config default)")
    parser.add_argument("--out", type=Path, default=Path("runs/bench_robustness.jsonl"))
    parser.add_argument("--shard", type=parse_shard, default=(0, 1), help="K/N: every N-th blade from K")
    parser.add_argument("--report", type=Path, nargs="+", help="summarise these record files and stop")
    parser.add_argument("--retry", type=Path, nargs="+", help="re-evaluate blades of these record files")
    parser.add_argument("--retry-status", default="not_converged", help="which records --retry takes")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a solver: key (repeatable), e.g. alpha_u=0.95")
    parser.add_argument("--mesh-set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a mesh: key (repeatable), e.g. half_height=1.0 (the campaigns' channel)")
    parser.add_argument("--save-monitors", type=Path, metavar="DIR",
                        help="write each blade's monitor and residual histories to DIR/blade_<index>.npz")
    args = parser.parse_args()
    solver, mesh = overrides(args.set), overrides(args.mesh_set, "mesh")
    check_overrides(solver, mesh, args.level)
    if args.report:
        report(read_records(args.report))
        return
    k, n = args.shard
    save = None if args.save_monitors is None else str(args.save_monitors)
    done = {r["index"] for r in read_records([args.out]) if "index" in r}
    if args.retry:
        tasks = [task(r["index"], r["mode"], r["continuity"], r["parameters"], r["level"], args.max_iter, solver, mesh,
                      save)
                 for r in read_records(args.retry) if r["status"] == args.retry_status and r["index"] not in done]
    else:
        blades = draw_blades(args.blades, args.seed)
        tasks = [task(i, m, c, p, args.level, args.max_iter, solver, mesh, save) for i, (m, c, p) in enumerate(blades)
                 if i % n == k and i not in done]
    print(f"{platform.node()} {platform.processor() or platform.machine()}, {args.workers} workers, "
          + (f"retrying the {args.retry_status} blades of {len(args.retry)} record files"
             if args.retry else f"level {args.level}, seed {args.seed}, shard {k}/{n}")
          + (f", solver overrides {solver}" if solver else "") + (f", mesh overrides {mesh}" if mesh else "")
          + f": {len(done)} blades already in {args.out}, {len(tasks)} to evaluate")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    by_key = {t.key: t.payload for t in tasks}
    # the campaign runner: in this process for one worker, else a local dask cluster of --workers processes;
    # an evaluation stops at its own iteration cap, so the runner's timeout (a day) never cuts one short
    execution = {"backend": "inline"} if args.workers == 1 else {"backend": "local", "workers": args.workers}
    with make_runner({**execution, "timeout": 86400.0}) as runner, args.out.open("a") as fh:
        for i, result in enumerate(runner.run(evaluate_one, tasks), 1):
            rec = result.record
            if rec is None:                     # the worker was lost or raised: recorded as a failed blade
                payload = by_key[result.key]
                rec = {k: payload[k] for k in ("index", "mode", "continuity", "parameters", "level")} | {
                    "status": "failed", "stage": "runner", "message": f"{result.status}: {result.reason}",
                    "seconds_total": result.seconds}
            fh.write(json.dumps(rec, default=str) + "\n")
            fh.flush()
            print(f"[{i}/{len(tasks)}] {rec['mode']} {rec['continuity']}: {rec['status']}"
                  f" F_Y {rec.get('F_Y')} C_max {rec.get('C_max')} ({rec.get('seconds_total', 0):.0f} s)",
                  flush=True)
    report(read_records([args.out]))


if __name__ == "__main__":
    main()
