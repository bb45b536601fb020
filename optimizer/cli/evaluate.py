"""``millfoil evaluate``: the whole pipeline for one blade (:func:`optimizer.pipeline.evaluate`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from optimizer.cli.common import (
    EXIT_FAILED,
    EXIT_INFEASIBLE,
    EXIT_OK,
    config_arguments,
    level_argument,
    load,
    progress_printer,
)
from optimizer.config import Config, ConfigError
from optimizer.evaluation import Evaluation
from optimizer.pipeline import evaluate
from optimizer.saving import check_output_directory, save


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``evaluate`` command."""
    parser = sub.add_parser(
        "evaluate",
        help="evaluate one blade: mesh it, solve the flow, report forces, C_L, C_max and convergence",
        description="Run the whole pipeline for one blade: geometry and feasibility, hybrid mesh and its "
        "quality check, steady RANS (k-omega SST) or laminar solve, then the figures of the paper: F_X, F_Y "
        "(N/m and N for the span depth), C_L (Eq. 23), C_max, C_p,min = 1 - C_max²/C0², y+ on the blade, and "
        "the convergence class (converged, oscillating: window means, not_converged, diverged). "
        "Progress goes to stderr, the results table (or JSON) to stdout. Exit status: 0 solved (check the "
        "status: not_converged values are unreliable), 2 bad input, 3 infeasible blade, 4 a stage failed "
        "(mesh below the quality thresholds, diverged solve).",
        epilog="Examples:\n"
        "  millfoil evaluate configs/examples/bench_g1_design.yaml --level coarse\n"
        "  millfoil evaluate my.yaml --set solver.model=laminar --set flow.speed=0.2 --json\n"
        "  millfoil evaluate my.yaml --save runs/one   # mesh.msh fields.vtu wall.csv result.json config.yaml\n"
        "What is computed and how: docs/explanation/evaluation.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    config_arguments(parser)
    level_argument(parser, "mesh resolution level")
    parser.add_argument("--save", type=Path, metavar="DIR", help="write mesh.msh, fields.vtu, wall.csv "
                        "(side,s,x,y,Cp,cf,yplus), result.json and the resolved config.yaml into DIR")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--every", type=int, default=50, metavar="N",
                        help="print solver progress every N iterations (default 50; 0: never)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(run=run_evaluate)


def run_evaluate(args: argparse.Namespace) -> int:
    config = load(args)
    if args.every < 0:
        raise ConfigError(f"--every must be >= 0, got {args.every}")
    if args.save:
        check_output_directory(args.save, "--save")    # before the solve, not after it
    config.warn_reynolds(config.blade.blade_spec().values["L"])
    evaluation = evaluate(config, log=progress_printer(args.quiet), every=args.every)
    written = save(evaluation, config, args.save) if args.save else []
    if args.json:
        summary = evaluation.summary()
        if written:
            summary["files"] = [str(p) for p in written]
        print(json.dumps(summary, indent=2, allow_nan=False))
    else:
        print(describe_evaluation(evaluation, config))
        for path in written:
            print(f"wrote {path}")
    if evaluation.status == "infeasible":
        return EXIT_INFEASIBLE
    return EXIT_OK if evaluation.ok else EXIT_FAILED


def describe_evaluation(ev: Evaluation, config: Config) -> str:
    """The results table of ``millfoil evaluate`` (SI units, one figure a line, then the status)."""
    def num(v, fmt, unit=""):
        return "-" if v is None else f"{v:{fmt}}{unit}"

    fl = config.flow
    lines = [f"{config.blade.continuity.value} {config.blade.mode.value} blade, {ev.model} model, "
             f"{config.mesh_spec().level} mesh, C0 = {fl.speed:g} m/s, rho = {fl.density:g} kg/m³, "
             f"mu = {fl.viscosity:g} Pa s"]
    if not ev.ok:
        lines.append(f"FAILED at stage {ev.stage}: {ev.status}: {ev.message}")
    else:
        span = f" N over the {ev.span * 1e3:g} mm span"
        rows = [("F_X", num(ev.fx, ".6g", " N/m"), num(ev.fx_span, ".6g", span)),
                ("F_Y", num(ev.fy, ".6g", " N/m"), num(ev.fy_span, ".6g", span)),
                ("C_L", num(ev.c_l, ".5g"), "Eq. 23: F_Y / (rho C0²/2 · L · span)"),
                ("C_max", num(ev.c_max, ".6g", " m/s"), "largest cell-centre velocity magnitude"),
                ("C_p,min", num(ev.cp_min, ".5g"), "1 - C_max²/C0²"),
                ("C_p wall min", num(ev.cp_wall_min, ".5g"), "p_ref = inlet mean static pressure"),
                ("y+ blade", f"max {num(ev.yplus_max, '.3g')}, mean {num(ev.yplus_mean, '.3g')}",
                 "wall-adjacent cell centres")]
        width = max(len(r[0]) for r in rows)
        lines += [f"  {name:{width}s}  {value:30s} {note}" for name, value, note in rows]
        if ev.values_from and ev.values_from != "final iterate":
            lines.append(f"  (F_X, F_Y, C_max: {ev.values_from})")
        for name, why in ev.missing.items():
            lines.append(f"  {name}: none ({why})")
        lines += _describe_classification(ev, num)
    times = ", ".join(f"{k} {v:.2f} s" for k, v in ev.seconds.items())
    lines.append(f"status {ev.status}{' (solver converged)' if ev.converged else ''} after "
                 f"{num(ev.iterations, 'd')} iterations on {num(ev.cells, 'd')} cells; {times}")
    if ev.ok:
        lines.append(ev.message)
    return "\n".join(lines)


def _describe_classification(ev: Evaluation, num) -> list[str]:
    """The classification's lines, for a solve that did not converge."""
    c = ev.classification
    if c is None or ev.status == "converged":
        return []
    period = c.dominant_period
    lines = [f"  classification over the last {c.window} iterations: {c.status}"
             + (f", period {period:.1f} iterations" if period else "") + f"; {c.reason}"]
    for m in c.mean:
        lines.append(f"    {m:9s} mean {num(c.mean[m], '.6g')}, amplitude {num(c.amplitude[m], '.3g')}, "
                     f"drift {num(c.drift[m], '+.3g')}  ({c.monitor_status[m]})")
    return lines
