"""The ``millfoil`` command line: a thin layer over plain functions, one module per command group.

Each module of :data:`COMMAND_MODULES` has ``register(subparsers)``, which adds its commands with a
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
import importlib
import os
import signal
import sys
from collections.abc import Sequence

from optimizer.cli.exits import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_PIPE

__all__ = ["COMMAND_MODULES", "build_parser", "commands", "EXIT_FAILED", "EXIT_INFEASIBLE", "EXIT_INPUT",
           "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_PIPE", "main"]

#: Command modules under :mod:`optimizer.cli`, in the order of ``millfoil --help``.
COMMAND_MODULES = ("blade", "mesh", "evaluate", "validate", "campaign", "report", "export")


def commands() -> tuple:
    """The command modules of :data:`COMMAND_MODULES`, imported."""
    return tuple(importlib.import_module(f"optimizer.cli.{name}") for name in COMMAND_MODULES)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``millfoil`` with ``argv`` (default: the process's arguments); returns the exit status.

    Ctrl-C and SIGTERM (a batch system's wall time, ``kill``) end any command with exit status 130 and one
    line, never a traceback or death by the signal; a campaign marks its store ``interrupted`` on the way
    out. While the command modules are imported (the first second) a signal is only noted, and acted on
    once they are: an interrupt inside a compiled module's initialisation would surface as an ImportError.

    Output to a reader that has gone (``millfoil status RUN | head``) ends the command quietly with 141.
    """
    pending: list[int] = []
    previous = _handle_signals(lambda signum, frame: pending.append(signum))
    try:
        parser = build_parser()
        _handle_signals(_raise_interrupt)
        if pending:
            raise KeyboardInterrupt(f"signal {pending[0]}")
        code = _main(parser, argv)
    except KeyboardInterrupt:
        print("\nmillfoil: interrupted", file=sys.stderr)
        # the command has stopped: a second signal on the way out (Ctrl-C pressed twice, a group's
        # signal arriving late) must not turn exit status 130 into death by the signal
        _handle_signals(lambda signum, frame: None)
        _forget_interrupted_evaluation()
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of the output has gone (`| head`): stop quietly, as a Unix tool stopped by SIGPIPE does,
        # and keep Python's final flush of stdout from printing a second error
        _discard_stdout()
        return EXIT_PIPE
    for signum, handler in previous.items():
        signal.signal(signum, handler)
    if code == EXIT_INTERRUPTED:
        _forget_interrupted_evaluation()
    return code


def _forget_interrupted_evaluation() -> None:
    """Keep exit status 130 under ``python -m optimizer.cli`` after an interrupt.

    CPython (3.8 to at least 3.12) ends a ``-m`` run by SIGINT, whatever its exit status, when a
    KeyboardInterrupt ended any string ``exec``/``eval`` during the run — a dataclass or named tuple being
    built as the signal arrived — even one caught afterwards. A string evaluation that ends normally clears
    that mark.
    """
    exec("pass", {})


def _discard_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (AttributeError, OSError, ValueError):   # a stdout without a descriptor (an embedding application)
        pass


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


def _handle_signals(handler) -> dict:
    """SIGINT and SIGTERM to ``handler``; the previous handlers (none off the main thread: an embedding
    application's signals are left alone)."""
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        try:
            if signal.getsignal(signum) is signal.SIG_IGN:   # ignored by whoever started us (nohup, `&`)
                continue
            previous[signum] = signal.signal(signum, handler)
        except ValueError:
            break
    return previous


def _main(parser, argv: Sequence[str] | None) -> int:
    import warnings

    from optimizer.config import ConfigError, ConfigWarning
    from optimizer.saving import WriteFailure

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
    import warnings

    from optimizer.config import ConfigWarning

    if issubclass(category, ConfigWarning):
        print(f"millfoil: warning: {message}", file=sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), end="", file=file or sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    """The ``millfoil`` parser: every command of :data:`COMMAND_MODULES` (docs/reference/cli.md is generated from
    it)."""

    from optimizer.cli.common import HelpFormatter

    parser = argparse.ArgumentParser(
        prog="millfoil",
        description="Multi-objective shape optimisation of hydraulic blade profiles, designed directly or "
        "through the milling tool path that machines them (Vessaz et al. 2013).",
        epilog="Exit status: 0 success, 2 bad input, 3 infeasible blade, 4 a stage failed (docs/reference/errors.md).",
        formatter_class=HelpFormatter,
    )
    sub = parser.add_subparsers(title="commands", metavar="COMMAND")
    for module in commands():
        module.register(sub)
    for command in sub.choices.values():
        command.formatter_class = HelpFormatter   # one help layout for every command, wrapped
    return parser
