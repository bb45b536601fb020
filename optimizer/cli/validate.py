"""``millfoil validate``: a solver validation case against published data (:mod:`solver.validation`)."""

from __future__ import annotations

import argparse
import inspect
import json
import textwrap

from optimizer.cli.common import EXIT_FAILED, EXIT_OK, LEVEL_CHOICES
from optimizer.config import ConfigError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``validate`` command."""
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
    validate.add_argument("--level", default="coarse", choices=LEVEL_CHOICES, help="resolution (default coarse)")
    # The airfoil's angle of attack (not the blade's chord angle, the blade parameter ``alpha``).
    validate.add_argument("--alpha", dest="angle_of_attack", type=float, default=None, metavar="DEG",
                          help="angle of attack in degrees (naca0012 only; default: both 0 and 10)")
    validate.add_argument("--json", action="store_true",
                          help="print one JSON object per compared quantity (name, computed, reference, error, "
                          "tolerance, pass)")
    validate.set_defaults(run=run_validate)


def run_validate(args: argparse.Namespace) -> int:
    from solver.validation import CASES, run_case  # the validation cases load only for this command

    if args.case not in CASES:
        raise ConfigError(f"unknown validation case {args.case!r}; allowed: {', '.join(CASES)}")
    options = {}
    if args.angle_of_attack is not None:
        if args.case != "naca0012":
            raise ConfigError(f"--alpha applies to the naca0012 case only, not {args.case!r}")
        options["alpha"] = args.angle_of_attack
    report = run_case(args.case, args.level, **options)
    if args.json:
        for c in report.comparisons:
            print(json.dumps({"name": c.name, "computed": c.computed, "reference": c.reference,
                              "error": c.error, "tolerance": c.tolerance, "pass": c.passed}))
    else:
        print(textwrap.fill(f"{report.case} ({report.level}): {_description(CASES[args.case], report.description)}",
                            width=100, subsequent_indent="  "))
        width = max(len(c.name) for c in report.comparisons)
        print(f"  {'quantity':{width}s} {'computed':>12s} {'reference':>12s} {'error':>10s} {'tolerance':>10s}")
        for c in report.comparisons:
            print(f"  {c.name:{width}s} {c.computed:12.6g} {c.reference:12.6g} {c.error:10.4g} {c.tolerance:10.4g}"
                  f"  {'pass' if c.passed else 'FAIL'}")
        print("\n".join(_details(report.details, "  ")))
        print(f"  {report.seconds:.1f} s")
        print("PASSED" if report.passed else "FAILED")
    return EXIT_OK if report.passed else EXIT_FAILED


def _description(case, fallback: str) -> str:
    """The first paragraph of the case's docstring, whole (the report keeps only its first line)."""
    doc = inspect.getdoc(case) or fallback
    return " ".join(doc.split("\n\n")[0].split())


def _details(details: dict, indent: str) -> list[str]:
    """Lines ``name: key value, key value`` for a report's details; nested sections on their own lines."""
    flat = {k: v for k, v in details.items() if not isinstance(v, dict | list)}
    lines = [textwrap.fill(", ".join(f"{k} {_value(v)}" for k, v in flat.items()), width=100,
                           initial_indent=indent, subsequent_indent=indent + "  ")] if flat else []
    for key, value in details.items():
        if isinstance(value, dict):
            lines.append(f"{indent}{key}:")
            lines += _details(value, indent + "  ")
        elif isinstance(value, list):
            lines.append(f"{indent}{key}:")
            for item in value:
                lines += _details(item, indent + "  ") if isinstance(item, dict) else [f"{indent}  {_value(item)}"]
    return lines


def _value(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)
