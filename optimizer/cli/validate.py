"""``millfoil validate``: a solver validation case against published data (:mod:`solver.validation`)."""

from __future__ import annotations

import argparse
import json

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
