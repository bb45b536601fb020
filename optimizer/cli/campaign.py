"""``millfoil run | resume | status | pack | unpack | check``: optimisation campaigns (:mod:`optimizer.campaign`).

Exit status of ``run`` and ``resume``: 0 the campaign finished, 2 bad input (configuration, an existing
run directory, no store to resume), 4 the campaign failed (an error outside any single evaluation; the
store keeps what finished), 130 interrupted (Ctrl-C or SIGTERM, e.g. a batch system's wall time: continue
with ``millfoil resume RUN``).
"""

from __future__ import annotations

import argparse
import json
import sys
from importlib import resources
from pathlib import Path

from optimizer.cli.common import EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK
from optimizer.config import ConfigError, shorten

#: The campaign ``run`` and ``check`` use without a CONFIG: a package file (package-data in pyproject.toml).
QUICKSTART = "optimizer/campaign/quickstart.yaml"


def register(sub: argparse._SubParsersAction) -> None:
    """Add the campaign commands."""
    run = sub.add_parser(
        "run",
        help="run an optimisation campaign (NSGA-II over the evaluation pipeline)",
        description="Run the campaign of a YAML file (none given: the embedded quickstart campaign): NSGA-II "
        "generation by generation, evaluations in parallel (execution: section; default a local dask cluster, "
        "one worker per core), every result stored at once in RUN/campaign.sqlite. Shows progress per "
        "generation and ends by printing where the results are and the non-dominated designs. Exit status: "
        "0 finished, 2 bad input, 4 failed, 130 interrupted (continue with `millfoil resume RUN`).",
        epilog="Examples:\n"
        "  millfoil run                # the embedded quickstart campaign, into runs/quickstart\n"
        "  millfoil run configs/paper/toolpath_g1.yaml --set execution.backend=slurm --out runs/tp_g1\n"
        "Configuration reference: docs/reference/configuration.md; how campaigns work: docs/explanation/campaigns.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    campaign_arguments(run)
    run.add_argument("--out", metavar="RUN", help="run directory (default: the config's output.directory)")
    run.add_argument("--quiet", action="store_true", help="no progress display")
    run.set_defaults(run=run_run)

    resume = sub.add_parser(
        "resume",
        help="continue a campaign whose driver stopped (interrupt, kill, wall time)",
        description="Continue the campaign stored in RUN with its saved configuration: the population and "
        "random state of the last finished generation come from the store, stored evaluations are never run "
        "again, and the result equals an uninterrupted run with the same seed. Exit status as `millfoil run`.",
        epilog="Example:\n  millfoil resume runs/quickstart\n"
        "  millfoil resume runs/tp_g1 --set execution.backend=local   # finish on this machine",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    resume.add_argument("directory", type=Path, metavar="RUN", help="run directory (holds campaign.sqlite)")
    resume.add_argument("--set", dest="overrides", action="append", default=[], metavar="execution.KEY=VALUE",
                        help="change the execution: section for the rest of the run (only execution.* keys)")
    resume.add_argument("--quiet", action="store_true", help="no progress display")
    resume.set_defaults(run=run_resume)

    status = sub.add_parser(
        "status",
        help="show a campaign's progress from its store (works while it runs)",
        description="Read RUN/campaign.sqlite (read-only; safe while the campaign runs, from any shell or "
        "node that sees the file) and print its state, generations, evaluations by status and convergence "
        "class, best objectives and hypervolume. With several runs, or a directory that holds runs (a study "
        "such as runs/paper), one line per run.",
        epilog="Examples:\n  millfoil status runs/quickstart\n  millfoil status runs/paper   # every run below it",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    status.add_argument("directories", nargs="+", type=Path, metavar="RUN",
                        help="run directory (holds campaign.sqlite); several, or a directory without a store, "
                        "for one line per run (its subdirectories' runs, two levels at most)")
    status.add_argument("--json", action="store_true", help="print the summary as JSON")
    status.set_defaults(run=run_status)

    for name, verb, help_, description in (
            ("pack", run_pack, "compress a campaign's store for an archive or a repository (campaign.sqlite.xz)",
             "Write RUN/campaign.sqlite (its write-ahead log folded in) to RUN/campaign.sqlite.xz, LZMA-compressed "
             "(about a fifth of the size), check that it reads back equal, and remove campaign.sqlite. `status`, "
             "`report` and `export` read a packed store as it is; `resume` unpacks it first. Refused while a "
             "driver runs in RUN."),
            ("unpack", run_unpack, "restore a packed store (campaign.sqlite.xz) to campaign.sqlite",
             "Write RUN/campaign.sqlite from RUN/campaign.sqlite.xz and remove the packed file (`resume` does "
             "this by itself). Refused while a driver runs in RUN.")):
        command = sub.add_parser(name, help=help_, description=description)
        command.add_argument("directory", type=Path, metavar="RUN", help="run directory")
        command.set_defaults(run=verb)

    check = sub.add_parser(
        "check",
        help="validate a campaign file and print the resolved campaign",
        description="Validate a campaign file (none given: the embedded quickstart) without running it: every "
        "key and value (errors name the key, the file and the line), the blade space, the mesh; print the "
        "design variables and their bounds, the objectives and constraints, the budget and the resolved "
        "configuration (every default included).",
    )
    campaign_arguments(check)
    check.set_defaults(run=run_check)


def campaign_arguments(parser: argparse.ArgumentParser) -> None:
    """The campaign file (optional: the embedded quickstart) and ``--set`` overrides of ``run`` and ``check``."""
    parser.add_argument("config", nargs="?", type=Path, metavar="CONFIG",
                        help=f"campaign YAML file (default: the embedded quickstart campaign, {QUICKSTART}: "
                        "G1 design blades, coarse mesh, population 4, 3 generations, about a minute on 2 cores)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a dotted key (algorithm.population=8, execution.backend=slurm); "
                        "repeatable")


# ------------------------------------------------------------------------------------------ commands
def run_check(args: argparse.Namespace) -> int:
    from optimizer.campaign.problem import make_problem

    config = load_campaign_argument(args)
    problem = make_problem(config)
    a = config.algorithm
    print(f"campaign {describe_source(args.config)}: valid")
    if config.analytic is None:
        print(f"  blade: {config.blade.mode.value} {config.blade.continuity.value}; mesh {config.mesh.level}, "
              f"half-height {config.mesh_spec().half_height:g} chords; solver {config.solver.model}")
        fixed = ", ".join(f"{k} = {v:g}" for k, v in problem.space.fixed.items())
        print(f"  fixed: {fixed or '-'}")
    else:
        print(f"  analytic problem {config.analytic.problem} ({config.analytic.variables} variables)")
    print(f"  design variables ({problem.n_var}):")
    for n, lo, hi in zip(problem.names, problem.lower, problem.upper, strict=True):
        print(f"    {n:10s} [{lo:g}, {hi:g}]")
    print("  objectives: " + ", ".join(f"{o.sense} {o.label}" for o in config.objectives))
    print("  constraints: " + (", ".join(problem.constraint_names)))
    print(f"  oscillating results: {config.convergence.oscillating}"
          + (f" (amplitude <= {config.convergence.max_amplitude:.2%} of the mean)"
             if config.convergence.oscillating == "accept_below_amplitude" else ""))
    method = "NSGA-II" if a.method == "nsga2" else (
        f"surrogate-assisted NSGA-II ({a.surrogate.kernel} kernel"
        f"{', coordinate search' if a.surrogate.coordinate_search else ''}, pool {a.surrogate.pool} per design, "
        f"exploration {a.surrogate.exploration:.0%}, models on at most {a.surrogate.training} designs)")
    print(f"  {method}: population {a.population}, {a.generations} generations, offspring "
          f"{a.batch}, seed {a.seed}: at most {a.population + (a.generations - 1) * a.batch} evaluations")
    print(f"  execution: {config.execution.backend}; run directory {config.output.directory}")
    if config.execution.backend in ("inline", "local"):
        import os

        workers = 1 if config.execution.backend == "inline" else (config.execution.workers or os.cpu_count() or 1)
        rounds = -(-a.batch // workers)
        idle = rounds * workers - a.batch
        print(f"  {a.batch} offspring on {workers} worker(s): {rounds} round(s) per generation"
              + (f", {idle} worker(s) idle in the last (offspring a multiple of the workers keeps all busy)"
                 if idle else ""))
    print("\n# resolved campaign")
    print(config.to_yaml(), end="")
    return EXIT_OK


def run_run(args: argparse.Namespace) -> int:
    from optimizer.campaign.driver import run_campaign
    from optimizer.saving import check_output_directory

    if args.out is not None and not args.out.strip():
        raise ConfigError(f"--out {shorten(args.out)}: the run directory is empty: give one, e.g. --out "
                          "runs/mine ('.' for the working directory)")
    config = load_campaign_argument(args)
    directory = Path(args.out) if args.out is not None else config.output.directory
    # Refused before any cluster starts (exit 2, naming the option): a file in the way, /proc, read-only.
    check_output_directory(directory, "--out" if args.out else "output.directory", files=())
    if args.config is None:
        print(f"running {describe_source(None)}; run directory {directory}", flush=True)
    return _drive(lambda display: run_campaign(config, directory, progress=display, log=display.log),
                  args.quiet, directory)


def run_resume(args: argparse.Namespace) -> int:
    from optimizer.campaign.driver import resume_campaign, saved_config
    from optimizer.campaign.store import STORE_NAME, Store

    for item in args.overrides:
        if not item.partition("=")[0].strip().startswith("execution."):
            raise ConfigError(f"--set {shorten(item)}: resume changes only execution.KEY=VALUE (the rest of the "
                              "campaign is fixed by its store)")
    # The overrides are validated as `run` validates a campaign (errors name the --set), here before the
    # driver takes the run directory, and again by the driver; a missing, empty or damaged store is the
    # driver's to report.
    path = args.directory / STORE_NAME
    row = None
    if args.overrides and path.is_file():
        try:
            with Store(path, readonly=True) as store:
                row = store.campaign()
        except ConfigError:
            raise
        except Exception:          # the driver opens it again and says what is wrong
            row = None
    if row is not None:
        saved_config(row.config, overrides=args.overrides)
    return _drive(lambda display: resume_campaign(args.directory, progress=display, log=display.log,
                                                  overrides=args.overrides), args.quiet, args.directory)


def run_status(args: argparse.Namespace) -> int:
    from optimizer.campaign.progress import format_damaged, format_status, status_of
    from optimizer.campaign.store import STORE_NAME, StoreDamaged, stored

    directory = args.directories[0]
    if len(args.directories) > 1 or directory.is_dir() and not stored(directory / STORE_NAME):
        return _status_of_several(args)
    try:
        summary = status_of(directory)
    except FileNotFoundError as exc:
        raise ConfigError(str(exc)) from None
    except StoreDamaged as exc:
        # what can still be read first, as a database tool shows it; then the one-line error (exit 2)
        inspection = exc.inspection
        print(json.dumps({"directory": str(directory), "damaged": inspection.to_dict()}, indent=2)
              if args.json else format_damaged(directory, inspection), flush=True)
        raise
    print(json.dumps(summary, indent=2) if args.json else format_status(summary))
    return EXIT_OK


def _status_of_several(args: argparse.Namespace) -> int:
    """``millfoil status`` of several runs: a line each; exit 2 if any could not be read (named in the table
    and in one error line), after the others are shown."""
    from optimizer.campaign.progress import status_of, status_table
    from optimizer.report.run import RunError, run_directories

    try:
        directories = run_directories(args.directories)
    except RunError as exc:
        raise ConfigError(str(exc)) from None
    summaries, unreadable = [], []
    for directory in directories:
        try:
            summaries.append(status_of(directory))
        except (OSError, ConfigError, RuntimeError, ValueError) as exc:   # a damaged store, a newer schema, …
            unreadable.append((str(directory), str(exc).splitlines()[0]))
    if args.json:
        print(json.dumps({"runs": summaries, "unreadable": [{"directory": d, "error": e} for d, e in unreadable]},
                         indent=2))
    else:
        print(status_table(summaries, unreadable), flush=True)
    if unreadable:
        raise ConfigError(f"{len(unreadable)} of {len(directories)} runs could not be read: "
                          + "; ".join(d for d, _ in unreadable) + " (`millfoil status RUN` on one says what it holds)")
    return EXIT_OK


def run_pack(args: argparse.Namespace) -> int:
    from optimizer.campaign.packed import pack

    done = _packing(pack, args.directory)
    print(f"packed {args.directory / 'campaign.sqlite'} ({done.before:,} bytes) into {done.written} "
          f"({done.after:,} bytes)")
    return EXIT_OK


def run_unpack(args: argparse.Namespace) -> int:
    from optimizer.campaign.packed import unpack

    done = _packing(unpack, args.directory)
    print(f"unpacked {args.directory / 'campaign.sqlite.xz'} ({done.before:,} bytes) into {done.written} "
          f"({done.after:,} bytes)")
    return EXIT_OK


def _packing(step, directory: Path):
    """``step`` (pack or unpack) on the run directory's store; a refusal is a bad input (exit 2)."""
    from optimizer.campaign.lock import DirectoryInUse
    from optimizer.campaign.packed import PackError
    from optimizer.campaign.store import STORE_NAME

    if not directory.is_dir():
        raise ConfigError(f"{directory}: no such run directory")
    try:
        return step(directory / STORE_NAME)
    except (PackError, DirectoryInUse) as exc:
        raise ConfigError(str(exc)) from None


# ------------------------------------------------------------------------------------------- helpers
def load_campaign_argument(args: argparse.Namespace):
    """The campaign of ``args.config`` with its ``--set`` overrides; without a file, the packaged quickstart
    (read through importlib.resources, so an installed, non-editable package has it too)."""
    from optimizer.campaign.config import load_campaign

    if args.config is not None:
        return load_campaign(args.config, args.overrides)
    with resources.as_file(resources.files("optimizer.campaign") / "quickstart.yaml") as path:
        return load_campaign(path, args.overrides)


def describe_source(config: Path | None) -> str:
    """How the headers name the campaign file: its path, or the embedded quickstart."""
    return str(config) if config is not None else f"the embedded quickstart campaign ({QUICKSTART})"


def _drive(start, quiet: bool, directory: Path) -> int:
    from optimizer.campaign.driver import CampaignError
    from optimizer.campaign.lock import DirectoryInUse
    from optimizer.campaign.problem import EmptySpaceError
    from optimizer.campaign.progress import ProgressDisplay, front_table, write_front_csv
    from optimizer.campaign.runner import ClusterRefused

    display = ProgressDisplay()
    try:
        outcome = start(_Quiet(display) if quiet else display)
    except (CampaignError, ClusterRefused, DirectoryInUse, EmptySpaceError) as exc:
        print(f"millfoil: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        left = (f"what finished is stored. Continue with: millfoil resume {directory}" if _stored(directory)
                else "nothing had been evaluated and nothing is left")
        print(f"\nmillfoil: interrupted; {left}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ConfigError:
        raise
    except Exception as exc:
        left = (f"what finished is stored in {directory}" if _stored(directory)
                else "nothing had been evaluated and nothing is left")
        print(f"millfoil: error: the campaign failed: {type(exc).__name__}: {exc}; {left}", file=sys.stderr)
        return EXIT_FAILED
    try:
        csv_path = write_front_csv(outcome.front, outcome.labels, Path(outcome.directory) / "front.csv")
    except OSError as exc:       # written whole or not at all: the store has everything
        print(f"millfoil: error: the campaign finished and is stored in {outcome.directory}, but front.csv could "
              f"not be written: {exc.strerror or exc}; millfoil report {outcome.directory} reads the store",
              file=sys.stderr)
        return EXIT_FAILED
    print(f"campaign finished: {outcome.generations} generations; results in {outcome.directory}/ "
          f"(campaign.sqlite, config.yaml, {csv_path.name})")
    print(f"non-dominated designs ({len(outcome.front)}):")
    print(front_table(outcome.front, outcome.labels))
    return EXIT_OK


def _stored(directory: Path) -> bool:
    """Whether the run directory still holds a store (a run stopped before its first evaluation removes it)."""
    from optimizer.campaign.store import STORE_NAME

    return (Path(directory) / STORE_NAME).exists()


class _Quiet:
    """A progress sink that shows nothing but phase lines."""

    def __init__(self, display):
        self.log = display.log

    def __call__(self, _p) -> None:
        pass
