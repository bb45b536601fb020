"""``millfoil profile`` (one blade and its feasibility) and ``millfoil space`` (a family's parameters)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from geometry import DEFAULT_TOLERANCE, BladeSpec, parameters_of
from optimizer.cli.common import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_OK, config_arguments, load
from optimizer.config import ConfigError
from optimizer.pipeline import StageFailure, build_blade
from optimizer.saving import PLOT_SUFFIXES, check_output_file, write_all

#: ``--tolerance`` range relative to the blade's largest length (chord, offsets, cutter radius), m/m.
#: Below it the N-buffer needs millions of needles (minutes); above it the outline is no longer the blade.
#: The default 1 µm is 1e-5 of the Table 4 chord.
TOLERANCE_RANGE = (1e-8, 1e-2)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``profile`` and ``space`` commands."""
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
        "Parameters and their units: docs/explanation/geometry.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    config_arguments(profile)
    profile.add_argument("--out", type=Path, metavar="CSV", help="write the profile points (x,y in m)")
    profile.add_argument("--plot", type=Path, metavar="PNG", help="write a figure of the blade")
    profile.add_argument("--tolerance", type=float, default=DEFAULT_TOLERANCE, metavar="M",
                         help=f"distance from the exact curves/envelope, m (default {DEFAULT_TOLERANCE:g}; "
                         f"{TOLERANCE_RANGE[0]:g} to {TOLERANCE_RANGE[1]:g} times the blade's largest length)")
    profile.add_argument("--json", action="store_true", help="print the summary as JSON")
    profile.set_defaults(run=run_profile)

    space = sub.add_parser(
        "space",
        help="list the parameters of a blade family and its optimisation space",
        description="Print every parameter of the configured (mode, continuity) with its unit, meaning and "
        "domain, and the optimisation space: design variables with bounds (Table 6 unless the config's "
        "blade.bounds/blade.fixed change them) and fixed values. CONFIG may be a blade file or a campaign "
        "file (the space its campaign searches).",
        epilog="Examples:\n"
        "  millfoil space                                        # Table 4's family: C2 design blades\n"
        "  millfoil space configs/paper/toolpath_c1.yaml         # a paper case's space\n"
        "  millfoil space --set blade.mode=toolpath --set blade.continuity=G2",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    config_arguments(space)
    space.set_defaults(run=run_space)


def run_profile(args: argparse.Namespace) -> int:
    config = load(args)
    blade_spec = config.blade.blade_spec()
    check_tolerance(args.tolerance, blade_spec)
    outputs = {"csv": args.out and check_output_file(args.out, "--out", (".csv",)),
               "plot": args.plot and check_output_file(args.plot, "--plot", PLOT_SUFFIXES)}
    start = time.perf_counter()
    try:
        result = build_blade(config, args.tolerance)
    except StageFailure as failure:
        print(f"millfoil: {failure.reason}", file=sys.stderr)
        return EXIT_FAILED
    seconds = time.perf_counter() - start
    profile = result.profile

    summary = {
        "mode": blade_spec.mode.value,
        "continuity": blade_spec.continuity.value,
        "parameters": dict(blade_spec.values),
        "outside_table6_bounds": blade_spec.outside_bounds(),
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
        write_all(_profile_files(profile, **outputs))
        summary.update({key: str(path) for key, path in outputs.items() if path})

    print(json.dumps(summary, indent=2) if args.json else _describe_profile(summary))
    return EXIT_OK if result.feasible else EXIT_INFEASIBLE


def check_tolerance(tolerance: float, blade_spec: BladeSpec) -> None:
    """ConfigError unless ``tolerance`` (m) is within :data:`TOLERANCE_RANGE` of the blade's largest length."""
    units = parameters_of(blade_spec.mode, blade_spec.continuity)
    size = max(v for name, v in blade_spec.values.items() if units[name].unit == "m")
    low, high = (f * size for f in TOLERANCE_RANGE)
    if not low <= tolerance <= high:     # also refuses nan and inf
        raise ConfigError(f"--tolerance {tolerance:g} m is outside [{low:.3g}, {high:.3g}] m, i.e. "
                          f"{TOLERANCE_RANGE[0]:g} to {TOLERANCE_RANGE[1]:g} times the blade's largest length "
                          f"({size:g} m): a smaller one costs minutes, a larger one is not the blade")


def _profile_files(profile, csv: Path | None, plot: Path | None) -> list:
    """The ``(path, write)`` pairs of the asked-for outputs of ``profile`` (written together)."""
    files = [(csv, profile.to_csv)] if csv else []
    if plot:
        from geometry.plot import plot_profile  # matplotlib is slow to import; only when asked

        files.append((plot, lambda path: plot_profile(profile, path)))
    return files


def _describe_profile(s: dict) -> str:
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


def run_space(args: argparse.Namespace) -> int:
    blade = _blade_section(args)
    space = blade.space()
    print(f"{blade.continuity.value} {blade.mode.value} blades: {len(space.names)} design variables")
    print(f"  {'name':9s} {'unit':4s} {'optimisation':24s} {'domain':16s} meaning")
    for name, param in parameters_of(blade.mode, blade.continuity).items():
        print(f"  {name:9s} {param.unit:4s} {space.role(name):24s} {param.domain_text:16s} {param.description}")
    return EXIT_OK


def _blade_section(args: argparse.Namespace):
    """The ``blade:`` section of CONFIG: a blade file's, or a campaign file's (told apart by a section only a
    campaign has: ``objectives:``, ``algorithm:`` …), validated by its own schema."""
    from optimizer.campaign.config import CampaignConfig, load_campaign
    from optimizer.config import Config, read_yaml

    campaign_only = set(CampaignConfig.model_fields) - set(Config.model_fields)
    if args.config is not None and campaign_only & set(read_yaml(args.config)):
        config = load_campaign(args.config, args.overrides)
        if config.analytic is not None:
            raise ConfigError(f"{args.config}: an analytic campaign has no blade space (its 'analytic:' section "
                              f"replaces the blade)")
        return config.blade
    return load(args, blade_values=False).blade
