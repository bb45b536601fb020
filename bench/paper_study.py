"""The paper's study: its eight cases (``configs/paper/{design,toolpath}_{g1,c1,g2,c2}.yaml``) run as ordinary
campaigns, one after the other, at one mesh level, with the surrogate-assisted NSGA-II; then what each cost.

Each case is ``millfoil run configs/paper/<case>.yaml --out OUT/<level>/<case> --set mesh.level=<level>`` (the
configs' surrogate-assisted NSGA-II at the paper's population 100 and 50 generations: 100 + 49 × 20 = 1 080
CFD evaluations); a case that was interrupted is continued with ``millfoil resume``, a finished one is left
alone, so the study spans sessions (the stores are the state). ``--report-only`` prints, per case, the
state, the CFD evaluations (failed ones included), the CPU hours of the workers and the wall time
(:func:`busy_hours`: the hours during which an evaluation ran, plus the driver's model fitting and
screening, so that the hours between sessions do not count, also inside a generation that was interrupted)
and the command that draws the report of all of them.

    python bench/paper_study.py --level coarse                 # the eight cases, hours on 2 cores
    python bench/paper_study.py --level medium --cases toolpath_g1
    python bench/paper_study.py --level medium --cases design_g1 --set convergence.max_amplitude=0.01
    python bench/paper_study.py --level coarse --report-only
    python bench/paper_study.py --level coarse --report-only --out /scratch/paper --archive runs/examples/paper
    python bench/paper_study.py --level medium --report-only --out /scratch/paper --archive runs/examples/paper \
        --unfinished                                           # carry unfinished runs to another machine
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = tuple(f"{mode}_{continuity}" for continuity in ("g1", "c1", "g2", "c2") for mode in ("design", "toolpath"))


def run_case(case: str, level: str, directory: Path, workers: int | None, settings: list[str] = ()) -> None:
    """Run, or continue, one case in ``directory`` (nothing when it is finished); ``settings`` (``KEY=VALUE``)
    change the configuration of a case that starts here (a started one keeps its own)."""
    from optimizer.campaign.store import STORE_NAME, Store, stored

    cli = [sys.executable, "-m", "optimizer.cli"]
    execution = [f"execution.workers={workers}"] if workers else []
    store = directory / STORE_NAME
    if stored(store):
        with Store(store, readonly=True) as s:
            row = s.campaign()
        if row is not None and row.state == "finished":
            return
    if stored(store):
        command = [*cli, "resume", str(directory), *(a for kv in execution for a in ("--set", kv))]
    else:
        overrides = [f"mesh.level={level}", *settings, *execution]
        command = [*cli, "run", str(ROOT / "configs" / "paper" / f"{case}.yaml"), "--out", str(directory),
                   *(a for kv in overrides for a in ("--set", kv))]
    print(" ".join(command[1:]), file=sys.stderr, flush=True)
    subprocess.run(command, check=True, env={**os.environ, "PYTHONPATH": str(ROOT)})


def cost(directory: Path) -> dict | None:
    """State, CFD evaluations, CPU hours and driver wall hours of the run in ``directory`` (None: no store)."""
    from optimizer.campaign.status import EvaluationStatus
    from optimizer.campaign.store import STORE_NAME, Store, stored

    if not stored(directory / STORE_NAME):
        return None
    with Store(directory / STORE_NAME, readonly=True) as s:
        state = s.campaign().state
        rows = [r for r in s.evaluations() if r.status != EvaluationStatus.INFEASIBLE]
        generations = s.generations()
    # the workers' CPU time (the report's rule: its wall time where a row has none)
    cpu = sum((r.seconds or {}).get("cpu") or r.wall_seconds or 0.0 for r in rows) / 3600
    wall = busy_hours(rows, generations)
    return {"state": state, "evaluations": len(rows), "generations": len(generations), "cpu_hours": cpu,
            "wall_hours": wall, "surrogate_share": driver_hours(generations) / wall if wall else None}


def busy_hours(rows, generations) -> float:
    """Wall hours a run took: the union of its evaluations' intervals from submission to end (time with at
    least one evaluation on a worker), plus the seconds the driver's surrogate step spent fitting models
    and screening candidates between generations (stored with each generation; no evaluation runs then).
    Time with nothing running, such as the hours between a stop and its ``resume``, does not count; nor do
    the driver's few seconds of start-up and bookkeeping."""
    spans = sorted((_time(r.submitted), _time(r.finished)) for r in rows if r.submitted)
    busy, end = 0.0, None
    for start, finish in spans:
        if end is None or start > end:
            busy += (finish - start).total_seconds()
            end = finish
        elif finish > end:
            busy += (finish - end).total_seconds()
            end = finish
    return busy / 3600 + driver_hours(generations)


def driver_hours(generations) -> float:
    """Hours the driver's surrogate step spent fitting models and screening candidates (stored with each
    generation), during which no evaluation runs."""
    return sum(sum(((g.search or {}).get("seconds") or {}).values()) for g in generations) / 3600


def _time(text: str) -> datetime:
    return datetime.fromisoformat(text)


def restore_fields(directory: Path) -> int:
    """Solve again every design on the front of the run in ``directory`` whose fields file is missing (a run
    continued from a copy that did not carry them), with the run's own configuration, worker function and
    backend, which write the file. A solve must give the stored figures again (one machine's solver is
    deterministic); where it does not, the design is named and its new file removed. Returns the files
    written."""
    import numpy as np

    from optimizer.campaign.driver import saved_config
    from optimizer.campaign.fields import fields_path, with_fields
    from optimizer.campaign.problem import make_problem
    from optimizer.campaign.record import EvaluationRecord, evaluate_payload
    from optimizer.campaign.runner import Task, make_runner
    from optimizer.campaign.store import STORE_NAME, Store

    with Store(directory / STORE_NAME, readonly=True) as s:
        config = saved_config(s.campaign().config)
        missing = {r.key: r for r in s.front() if not fields_path(directory, r.key).is_file()}
    if not missing:
        return 0
    print(f"{directory}: solving {len(missing)} front designs again for their fields", file=sys.stderr)
    problem = make_problem(config)
    tasks = [Task(k, with_fields(problem.payload(np.asarray(r.x, float)), directory, k), 0) for k, r in missing.items()]
    written = 0
    with make_runner(config.execution) as runner:
        for result in runner.run(evaluate_payload, tasks):
            stored_figures = missing[result.key].figures or {}
            record = EvaluationRecord.of(result.record) if result.record is not None else None
            same = record is not None and all(
                v is None or (record.figures.get(k) is not None and np.isclose(record.figures[k], v, rtol=1e-9))
                for k, v in stored_figures.items() if isinstance(v, float))
            if same and fields_path(directory, result.key).is_file():
                written += 1
            else:
                fields_path(directory, result.key).unlink(missing_ok=True)
                print(f"{directory}: design {result.key[:10]} solved again does not give its stored figures; "
                      "its fields are not kept", file=sys.stderr)
    return written


def archive(out: Path, level: str, cases, dest: Path, unfinished: bool = False) -> None:
    """Copy the finished runs of ``out/level`` to ``dest/level`` as the repository keeps them: each store
    packed (a consistent snapshot; its message names the copy, not the original), its ``config.yaml``, and
    only the fields files the report of all of them draws (:func:`optimizer.report.html.fields_shown`), so
    that ``millfoil report`` of the copies draws the same page. A run already there is replaced, unless it is
    the same finished campaign (same start, as many evaluations): that one is left as it is. The designs
    of a finished run's front whose fields files are missing are solved again first (:func:`restore_fields`).

    A run that is not finished is named and left out (the report would take its partial front for the
    case's), unless ``unfinished``: then its store and configuration are copied, without fields (a front's
    worth is megabytes), and the study continues from the copy on another machine: copy ``dest/level`` to
    ``out/level`` and run the same command; the finished run's archive restores the fields its report
    draws."""
    import shutil
    import sqlite3

    from optimizer.campaign.fields import fields_path
    from optimizer.campaign.packed import pack
    from optimizer.campaign.store import STORE_NAME, locate, stored
    from optimizer.report.html import fields_shown
    from optimizer.report.run import load_run

    runs = [load_run(out / level / case) for case in cases if stored(out / level / case / STORE_NAME)]
    for run in (r for r in runs if r.campaign.state != "finished"):
        kept = "archived without fields" if unfinished else "not archived"
        print(f"{run.directory}: {kept}, the campaign is {run.campaign.state}", file=sys.stderr)
    # a finished run archived before (copied back to continue the study) keeps the fields the report draws and
    # no others: archiving it again would solve the rest of its front again for nothing
    done = {r.directory for r in runs if r.campaign.state == "finished" and _archived(r, dest / level)}
    for directory in sorted(done):
        print(f"{directory}: already archived in {dest / level / directory.name}", file=sys.stderr)
    for run in (r for r in runs if r.campaign.state == "finished" and r.directory not in done):
        restore_fields(run.directory)
    shown = fields_shown([r for r in runs if r.campaign.state == "finished"])
    runs = [r for r in runs if (unfinished or r.campaign.state == "finished") and r.directory not in done]
    for run in runs:
        target = dest / level / run.directory.name
        shutil.rmtree(target, ignore_errors=True)
        target.mkdir(parents=True)
        shutil.copy2(run.directory / "config.yaml", target / "config.yaml")
        _, readable = locate(run.directory / STORE_NAME)      # a packed run is read from its unpacked copy
        source = sqlite3.connect(f"file:{readable}?mode=ro", uri=True)
        copy = sqlite3.connect(target / STORE_NAME)
        try:
            source.backup(copy)
            with copy:
                copy.execute("UPDATE campaign SET message = replace(message, ?, ?)",
                             (str(run.directory), str(_in_repository(target))))
        finally:
            source.close()
            copy.close()
        pack(target / STORE_NAME)
        (target / "driver.lock").unlink(missing_ok=True)
        for key in sorted(shown.get(run.directory, ())):
            kept = fields_path(run.directory, key)
            if kept.is_file():
                fields_path(target, key).parent.mkdir(exist_ok=True)
                shutil.copy2(kept, fields_path(target, key))
        size = sum(f.stat().st_size for f in target.rglob("*") if f.is_file())
        print(f"{target}: {size / 1e6:.2f} MB ({len(shown.get(run.directory, ()))} fields files)", file=sys.stderr)


def _in_repository(path: Path) -> Path:
    """``path`` relative to the git repository that holds it (a kept store must not name this machine's
    directories), else as given."""
    path = path.resolve()
    for parent in path.parents:
        if (parent / ".git").exists():
            return path.relative_to(parent)
    return path


def _archived(run, dest: Path) -> bool:
    """Whether ``dest`` holds ``run``'s finished campaign already (same start, same evaluations)."""
    from optimizer.campaign.store import STORE_NAME, stored
    from optimizer.report.run import load_run

    target = dest / run.directory.name
    if not stored(target / STORE_NAME):
        return False
    kept = load_run(target)
    return (kept.campaign.state == "finished" and kept.campaign.started == run.campaign.started
            and len(kept.designs) == len(run.designs))


def summary(out: Path, level: str, cases) -> None:
    print(f"# the paper's cases, surrogate-assisted, {level} mesh; machine {platform.node()}, {os.cpu_count()} cores")
    print("| case | state | generations | CFD evaluations | CPU hours | wall hours | of it, model fit and screening |")
    print("|---|---|---|---|---|---|---|")
    for case in cases:
        c = cost(out / level / case)
        if c is None:
            print(f"| {case} | not started | | | | | |")
            continue
        share = "-" if c["surrogate_share"] is None else f"{100 * c['surrogate_share']:.1f} %"
        print(f"| {case} | {c['state']} | {c['generations']} | {c['evaluations']} | {c['cpu_hours']:.2f} "
              f"| {c['wall_hours']:.2f} | {share} |")
    runs = " ".join(str(out / level / case) for case in cases if (out / level / case).exists())
    print(f"\nmillfoil report {runs} --out {out / level / 'report'}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--level", choices=["coarse", "medium", "fine"], default="coarse")
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--workers", type=int, help="execution.workers of every run (default: one per core)")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "examples" / "paper")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
                        help="change a key of the configuration of the cases started now (repeatable)")
    parser.add_argument("--report-only", action="store_true", help="summarise the stores already there")
    parser.add_argument("--archive", type=Path, metavar="DEST",
                        help="then copy the runs to DEST/LEVEL as the repository keeps them (packed stores, the "
                        "fields the report draws): e.g. runs/examples/paper")
    parser.add_argument("--unfinished", action="store_true",
                        help="with --archive, copy the runs that are not finished too (their stores, without fields), "
                        "to continue the study on another machine: copy DEST/LEVEL to OUT/LEVEL there")
    args = parser.parse_args()
    if not args.report_only:
        for case in args.cases:
            run_case(case, args.level, args.out / args.level / case, args.workers, args.settings)
    summary(args.out, args.level, args.cases)
    if args.archive:
        archive(args.out.resolve(), args.level, args.cases, args.archive.resolve(), args.unfinished)
    return 0


if __name__ == "__main__":
    sys.exit(main())
