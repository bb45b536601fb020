"""The ``millfoil`` command line: a thin layer over plain functions.

Exit status: 0 success, 2 bad input (configuration, override, file), 3 the blade is infeasible (its
constraints are printed; files are still written when the profile could be built), 4 a stage failed
(the mesh could not be built or is below the quality thresholds, or the flow solve diverged; the reason is
printed). ``millfoil evaluate`` returns 0 whenever the solve ran (its status, possibly ``not_converged``, is
printed).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from geometry import DEFAULT_TOLERANCE, evaluate_blade, parameters_of
from optimizer.config import ConfigError, load_config

EXIT_OK, EXIT_INPUT, EXIT_INFEASIBLE, EXIT_FAILED = 0, 2, 3, 4


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "run"):
        parser.print_help()
        return EXIT_INPUT
    try:
        return args.run(args)
    except ConfigError as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_INPUT


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="millfoil",
        description="Multi-objective shape optimisation of hydraulic blade profiles, designed directly or "
        "through the milling tool path that machines them (Vessaz et al. 2013).",
    )
    sub = parser.add_subparsers(title="commands", metavar="COMMAND")

    profile = sub.add_parser(
        "profile",
        help="build one blade profile and check its feasibility",
        description="Build one blade from a YAML file (or the embedded Table 4 blade), print its figures and "
        "constraints, and optionally write it as CSV and plot it. In toolpath mode the blade is what a "
        "cylindrical cutter leaves (N-buffer machining simulation).",
        epilog="Examples:\n"
        "  millfoil profile                                     # Table 4 C2 design blade\n"
        "  millfoil profile configs/examples/table5_g1_toolpath.yaml --plot table5.png\n"
        "  millfoil profile my.yaml --set alpha=20 --set blade.continuity=G1 --out blade.csv\n"
        "Parameters and their units: docs/geometry.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _config_arguments(profile)
    profile.add_argument("--out", type=Path, metavar="CSV", help="write the profile points (x,y in m)")
    profile.add_argument("--plot", type=Path, metavar="PNG", help="write a figure of the blade")
    profile.add_argument("--tolerance", type=float, default=DEFAULT_TOLERANCE, metavar="M",
                         help=f"distance from the exact curves/envelope, m (default {DEFAULT_TOLERANCE:g})")
    profile.add_argument("--json", action="store_true", help="print the summary as JSON")
    profile.set_defaults(run=run_profile)

    mesh = sub.add_parser(
        "mesh",
        help="mesh the fluid around one blade and report cell counts and quality",
        description="Build the hybrid mesh around one blade: a structured O-layer of quads between the blade "
        "and the convex hull of its offset, triangles from there to the rectangular domain. Prints cell "
        "counts and quality figures; fails (exit 4) if a cell is below the quality thresholds (minimum angle "
        "15°, scaled Jacobian 0.4), naming the worst cells.",
        epilog="Examples:\n"
        "  millfoil mesh --level coarse --plot mesh.png\n"
        "  millfoil mesh configs/examples/table5_g1_toolpath.yaml --out mesh.msh --set mesh.upstream=8\n"
        "Mesh options (the 'mesh:' section): docs/meshing.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _config_arguments(mesh)
    mesh.add_argument("--level", choices=["coarse", "medium", "fine"],
                      help="resolution level (default: the config's mesh.level, else medium)")
    mesh.add_argument("--out", type=Path, metavar="FILE", help="write the mesh (.msh gmsh 2.2, .vtu, ...)")
    mesh.add_argument("--plot", type=Path, metavar="PNG", help="write a figure: O-layer, leading and trailing edge")
    mesh.add_argument("--json", action="store_true", help="print the summary as JSON")
    mesh.set_defaults(run=run_mesh)

    evaluate = sub.add_parser(
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
        "What is computed and how: docs/evaluation.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _config_arguments(evaluate)
    evaluate.add_argument("--level", choices=["coarse", "medium", "fine"],
                          help="mesh resolution level (default: the config's mesh.level, else medium)")
    evaluate.add_argument("--save", type=Path, metavar="DIR", help="write mesh.msh, fields.vtu, wall.csv "
                          "(side,s,x,y,Cp,cf,yplus), result.json and the resolved config.yaml into DIR")
    evaluate.add_argument("--json", action="store_true", help="print the results as JSON")
    evaluate.add_argument("--every", type=int, default=50, metavar="N",
                          help="print solver progress every N iterations (default 50; 0: never)")
    evaluate.add_argument("--quiet", action="store_true", help="no progress on stderr")
    evaluate.set_defaults(run=run_evaluate)

    validate = sub.add_parser(
        "validate",
        help="run a solver validation case and compare it with published data",
        description="Solve a validation case with the bundled solver and print computed vs reference values "
        "with the error and the agreed tolerance. Cases: cavity (lid-driven cavity, Re = 100 and 1000, vs "
        "Ghia et al. 1982), cylinder (Schäfer-Turek DFG 2D-1, Re = 20), mms (manufactured solution, observed "
        "order of accuracy), flatplate (NASA TMR zero-pressure-gradient flat plate, k-omega SST), naca0012 "
        "(NASA TMR NACA 0012, Re = 6e6, k-omega SST). 'coarse' is the CI-size run; 'medium'/'fine' give the "
        "documented figures.",
    )
    validate.add_argument("case", help="cavity, cylinder, mms, flatplate or naca0012")
    validate.add_argument("--level", default="coarse", choices=["coarse", "medium", "fine"],
                          help="resolution (default coarse)")
    validate.add_argument("--alpha", type=float, default=None, metavar="DEG",
                          help="angle of attack in degrees (naca0012 only; default: both 0 and 10)")
    validate.add_argument("--json", action="store_true",
                          help="print one JSON object per compared quantity (name, computed, reference, error, "
                          "tolerance, pass)")
    validate.set_defaults(run=run_validate)

    space = sub.add_parser(
        "space",
        help="list the parameters of a blade family and its optimisation space",
        description="Print every parameter of the configured (mode, continuity) with its unit, meaning and "
        "domain, and the optimisation space: design variables with bounds (Table 6 unless the config's "
        "blade.bounds/blade.fixed change them) and fixed values.",
    )
    _config_arguments(space)
    space.set_defaults(run=run_space)
    return parser


def run_mesh(args: argparse.Namespace) -> int:
    from meshing import MeshingError, MeshQualityError, build_mesh, check_quality

    overrides = [*args.overrides, *([f"mesh.level={args.level}"] if args.level else [])]
    config = load_config(args.config, overrides)
    result = evaluate_blade(config.blade.spec())
    if not result.feasible:
        for c in result.violations:
            print(f"millfoil: infeasible blade: {c.name}: {c.reason}", file=sys.stderr)
        return EXIT_INFEASIBLE
    spec = config.mesh_spec()
    try:
        mesh = build_mesh(result.profile, spec)
        report = check_quality(mesh)
    except (MeshingError, MeshQualityError) as exc:
        print(f"millfoil: mesh failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    summary = {"level": spec.level, "points": mesh.n_points, **mesh.cell_counts(), "cells": mesh.n_cells,
               "first_cell_height_m": mesh.info["first_cell_height"], "layers": mesh.info["layers"],
               "seconds": mesh.info["time_total"], "quality": report.summary()}
    if args.out:
        mesh.write(args.out)
        summary["file"] = str(args.out)
    if args.plot:
        from meshing.plot import plot_mesh

        plot_mesh(mesh, args.plot, result.profile)
        summary["plot"] = str(args.plot)
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        q = summary["quality"]
        print(f"{spec.level} mesh: {summary['cells']} cells ({summary['quad']} quads, {summary['triangle']} "
              f"triangles), {summary['points']} nodes, built in {summary['seconds']:.2f} s\n"
              f"O-layer: {summary['layers']} layers, first cell {summary['first_cell_height_m'] * 1e6:.2f} µm "
              f"(y+ {spec.y_plus:g} at Re {spec.reynolds(config.blade.spec()['L']):.3g})\n"
              f"quality: min angle {q['min_angle_min']:.1f}° (threshold 15°), scaled Jacobian "
              f"{q['scaled_jacobian_min']:.3f} (threshold 0.4), max aspect ratio {q['aspect_ratio_max']:.3g}, "
              f"max skewness {q['skewness_max']:.3f}, non-orthogonality max {q['non_orthogonality_max']:.1f}° "
              f"mean {q['non_orthogonality_mean']:.1f}°")
        for key in ("file", "plot"):
            if key in summary:
                print(f"wrote {summary[key]}")
    return EXIT_OK


def run_evaluate(args: argparse.Namespace) -> int:
    from optimizer.evaluate import evaluate, save

    overrides = [*args.overrides, *([f"mesh.level={args.level}"] if args.level else [])]
    config = load_config(args.config, overrides)
    if args.every < 0:
        raise ConfigError(f"--every must be >= 0, got {args.every}")
    log = None if args.quiet else (lambda line: print(f"millfoil: {line}", file=sys.stderr, flush=True))
    ev = evaluate(config, log=log, every=args.every)
    written = save(ev, config, args.save) if args.save else []
    if args.json:
        summary = ev.summary()
        if written:
            summary["files"] = [str(p) for p in written]
        print(json.dumps(summary, indent=2, allow_nan=False))
    else:
        print(_describe_evaluation(ev, config))
        for path in written:
            print(f"wrote {path}")
    if ev.status == "infeasible":
        return EXIT_INFEASIBLE
    return EXIT_OK if ev.ok else EXIT_FAILED


def _describe_evaluation(ev, config) -> str:
    def num(v, fmt, unit=""):
        return "-" if v is None else f"{v:{fmt}}{unit}"

    spec = config.mesh_spec()
    fl = config.flow
    lines = [f"{config.blade.continuity.value} {config.blade.mode.value} blade, {ev.model} model, {spec.level} mesh, "
             f"C0 = {fl.speed:g} m/s, rho = {fl.density:g} kg/m³, mu = {fl.viscosity:g} Pa s"]
    if not ev.ok:
        lines.append(f"FAILED at stage {ev.stage}: {ev.status}: {ev.message}")
    else:
        rows = [("F_X", num(ev.fx, ".6g", " N/m"), num(ev.fx_span, ".6g", f" N over the {ev.span * 1e3:g} mm span")),
                ("F_Y", num(ev.fy, ".6g", " N/m"), num(ev.fy_span, ".6g", f" N over the {ev.span * 1e3:g} mm span")),
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
        c = ev.classification
        if c is not None and ev.status != "converged":
            period = c.dominant_period
            lines.append(f"  classification over the last {c.window} iterations: {c.status}"
                         + (f", period {period:.1f} iterations" if period else "") + f"; {c.reason}")
            for m in c.mean:
                lines.append(f"    {m:9s} mean {num(c.mean[m], '.6g')}, amplitude {num(c.amplitude[m], '.3g')}, "
                             f"drift {num(c.drift[m], '+.3g')}  ({c.monitor_status[m]})")
    times = ", ".join(f"{k} {v:.2f} s" for k, v in ev.seconds.items())
    lines.append(f"status {ev.status}{' (solver converged)' if ev.converged else ''} after "
                 f"{num(ev.iterations, 'd')} iterations on {num(ev.cells, 'd')} cells; {times}")
    if ev.ok:
        lines.append(ev.message)
    return "\n".join(lines)


def run_validate(args: argparse.Namespace) -> int:
    from solver.validation import CASES, run_case

    if args.case not in CASES:
        raise ConfigError(f"unknown validation case {args.case!r}; allowed: {', '.join(CASES)}")
    options = {}
    if args.alpha is not None:
        if args.case != "naca0012":
            raise ConfigError(f"--alpha applies to the naca0012 case only, not {args.case!r}")
        options["alpha"] = args.alpha
    report = run_case(args.case, args.level, **options)
    if args.json:
        for c in report.comparisons:
            print(json.dumps({"name": c.name, "computed": c.computed, "reference": c.reference,
                              "error": c.error, "tolerance": c.tolerance, "pass": c.passed}))
    else:
        print(f"{report.case} ({report.level}): {report.description}")
        width = max(len(c.name) for c in report.comparisons)
        print(f"  {'quantity':{width}s} {'computed':>12s} {'reference':>12s} {'error':>10s} {'tolerance':>10s}")
        for c in report.comparisons:
            print(f"  {c.name:{width}s} {c.computed:12.6g} {c.reference:12.6g} {c.error:10.4g} {c.tolerance:10.4g}"
                  f"  {'pass' if c.passed else 'FAIL'}")
        details = ", ".join(f"{k} {v}" for k, v in report.details.items())
        print(f"  {details}; {report.seconds:.1f} s")
        print("PASSED" if report.passed else "FAILED")
    return EXIT_OK if report.passed else EXIT_FAILED


def run_space(args: argparse.Namespace) -> int:
    config = load_config(args.config, args.overrides, blade_values=False)
    blade = config.blade
    space = blade.space()
    print(f"{blade.continuity.value} {blade.mode.value} blades: {len(space.names)} design variables")
    print(f"  {'name':9s} {'unit':4s} {'optimisation':24s} {'domain':16s} meaning")
    for name, param in parameters_of(blade.mode, blade.continuity).items():
        if name in space.fixed:
            role = f"fixed {space.fixed[name]:g}"
        else:
            i = space.names.index(name)
            role = f"[{space.lower[i]:g}, {space.upper[i]:g}]"
        lo, hi = param.domain
        domain = f"{'(' if param.open_low else '['}{lo:g}, {hi:g}]"
        print(f"  {name:9s} {param.unit:4s} {role:24s} {domain:16s} {param.description}")
    return EXIT_OK


def _config_arguments(parser: argparse.ArgumentParser) -> None:
    """The configuration file and ``--set`` overrides that every command reading a config takes."""
    parser.add_argument("config", nargs="?", type=Path, help="YAML configuration file (default: the embedded "
                        "defaults, i.e. the Table 4 blade)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                        help="override a value: a blade parameter (alpha=25, in m or deg) or a dotted key "
                        "(blade.mode=toolpath, mesh.level=fine); repeatable")


def run_profile(args: argparse.Namespace) -> int:
    config = load_config(args.config, args.overrides)
    spec = config.blade.spec()
    if not args.tolerance > 0:
        raise ConfigError(f"--tolerance must be positive, got {args.tolerance}")
    start = time.perf_counter()
    result = evaluate_blade(spec, args.tolerance)
    seconds = time.perf_counter() - start
    profile = result.profile

    summary = {
        "mode": spec.mode.value,
        "continuity": spec.continuity.value,
        "parameters": dict(spec.values),
        "outside_table6_bounds": spec.outside_bounds(),
        "feasible": result.feasible,
        "constraints": [{"name": c.name, "value": float(c.value), "satisfied": c.satisfied, "reason": c.reason}
                        for c in result.constraints],
        "seconds": seconds,
    }
    if profile is not None:
        summary.update(points=len(profile.points), area_m2=profile.area, max_thickness_m=profile.max_thickness,
                       leading_edge_m=profile.leading_edge.tolist(), tolerance_m=args.tolerance)
        if profile.machining is not None:
            summary.update(cutter_positions=profile.machining.cutter_positions,
                           gouged_needle_fraction=profile.machining.gouged_fraction)
        if args.out:
            profile.to_csv(args.out)
            summary["csv"] = str(args.out)
        if args.plot:
            from geometry.plot import plot_profile  # matplotlib is slow to import; only when asked

            plot_profile(profile, args.plot)
            summary["plot"] = str(args.plot)

    print(json.dumps(summary, indent=2) if args.json else _describe(summary))
    return EXIT_OK if result.feasible else EXIT_INFEASIBLE


def _describe(s: dict) -> str:
    units = {n: p.unit for n, p in parameters_of(s["mode"], s["continuity"]).items()}
    lines = [f"{s['continuity']} {s['mode']} blade"]
    for name, value in s["parameters"].items():
        shown = f"{value * 1e3:g} mm" if units[name] == "m" else f"{value:g} {units[name]}".rstrip(" -")
        flag = "   (outside Table 6 range)" if name in s["outside_table6_bounds"] else ""
        lines.append(f"  {name:9s} {shown}{flag}")
    lines.append("constraints (value <= 0 is feasible):")
    for c in s["constraints"]:
        lines.append(f"  [{'ok' if c['satisfied'] else 'VIOLATED'}] {c['name']:16s} {c['value']:+.4g}  {c['reason']}")
    if "points" in s:
        lines.append(f"profile: {s['points']} points within {s['tolerance_m'] * 1e6:g} µm, area "
                     f"{s['area_m2'] * 1e6:.3f} mm², max thickness {s['max_thickness_m'] * 1e3:.3f} mm")
    if "cutter_positions" in s:
        lines.append(f"N-buffer: {s['cutter_positions']} cutter positions, "
                     f"{100 * s['gouged_needle_fraction']:.1f} % of needles gouged by another position")
    lines.append(f"built in {s['seconds'] * 1e3:.0f} ms")
    for key in ("csv", "plot"):
        if key in s:
            lines.append(f"wrote {s[key]}")
    lines.append("FEASIBLE" if s["feasible"] else "INFEASIBLE")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
