"""``millfoil export``: the tool path of a design as an NC program (Sinumerik, LinuxCNC), DXF or CSV.

Exit status: 0 written, 2 refused (no store, a damaged store, unknown design, a design-mode or analytic
campaign, a failed or infeasible design, a bad option, an output path that is a directory), 4 the file
could not be written (then none is: it is written under a temporary name and renamed when whole) or the
program read back deviates from the tool path by more than 1 µm (never expected: it would be a bug).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from optimizer.cli.common import EXIT_FAILED, EXIT_INPUT, EXIT_OK

#: Largest deviation (mm) allowed between a written program, read back, and the optimiser's tool path.
TOLERANCE_MM = 1e-3


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``millfoil export``."""
    from optimizer.export import FORMATS, NcSettings

    d = NcSettings()
    p = sub.add_parser(
        "export",
        help="write a design's tool path as NC program (Sinumerik POLY, LinuxCNC NURBS), DXF or CSV",
        description="Write the cutter-centre path of a tool-path design, in millimetres, as the controller's "
        "own polynomial or spline blocks (the degree-4 Bezier sides exactly: Sinumerik POLY, LinuxCNC G5.2 "
        "order 5), as DXF with true SPLINE entities, or as CSV of the blade outline and the tool path. The "
        "design is a stored design of a campaign (RUN --id N: the design number of the report, or a key "
        "prefix) or the blade of a configuration file (--config). An NC program is read back after writing "
        "and compared with the tool path (it must agree within 1 µm). Design-mode blades and failed or "
        "infeasible designs are refused. Exit status: 0 written, 2 refused, 4 not written.",
        epilog="Examples:\n"
        "  millfoil export runs/tp_g1 --id 57 --format sinumerik\n"
        "  millfoil export runs/tp_g1 --id 57 --format linuxcnc --feed 400 --depth -8 --out blade.ngc\n"
        "  millfoil export --config configs/examples/table5_g1_toolpath.yaml --format dxf\n"
        "Formats, manuals and the verification: docs/how-to/export-nc-programs.md.",
    )
    p.add_argument("directory", nargs="?", type=Path, metavar="RUN", help="run directory of a campaign")
    p.add_argument("--id", dest="ident", metavar="N", help="design number (as in the report) or key prefix")
    p.add_argument("--config", type=Path, metavar="FILE", help="export the blade of this configuration instead")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                   help="with --config: override a value (as for `millfoil profile`); repeatable")
    p.add_argument("--format", required=True, choices=sorted(FORMATS), help="output format")
    p.add_argument("--out", metavar="FILE", help="output file ('-': standard output; default RUN/export/"
                   "design-N.EXT, or CONFIG-NAME.EXT in the working directory)")
    nc = p.add_argument_group("NC program (mm, mm/min, rpm)")
    nc.add_argument("--feed", type=float, default=d.feed, help="cutting feed (default %(default)s)")
    nc.add_argument("--plunge-feed", type=float, default=d.plunge_feed, help="plunge feed (default %(default)s)")
    nc.add_argument("--spindle", type=float, default=d.spindle, help="spindle speed, M3 (default %(default)s)")
    nc.add_argument("--tool", type=int, default=d.tool, help="tool number (default %(default)s)")
    nc.add_argument("--plane", choices=("G17", "G18", "G19"), default=d.plane,
                    help="working plane (default %(default)s; LinuxCNC NURBS: G17 only)")
    nc.add_argument("--safe", type=float, default=d.safe, help="safe height on the depth axis (default %(default)s)")
    nc.add_argument("--depth", type=float, default=d.depth, help="cutting depth on the depth axis "
                    "(default %(default)s)")
    nc.add_argument("--approach", type=float, default=d.approach, help="straight approach along the trailing-edge "
                    "lead-in line (default %(default)s; 0: plunge at the start)")
    nc.add_argument("--retract", type=float, default=d.retract, help="straight retract along the pressure-side "
                    "normal (default %(default)s; 0: lift at the end)")
    p.set_defaults(run=run_export)


def run_export(args: argparse.Namespace) -> int:
    from optimizer.export import FORMATS, ExportError, NcSettings
    from optimizer.export.source import default_output
    from optimizer.report.run import RunError
    from optimizer.saving import write_atomic

    try:
        settings = NcSettings(feed=args.feed, plunge_feed=args.plunge_feed, spindle=args.spindle, tool=args.tool,
                              plane=args.plane, safe=args.safe, depth=args.depth, approach=args.approach,
                              retract=args.retract)
        path, origin, out = _source(args)
        fmt = FORMATS[args.format]
        from optimizer.campaign.problem import millfoil_version
        from optimizer.export.source import header_lines

        header = header_lines(path, origin, millfoil_version())
        if fmt.nc:
            header.append(f"NC: {args.format}; feed {settings.feed:g} mm/min, plane {settings.plane}, depth "
                          f"{settings.depth:g} mm, safe {settings.safe:g} mm, approach {settings.approach:g} mm, "
                          f"retract {settings.retract:g} mm")
        text = fmt.write(path, header, settings)
    except (ExportError, RunError) as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    if fmt.nc:
        worst = _verify(text, args.format, path, settings)
        if worst > TOLERANCE_MM:
            print(f"millfoil: error: the {args.format} program read back deviates from the tool path by "
                  f"{worst * 1e3:.3f} µm > {TOLERANCE_MM * 1e3:g} µm; not written", file=sys.stderr)
            return EXIT_FAILED
    target = default_output(*out, fmt.extension) if args.out is None else args.out
    if target == "-":
        sys.stdout.write(text)
        return EXIT_OK
    target = Path(target)
    if target.is_dir() or (target.exists() and not target.is_file()):
        what = "a directory" if target.is_dir() else "not a regular file"
        print(f"millfoil: error: --out {target} is {what}; nothing was written", file=sys.stderr)
        return EXIT_INPUT
    try:
        # under a temporary name beside it, renamed when whole: a full disk leaves no truncated file
        write_atomic(target, lambda path: path.write_text(text))
    except OSError as exc:
        print(f"millfoil: error: cannot write {target}: {exc.strerror or exc}; nothing was written", file=sys.stderr)
        return EXIT_FAILED
    note = f"; read back: within {worst * 1e3:.4f} µm of the optimiser's tool path" if fmt.nc else ""
    print(f"wrote {target} ({args.format}, tool radius {path.radius:g} mm){note}")
    return EXIT_OK


def _source(args: argparse.Namespace):
    """(tool path, origin header lines, (run directory or None, default file stem)) of the arguments."""
    from optimizer.config import load_config
    from optimizer.export.source import config_tool_path, run_tool_path
    from optimizer.export.toolpath import ExportError
    from optimizer.report.run import load_run

    if (args.directory is None) == (args.config is None):
        raise ExportError("give either a run directory (RUN --id N) or --config FILE")
    if args.config is not None:
        if args.ident is not None:
            raise ExportError("--id selects a design of a run; it does not go with --config")
        config = load_config(args.config, args.overrides)
        path, origin = config_tool_path(config.blade.blade_spec(), str(args.config))
        return path, origin, (None, args.config.stem)
    if args.overrides:
        raise ExportError("--set goes with --config; a stored design is exported as it was evaluated")
    if args.ident is None:
        raise ExportError("--id N: which design of the run (the design number in its report, or a key prefix)")
    run = load_run(args.directory)
    design = run.design(args.ident)
    path, origin = run_tool_path(run, design)
    return path, origin, (args.directory, f"design-{design.number}")


def _verify(text: str, dialect: str, path, settings) -> float:
    from optimizer.export.verify import deviation, read_program

    return deviation(read_program(text, dialect), path, settings.axes, settings.depth).worst
