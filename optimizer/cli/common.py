"""What the ``millfoil`` commands share: exit statuses, the configuration arguments, progress lines, the
help layout."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from meshing import LEVELS
from optimizer.cli.exits import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK  # noqa: F401
from optimizer.config import Config, load_config

#: Mesh resolution levels a command accepts on ``--level``: :data:`meshing.LEVELS`.
LEVEL_CHOICES = tuple(LEVELS)


def config_arguments(parser: argparse.ArgumentParser) -> None:
    """The configuration file and ``--set`` overrides that every command reading a config takes."""
    parser.add_argument("config", nargs="?", type=Path, help="YAML configuration file (default: the embedded "
                        "defaults, i.e. the Table 4 blade)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                        help="override a value: a blade parameter (alpha=25, in m or deg) or a dotted key "
                        "(blade.mode=toolpath, mesh.level=fine); repeatable")


def level_argument(parser: argparse.ArgumentParser, what: str = "resolution level") -> None:
    """``--level``: the mesh level, applied over the configuration's ``mesh.level`` (see :func:`load`)."""
    parser.add_argument("--level", choices=LEVEL_CHOICES,
                        help=f"{what} (default: the config's mesh.level, else medium)")


def load(args: argparse.Namespace, *, blade_values: bool = True) -> Config:
    """The configuration of a command's arguments: the file, its ``--set`` overrides, then ``--level``
    (a typed value, not re-parsed) where the command has one and it was given."""
    level = getattr(args, "level", None)
    values = {"mesh.level": level} if level else None
    return load_config(args.config, args.overrides, values=values, blade_values=blade_values)


def progress_printer(quiet: bool):
    """A ``log`` callable printing ``millfoil: LINE`` on stderr, or None when ``quiet``."""
    if quiet:
        return None
    return lambda line: print(f"millfoil: {line}", file=sys.stderr, flush=True)


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """``--help`` layout: prose lines of a description or epilog are wrapped to the terminal width; lines
    that start with a space (examples, lists) and blank lines are kept as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        lines = []
        for line in text.splitlines():
            if not line.strip() or line[0].isspace():
                lines.append(indent + line)
            else:
                lines += textwrap.wrap(line, width, initial_indent=indent, subsequent_indent=indent)
        return "\n".join(lines)
