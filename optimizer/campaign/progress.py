"""Progress of a running campaign and summaries of a stored one, as text.

:class:`ProgressDisplay` receives :class:`optimizer.campaign.driver.GenerationProgress` events. On a
terminal it keeps one status line updated in place (done / failed / running, best objectives,
hypervolume, ETA) and leaves one line per finished generation above it; elsewhere (a log file, a batch
job) it writes only the line per finished generation — a log, not a flood.

:func:`status_of` reads a store (read-only, safe while the campaign runs) into a JSON-able summary, and
:func:`format_status` / :func:`status_table` / :func:`front_table` turn summaries into text for ``millfoil
status`` (one run, several) and the end of ``millfoil run``; :func:`format_damaged` shows what a damaged
store still holds (its :class:`~optimizer.campaign.store.StoreInspection`), before ``millfoil status`` says
it is damaged.
"""

from __future__ import annotations

import datetime as _dt
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from optimizer.campaign.offspring import THETA_KEYS
from optimizer.campaign.store import STORE_NAME, EvaluationRow, Store, StoreInspection, check_values


def duration(seconds: float | None) -> str:
    """``1h02m``, ``3m05s``, ``42s`` or ``?``."""
    if seconds is None:
        return "?"
    s = int(round(seconds))
    if s >= 3600:
        return f"{s // 3600}h{(s % 3600) // 60:02d}m"
    if s >= 60:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s}s"


def number(v: float | None) -> str:
    return "-" if v is None else f"{v:.4g}"


def figures_text(values: dict[str, float], units: dict[str, str]) -> str:
    """``|fy| 1.151e+04 N/m, c_max 13.32 m/s``: labelled values with their units, or ``-``."""
    return ", ".join(f"{k} {number(v)}" + (f" {units[k]}" if units.get(k) else "") for k, v in values.items()) or "-"


def progress_line(p) -> str:
    """One line for a :class:`GenerationProgress`, most telling first (a terminal may cut its end)."""
    best = figures_text(p.best, p.units)
    share = "-" if p.feasible_share is None else f"{p.feasible_share:.0%}"
    counts = f"{p.done} done, {p.failed} failed, {p.infeasible} infeasible, {p.cached} cached"
    if not p.finished:
        counts += f", {p.running} running"
    line = (f"generation {p.generation + 1}/{p.generations}: {counts} of {p.total} | ETA {duration(p.eta_s)} | "
            f"best {best} | hypervolume {number(p.hypervolume)} | feasible {share}")
    search = search_text(p.search)
    return f"{line} | {search}" if search else line


def search_text(search: dict | None) -> str:
    """How a generation's offspring were found, in a few words: ``drew 120, 100 feasible, 100 to CFD``
    (plain), ``drew 1000, 765 screened, 20 to CFD (2 of 22 checked infeasible)`` (surrogate; with CFD
    constraints ``20 to CFD, 5 bisecting constraint boundaries``: the boundary share) and, once evaluated,
    the models' out-of-sample error on them (surrogate mode)."""
    if not search or search.get("drawn") is None:
        return ""
    if "checked" in search:     # surrogate: the pool passed the cheap conditions, the batch the full check
        roles = [p.get("role") for p in (search.get("predicted") or {}).values()]
        boundary = f", {roles.count('boundary')} bisecting constraint boundaries" if "boundary" in roles else ""
        text = (f"drew {search['drawn']}, {search['screened']} screened, {search['batch']} to CFD{boundary} "
                f"({search['rejected']} of {search['checked']} checked infeasible)")
    else:
        text = f"drew {search['drawn']}, {search['screened']} feasible, {search['batch']} to CFD"
    if search.get("fallback"):
        text += f" (NSGA-II's own offspring: {search['fallback']})"
    error = search.get("error")
    if error:
        text += "; model error " + ", ".join(f"{k} {v:.0%}" for k, v in error.items())
    failures = search.get("failures") or {}
    if failures.get("observed") is not None and failures.get("predicted") is not None:
        text += f", failed {failures['observed']:.0%} (predicted {failures['predicted']:.0%})"
    return text


class ProgressDisplay:
    """Callable progress sink (see the module docstring); ``live`` defaults to ``stream.isatty()``."""

    def __init__(self, stream: TextIO | None = None, live: bool | None = None):
        self.stream = stream or sys.stderr
        self.live = self.stream.isatty() if live is None else live
        self._pending = False

    def __call__(self, p) -> None:
        line = progress_line(p)
        if p.finished:
            self._clear()
            print(line, file=self.stream, flush=True)
        elif self.live:
            self._clear()
            print(line[: _width() - 1], end="", file=self.stream, flush=True)
            self._pending = True

    def log(self, line: str) -> None:
        self._clear()
        print(f"millfoil: {line}", file=self.stream, flush=True)

    def _clear(self) -> None:
        if self._pending:
            print("\r\033[K", end="", file=self.stream)
            self._pending = False


def _width() -> int:
    import shutil

    return shutil.get_terminal_size((120, 20)).columns


# -------------------------------------------------------------------------------------------- status
def status_of(directory: str | Path) -> dict:
    """A JSON-able summary of the campaign in ``directory`` read from its store (read-only). A damaged
    store raises :class:`~optimizer.campaign.store.StoreDamaged` (its ``inspection``: what can be read)."""
    from optimizer.campaign.driver import saved_config

    with Store(Path(directory) / STORE_NAME, readonly=True) as store:
        row = store.campaign()
        if row is None:
            raise FileNotFoundError(f"{directory}: the store holds no campaign yet")
        config = saved_config(row.config)
        generations = store.generations()
        rows = list(store.evaluations())
    check_values(Path(directory) / STORE_NAME, rows, [o.label for o in config.objectives])
    by_status = dict(Counter(str(r.status) for r in rows))
    by_class = dict(Counter(str(r.convergence) for r in rows if r.convergence))
    labels = [o.label for o in config.objectives]
    senses = {o.label: o.sense for o in config.objectives}
    best: dict[str, float] = {}
    for r in rows:
        if r.feasible and r.objectives:
            for k in labels:
                v = r.objectives[k]
                if k not in best or (v > best[k] if senses[k] == "max" else v < best[k]):
                    best[k] = v
    done = len(generations)
    current = [r for r in rows if r.generation == done]
    seconds = [r.wall_seconds for r in rows if r.wall_seconds is not None]
    return {
        "directory": str(directory), "state": row.state, "message": row.message, "started": row.started,
        "driver": _driver(directory) if row.state == "running" else None,
        "ended": row.ended, "version": row.version, "seed": row.seed,
        "generations": {"done": done, "total": config.algorithm.generations},
        "population": config.algorithm.population, "evaluations": len(rows), "by_status": by_status,
        "by_class": by_class, "current_generation": {"index": done, "stored": len(current)},
        "best": best, "objectives": labels, "units": {o.label: o.unit for o in config.objectives},
        "hypervolume": [g.hypervolume for g in generations],
        "feasible_share": [g.feasible_share for g in generations],
        "cache_hits": sum(g.cache_hits for g in generations),
        "method": config.algorithm.method,
        "search": [{"generation": g.generation + 1, **{k: v for k, v in (g.search or {}).items()
                                                     if k not in ("predicted", "scale", *THETA_KEYS)}}
                   for g in generations],
        "mean_evaluation_seconds": sum(seconds) / len(seconds) if seconds else None,
        "remaining": None if row.state == "finished" else remaining(config.algorithm.evaluations, rows, generations),
        "last_stored": max((r.finished for r in rows), default=None),
        "problem": (config.analytic.problem if config.analytic
                    else f"{config.blade.mode.value} {config.blade.continuity.value}"),
    }


def _driver(directory: str | Path) -> dict:
    """``{"alive": True/False/None, "holder": …}`` of a campaign whose store says it is running: whether a
    live driver holds its directory (:func:`optimizer.campaign.lock.probe`; None: the lock cannot tell)."""
    from optimizer.campaign.lock import probe

    alive, holder = probe(directory)
    return {"alive": alive, "holder": holder}


#: Stored evaluations whose pace :func:`remaining` reads, the most recent ones.
PACE_WINDOW = 100


def remaining(planned: int, rows: Sequence[EvaluationRow], generations) -> dict:
    """``{"evaluations": n, "seconds": s}``: the evaluations the campaign has still to run (``planned``: the
    configuration's most, less those stored and the generations' cache hits) and the wall seconds they take
    at the run's recent pace: the mean gap between the last :data:`PACE_WINDOW` stored evaluations, without
    the gaps over ten times their median (a stop before a resume). ``seconds`` is None before ten gaps."""
    import numpy as np

    left = max(0, planned - len(rows) - sum(g.cache_hits for g in generations))
    times = sorted(_dt.datetime.fromisoformat(r.finished).timestamp() for r in rows if r.finished)
    gaps = np.diff(times[-PACE_WINDOW:])
    if len(gaps) < 10:
        return {"evaluations": left, "seconds": None}
    gaps = gaps[gaps <= 10.0 * np.median(gaps)]
    return {"evaluations": left, "seconds": left * float(gaps.mean())}


def format_status(s: dict) -> str:
    """``millfoil status`` text of a :func:`status_of` summary."""
    g = s["generations"]
    lines = [
        f"campaign {s['directory']}: {_state_text(s)}",
        f"  started {s['started']}" + (f", ended {s['ended']}" if s.get("ended") else "")
        + f"; millfoil {s['version']}, seed {s['seed']}",
        f"  generations {g['done']}/{g['total']} (population {s['population']}); "
        f"{s['current_generation']['stored']} evaluations of generation {g['done'] + 1} stored"
        if g["done"] < g["total"] else f"  generations {g['done']}/{g['total']} (population {s['population']})",
        f"  evaluations {s['evaluations']}: " + ", ".join(f"{k} {v}" for k, v in sorted(s["by_status"].items())),
        "  convergence classes: " + (", ".join(f"{k} {v}" for k, v in sorted(s["by_class"].items())) or "-"),
        "  best: " + figures_text(s["best"], s.get("units", {})),
        f"  hypervolume (last generation): {number(s['hypervolume'][-1] if s['hypervolume'] else None)}; "
        f"feasible share of offspring (last): "
        + ("-" if not s["feasible_share"] or s["feasible_share"][-1] is None else f"{s['feasible_share'][-1]:.0%}")
        + f"; cache hits {s['cache_hits']}; mean evaluation {duration(s['mean_evaluation_seconds'])}",
    ]
    left = s.get("remaining")
    if left and left["evaluations"]:
        lines.append(f"  remaining: about {left['evaluations']} evaluations"
                     + (f", {duration(left['seconds'])} at the recent pace" if left["seconds"] is not None else ""))
    searched = [x for x in s.get("search", []) if x.get("drawn") is not None]
    if searched:
        last = searched[-1]
        lines.append(f"  offspring ({s.get('method', 'nsga2')}), generation {last['generation']}: "
                     + search_text(last))
    return "\n".join(lines)


def _state_text(s: dict) -> str:
    """The state of a :func:`status_of` summary in words. A driver killed outright (``kill -9``, a node or
    job that stopped) cannot record that it stopped, so a store that says "running" is checked against the
    directory's lock; where the lock cannot tell, how long ago the last result came is the hint."""
    state, driver = s["state"], s.get("driver") or {}
    age = ""
    if s.get("last_stored"):
        seconds = (_dt.datetime.now(_dt.UTC) - _dt.datetime.fromisoformat(s["last_stored"])).total_seconds()
        age = f"last evaluation stored {duration(seconds)} ago"
    if _driver_gone(s):
        return (f"stopped without recording it: no driver holds the directory (killed, or its machine or job "
                f"ended){'; ' + age if age else ''}; continue with `millfoil resume {s['directory']}`")
    if state == "running":
        notes = ([f"driver: {driver['holder']}"] if driver.get("alive") else []) + ([age] if age else [])
        state += f" ({'; '.join(notes)})" if notes else ""
    return state + (f" ({s['message']})" if s.get("message") else "")


def _driver_gone(s: dict) -> bool:
    """Whether the store of summary ``s`` says "running" while no driver holds its directory."""
    return s["state"] == "running" and (s.get("driver") or {}).get("alive") is False


def status_table(summaries: Sequence[dict], unreadable: Sequence[tuple[str, str]] = ()) -> str:
    """``millfoil status`` of several runs: one line each (state, generations, evaluations and how many gave
    values, best objectives, what remains), then a line per run that could not be read (``unreadable``:
    ``(directory, why)``)."""
    head = ["run", "state", "generations", "evaluations", "ok", "best", "remaining"]
    body = []
    for s in summaries:
        state = "stopped (no driver)" if _driver_gone(s) else s["state"]
        left = s.get("remaining") or {}
        body.append([s["directory"], state, f"{s['generations']['done']}/{s['generations']['total']}",
                     str(s["evaluations"]), str(s["by_status"].get("ok", 0)),
                     figures_text(s["best"], s.get("units", {})),
                     f"{left['evaluations']}, {duration(left['seconds'])}" if left.get("evaluations") else "-"])
    widths = [max(len(row[j]) for row in [head, *body]) for j in range(len(head))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in [head, *body]]
    return "\n".join(lines + [f"{directory}: unreadable: {why}" for directory, why in unreadable])


def format_damaged(directory: str | Path, inspection: StoreInspection) -> str:
    """``millfoil status`` text of a damaged store: what it still holds, table by table, as far as SQLite,
    JSON and YAML read it (the one-line error that follows says what is damaged)."""
    lines = [f"campaign {directory}: damaged store ({inspection.path.name}, {inspection.size} bytes)"]
    if inspection.error is not None:
        lines.append(f"  {inspection.error}; {inspection.readable}")
        return "\n".join(lines)
    c = inspection.campaign
    if c:
        lines.append(f"  state {c['state']}" + (f" ({c['message']})" if c.get("message") else "")
                     + f"; started {c['started']}" + (f", ended {c['ended']}" if c.get("ended") else "")
                     + f"; millfoil {c['version']}, seed {c['seed']}")
    for t in inspection.tables:
        if not t.present:
            text = "missing"
        else:
            text = f"{t.readable_rows} row{'s' * (t.readable_rows != 1)} readable"
            if t.invalid:
                named = ", ".join(f"{row}: {column}" for row, column, _ in t.invalid[:5])
                more = f" and {len(t.invalid) - 5} more" if len(t.invalid) > 5 else ""
                text += f"; {len(t.invalid)} value(s) that do not parse ({named}{more})"
            if not t.complete:
                text += f"; unreadable after row {t.rows} ({t.error})"
        if t.name == "evaluations" and inspection.by_status:
            counts = sorted(inspection.by_status.items(), key=lambda kv: str(kv[0]))    # a damaged status: NULL
            text += "; by status: " + ", ".join(f"{k} {v}" for k, v in counts)
        lines.append(f"  {t.name} table: {text}")
    return "\n".join(lines)


def front_table(rows: Sequence[EvaluationRow], labels: Sequence[str]) -> str:
    """The non-dominated designs as a text table: objectives, convergence class, generation, key."""
    if not rows:
        return "no feasible design yet"
    head = ["#", *labels, "class", "gen", "key"]
    body = [[str(i + 1), *(number(r.objectives[k]) for k in labels), r.convergence or "-", str(r.generation + 1),
             r.key[:10]] for i, r in enumerate(rows)]
    widths = [max(len(row[j]) for row in [head, *body]) for j in range(len(head))]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    return "\n".join(fmt.format(*row) for row in [head, *body])


def write_front_csv(rows: Sequence[EvaluationRow], labels: Sequence[str], path: str | Path) -> Path:
    """The non-dominated designs with every parameter as CSV (objectives, class, generation, key,
    parameters in configuration units: metres, degrees), written whole or not at all
    (:func:`optimizer.saving.write_atomic`: an error leaves no file and any earlier one as it was)."""
    import csv

    from optimizer.saving import write_atomic

    names = sorted({n for r in rows for n in r.parameters})

    def write(temporary: Path) -> None:
        with open(temporary, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([*labels, "class", "generation", "key", *names])
            for r in rows:
                w.writerow([*(repr(r.objectives[k]) for k in labels), r.convergence or "", r.generation + 1,
                            r.key, *(repr(r.parameters.get(n, "")) for n in names)])

    return write_atomic(path, write)
