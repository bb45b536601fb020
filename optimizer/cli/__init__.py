"""The ``millfoil`` command line: a thin layer over plain functions, one module per command group.

Each module of :data:`COMMANDS` has ``register(subparsers)``, which adds its commands with a
``run(args) -> exit status`` default; a new command group is one module and one entry here.
:mod:`optimizer.cli.common` holds what they share.

Exit status (``docs/reference/errors.md``): 0 success, 2 bad input (configuration, override, option, output location;
refused before any stage runs), 3 the blade is infeasible (its constraints are printed; files are still
written when the profile could be built), 4 a stage failed (the mesh could not be built or is below the
quality thresholds, the flow solve diverged, an output could not be written; the reason is printed).
``millfoil evaluate`` returns 0 whenever the solve ran (its status, possibly ``not_converged``, is printed).
Every error is one line ``millfoil: error: ...`` on stderr.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence

from optimizer.cli import blade, campaign, evaluate, export, mesh, report, validate
from optimizer.cli.common import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_INPUT, EXIT_OK, HelpFormatter
from optimizer.config import ConfigError, ConfigWarning
from optimizer.saving import WriteFailure

__all__ = ["COMMANDS", "build_parser", "EXIT_FAILED", "EXIT_INFEASIBLE", "EXIT_INPUT", "EXIT_OK", "main"]

#: Command modules, in the order of ``millfoil --help``.
COMMANDS = (blade, mesh, evaluate, validate, campaign, report, export)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``millfoil`` with ``argv`` (default: the process's arguments); returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "run"):
        parser.print_help()
        return EXIT_INPUT
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", ConfigWarning)
            warnings.showwarning = _show_warning
            return args.run(args)
    except ConfigError as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except WriteFailure as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_FAILED


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A :class:`ConfigWarning` as one line ``millfoil: warning: ...`` on stderr; others as Python shows them."""
    if issubclass(category, ConfigWarning):
        print(f"millfoil: warning: {message}", file=sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), end="", file=file or sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    """The ``millfoil`` parser: every command of :data:`COMMANDS` (docs/reference/cli.md is generated from it)."""
    parser = argparse.ArgumentParser(
        prog="millfoil",
        description="Multi-objective shape optimisation of hydraulic blade profiles, designed directly or "
        "through the milling tool path that machines them (Vessaz et al. 2013).",
        epilog="Exit status: 0 success, 2 bad input, 3 infeasible blade, 4 a stage failed (docs/reference/errors.md).",
        formatter_class=HelpFormatter,
    )
    sub = parser.add_subparsers(title="commands", metavar="COMMAND")
    for module in COMMANDS:
        module.register(sub)
    for command in sub.choices.values():
        command.formatter_class = HelpFormatter   # one help layout for every command, wrapped
    return parser
