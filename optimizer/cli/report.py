"""``millfoil report``: a campaign's report (static HTML page, SVG figures, CSV tables) from its store.

Exit status: 0 written, 2 bad input (no store in a run directory, a damaged store, an output path that is a
directory or cannot be written), 4 the report could not be written (then no file of it is).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from optimizer.cli.common import EXIT_FAILED, EXIT_INPUT, EXIT_OK


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``millfoil report``."""
    p = sub.add_parser(
        "report",
        help="write a campaign's report: Pareto fronts, Table 7 summary, geometry gallery, health, provenance",
        description="Read the stores of one or more runs (read-only: works while a campaign runs, showing what "
        "has finished) and write a static HTML page that opens without a network, with SVG figures and CSV "
        "tables beside it: the Pareto fronts |F_Y| vs C_max and C_L vs |C_p,min| (two runs on one plot, more "
        "one panel each), a Table 7 summary (with the paper's values for its cases), blades and flow fields "
        "along the front, the hypervolume against the CFD evaluations spent, campaign health per generation, "
        "provenance; with two or more of the paper's eight cases, the paper study (Table 7 side by side, Fig. "
        "9-13, the paper's conclusions tested, mesh dependence). Exit status: 0 written, 2 bad input, 4 not "
        "written.",
        epilog="Examples:\n  millfoil report runs/quickstart\n"
        "  millfoil report runs/design_g1 runs/toolpath_g1 --out reports/g1 --open\n"
        "  millfoil report runs/examples/paper --out reports/paper\nSee docs/explanation/reports.md.",
    )
    p.add_argument("directories", nargs="+", type=Path, metavar="RUN",
                   help="run directories; a directory without a store stands for the runs in its subdirectories "
                   "(two levels at most: runs/examples/paper holds coarse/design_g1, …)")
    p.add_argument("--out", type=Path, metavar="DIR", help="output directory (default: FIRST-RUN/report)")
    p.add_argument("--open", action="store_true", help="open the page in a web browser when written")
    p.set_defaults(run=run_report)


def run_report(args: argparse.Namespace) -> int:
    from optimizer.report.html import write_report
    from optimizer.report.run import RunError, load_run, run_directories
    from optimizer.saving import check_output_directory

    try:
        runs = [load_run(d) for d in run_directories(args.directories)]
    except RunError as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    out = args.out or args.directories[0] / "report"
    option = "--out" if args.out else "the report directory"
    check_output_directory(out, option, files=["index.html"])   # a bad --out is refused before any drawing
    print(f"millfoil: drawing the report of {len(runs)} run{'s' * (len(runs) != 1)} in {out}", file=sys.stderr)
    try:
        # every path checked first (OutputError: exit 2); then all files or none (WriteFailure: exit 4)
        page = write_report(runs, out, option)
    except OSError as exc:
        print(f"millfoil: error: cannot write the report in {out}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_FAILED
    print(f"wrote {page}")
    if args.open:
        import webbrowser

        webbrowser.open(page.resolve().as_uri())
    return EXIT_OK
