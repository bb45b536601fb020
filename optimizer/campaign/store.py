"""The evaluation store of a campaign: one SQLite file in the run directory, written only by the driver.

Every evaluation is written the moment it finishes, so a driver that dies (SIGKILL, node loss, wall
time) loses nothing that was computed; ``millfoil resume`` rebuilds the optimiser from these tables.
WAL journal mode lets any number of readers (``millfoil status``, a report) read while the driver writes,
from another process or a login node sharing the file system.

Tables (the full reference with every column is in ``docs/explanation/campaigns.md``):

``campaign``
    one row: the resolved configuration (YAML), seed, millfoil version, start and end times (UTC ISO
    8601), state (``running``, ``finished``, ``interrupted``, ``failed``), the hypervolume reference point.
``evaluations``
    one row per distinct design (``key``: content hash of everything that determines the result): design
    vector, blade parameters, status and reason, convergence class and per-monitor window mean and
    amplitude, objectives (as the user states them, and as minimised), constraint values (G ≤ 0
    feasible), figures, cells, per-stage seconds, generation, worker, timestamps.
``generations``
    one row per finished generation: the population members' keys in order with their NSGA-II rank and
    crowding distance, the offspring keys, the feasible share of offspring, cache hits, hypervolume and
    the optimiser's random state after the generation (JSON) — what :mod:`optimizer.campaign.driver`
    needs to continue exactly where an uninterrupted run would be — and ``search``: how the generation's
    offspring were found (candidates drawn and geometrically feasible; with the surrogate, the models'
    hyperparameters, predictions for the batch and their out-of-sample error, fit and screen seconds).

Values are JSON text where they are structured; floats round-trip exactly (``repr``). Non-finite floats
are stored as the strings ``"inf"``, ``"-inf"``, ``"nan"`` so that any JSON reader can read the columns.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import sqlite3
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from optimizer.campaign.status import EvaluationStatus
from solver.convergence import ConvergenceClass

#: File name of the store in the run directory.
STORE_NAME = "campaign.sqlite"
#: Schema version written in ``PRAGMA user_version``; bump on any change of the tables.
SCHEMA_VERSION = 2
#: Columns added after the first schema, with their SQL type: a store written by an earlier millfoil gains
#: them (empty) when the driver opens it.
_ADDED_COLUMNS = {"generations": {"search": "TEXT"}}

#: Campaign states.
STATES = ("running", "finished", "interrupted", "failed")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS campaign (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    config TEXT NOT NULL,
    seed INTEGER NOT NULL,
    version TEXT NOT NULL,
    started TEXT NOT NULL,
    ended TEXT,
    state TEXT NOT NULL,
    reference TEXT,
    message TEXT
);
CREATE TABLE IF NOT EXISTS evaluations (
    key TEXT PRIMARY KEY,
    generation INTEGER NOT NULL,
    x TEXT NOT NULL,
    parameters TEXT NOT NULL,
    status TEXT NOT NULL,
    reason TEXT NOT NULL,
    class TEXT,
    objectives TEXT,
    minimised TEXT NOT NULL,
    constraints TEXT NOT NULL,
    figures TEXT,
    monitors TEXT,
    cells INTEGER,
    iterations INTEGER,
    seconds TEXT,
    wall_seconds REAL,
    worker TEXT,
    submitted TEXT,
    finished TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS evaluations_generation ON evaluations (generation);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY,
    members TEXT NOT NULL,
    rank TEXT NOT NULL,
    crowding TEXT NOT NULL,
    offspring TEXT NOT NULL,
    feasible_offspring INTEGER NOT NULL,
    feasible_share REAL,
    cache_hits INTEGER NOT NULL,
    hypervolume REAL,
    rng_state TEXT NOT NULL,
    finished TEXT NOT NULL,
    search TEXT
);
"""


def now() -> str:
    """The current UTC time, ISO 8601 with microseconds (sorts as text)."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="microseconds")


def dumps(value: Any) -> str:
    """JSON text with non-finite floats as strings (see the module docstring)."""
    return json.dumps(_finite(value), allow_nan=False)


def loads(text: str | None) -> Any:
    """Inverse of :func:`dumps` for floats: ``"inf"``, ``"-inf"``, ``"nan"`` become floats again."""
    return None if text is None else _infinite(json.loads(text))


def _finite(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, Mapping):
        return {str(k): _finite(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_finite(x) for x in v]
    if hasattr(v, "item") and callable(v.item):       # numpy scalars
        return _finite(v.item())
    return v


def _infinite(v: Any) -> Any:
    if isinstance(v, str) and v in ("inf", "-inf", "nan"):
        return float(v)
    if isinstance(v, dict):
        return {k: _infinite(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_infinite(x) for x in v]
    return v


@dataclass(frozen=True)
class EvaluationRow:
    """One row of ``evaluations`` (see ``docs/explanation/campaigns.md`` for the meaning of each field).

    x: design vector (configuration units). parameters: ``{name: value}`` of the whole blade (or the
    analytic problem's variables). objectives: ``{name: value}`` as the user states them (``None`` when
    the design has no usable values); minimised: the vector handed to the optimiser (senses applied,
    failures as a large value). constraints: ``{name: G}``, G ≤ 0 feasible. monitors: ``{monitor:
    {"mean", "amplitude", "status"}}`` of the solve's window. seconds: ``{stage: s}``; wall_seconds: the
    time seen by the runner.
    """

    key: str
    generation: int
    x: list[float]
    parameters: dict[str, float]
    status: EvaluationStatus
    reason: str
    minimised: list[float]
    constraints: dict[str, float]
    finished: str = field(default_factory=now)
    convergence: ConvergenceClass | None = None
    objectives: dict[str, float | None] | None = None
    figures: dict[str, Any] | None = None
    monitors: dict[str, Any] | None = None
    cells: int | None = None
    iterations: int | None = None
    seconds: dict[str, float] | None = None
    wall_seconds: float | None = None
    worker: str | None = None
    submitted: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", EvaluationStatus.parse(self.status))
        if self.convergence is not None:
            object.__setattr__(self, "convergence", ConvergenceClass(self.convergence))

    @property
    def ok(self) -> bool:
        return self.status is EvaluationStatus.OK

    @property
    def feasible(self) -> bool:
        """Accepted values and every constraint satisfied."""
        return self.ok and all(v <= 0.0 for v in self.constraints.values())


@dataclass(frozen=True)
class GenerationRow:
    """One row of ``generations``: the population after generation ``generation`` (keys in order, with
    their rank and crowding distance), its offspring, and the optimiser's random state at that point."""

    generation: int
    members: list[str]
    rank: list[int]
    crowding: list[float]
    offspring: list[str]
    feasible_offspring: int
    feasible_share: float | None
    cache_hits: int
    hypervolume: float | None
    rng_state: dict
    finished: str = field(default_factory=now)
    search: dict | None = None


@dataclass(frozen=True)
class CampaignRow:
    """The ``campaign`` row."""

    config: str
    seed: int
    version: str
    started: str
    ended: str | None
    state: str
    reference: list[float] | None
    message: str | None


class Store:
    """The SQLite store of one run (see the module docstring).

    ``Store(path)`` opens (creating the tables if needed) for writing — only the driver does that;
    ``Store(path, readonly=True)`` opens an existing store for reading, safe while the driver runs.
    ``sync``: ``full`` (default) or ``normal``, SQLite's ``synchronous`` (see ``output.sync``).
    """

    def __init__(self, path: str | Path, *, readonly: bool = False, sync: str = "full"):
        self.path = Path(path)
        if readonly:
            if not self.path.exists():
                raise FileNotFoundError(f"no campaign store at {self.path}")
            self._db = sqlite3.connect(f"file:{self.path}?mode=ro", uri=True, timeout=30.0)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(self.path, timeout=30.0)
            self._db.execute("PRAGMA journal_mode=WAL")
            # FULL: a finished evaluation survives a power cut of the driver's machine too, for one fsync
            # (about 1 ms here) per evaluation, far below a solve; NORMAL: it survives the driver's death (SIGKILL).
            if sync not in ("full", "normal"):
                raise ValueError(f"sync must be 'full' or 'normal', got {sync!r}")
            self._db.execute(f"PRAGMA synchronous={sync.upper()}")
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise RuntimeError(f"{self.path}: store schema {version}, this millfoil reads up to {SCHEMA_VERSION}")
            with self._db:
                self._db.executescript(_SCHEMA)
                for table, columns in _ADDED_COLUMNS.items():
                    have = {r[1] for r in self._db.execute(f"PRAGMA table_info({table})")}
                    for name, kind in columns.items():
                        if name not in have:
                            self._db.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")
                self._db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        self._db.row_factory = sqlite3.Row
        self.readonly = readonly

    # --------------------------------------------------------------------------------------- lifecycle
    def set_sync(self, sync: str) -> None:
        """Change SQLite's ``synchronous`` level (``full`` or ``normal``) of this connection."""
        if sync not in ("full", "normal"):
            raise ValueError(f"sync must be 'full' or 'normal', got {sync!r}")
        self._db.execute(f"PRAGMA synchronous={sync.upper()}")

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---------------------------------------------------------------------------------------- campaign
    def start_campaign(self, config_yaml: str, seed: int, version: str) -> None:
        """Write the campaign row (first run) or mark an existing one ``running`` again (resume)."""
        with self._db:
            if self.campaign() is None:
                self._db.execute("INSERT INTO campaign (id, config, seed, version, started, state) "
                                 "VALUES (1, ?, ?, ?, ?, 'running')", (config_yaml, seed, version, now()))
            else:
                self._db.execute("UPDATE campaign SET state='running', ended=NULL, message=NULL WHERE id=1")

    def end_campaign(self, state: str, message: str | None = None) -> None:
        if state not in STATES:
            raise ValueError(f"unknown campaign state {state!r}; allowed: {', '.join(STATES)}")
        with self._db:
            self._db.execute("UPDATE campaign SET state=?, ended=?, message=? WHERE id=1", (state, now(), message))

    def set_reference(self, reference: Iterable[float]) -> None:
        """Fix the hypervolume reference point (minimised objective space) once for the whole run."""
        with self._db:
            self._db.execute("UPDATE campaign SET reference=? WHERE id=1", (dumps([float(v) for v in reference]),))

    def campaign(self) -> CampaignRow | None:
        row = self._db.execute("SELECT * FROM campaign WHERE id=1").fetchone()
        if row is None:
            return None
        return CampaignRow(row["config"], row["seed"], row["version"], row["started"], row["ended"],
                           row["state"], loads(row["reference"]), row["message"])

    # ------------------------------------------------------------------------------------- evaluations
    def add(self, row: EvaluationRow) -> None:
        """Insert one finished evaluation (committed at once). A key already present is an error: the
        driver never evaluates a stored design again."""
        with self._db:
            self._db.execute(
                "INSERT INTO evaluations (key, generation, x, parameters, status, reason, class, objectives, "
                "minimised, constraints, figures, monitors, cells, iterations, seconds, wall_seconds, worker, "
                "submitted, finished) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (row.key, row.generation, dumps(row.x), dumps(row.parameters), row.status, row.reason,
                 row.convergence, None if row.objectives is None else dumps(row.objectives), dumps(row.minimised),
                 dumps(row.constraints), None if row.figures is None else dumps(row.figures),
                 None if row.monitors is None else dumps(row.monitors), row.cells, row.iterations,
                 None if row.seconds is None else dumps(row.seconds), row.wall_seconds, row.worker,
                 row.submitted, row.finished))

    def get(self, key: str) -> EvaluationRow | None:
        row = self._db.execute("SELECT * FROM evaluations WHERE key=?", (key,)).fetchone()
        return None if row is None else _evaluation(row)

    def get_many(self, keys: Iterable[str]) -> dict[str, EvaluationRow]:
        """``{key: row}`` for those of ``keys`` that are stored."""
        keys = list(dict.fromkeys(keys))
        found: dict[str, EvaluationRow] = {}
        for i in range(0, len(keys), 500):        # SQLite's host-parameter limit
            chunk = keys[i:i + 500]
            marks = ",".join("?" * len(chunk))
            for row in self._db.execute(f"SELECT * FROM evaluations WHERE key IN ({marks})", chunk):
                found[row["key"]] = _evaluation(row)
        return found

    def evaluations(self, generation: int | None = None) -> Iterator[EvaluationRow]:
        """Stored evaluations in the order they finished (optionally of one generation)."""
        if generation is None:
            rows = self._db.execute("SELECT * FROM evaluations ORDER BY finished, rowid")
        else:
            rows = self._db.execute("SELECT * FROM evaluations WHERE generation=? ORDER BY finished, rowid",
                                    (generation,))
        for row in rows:
            yield _evaluation(row)

    def front(self) -> list[EvaluationRow]:
        """The non-dominated designs among every stored feasible accepted design (``minimised``: smaller
        is better in each), sorted by the first minimised objective; designs with equal vectors are all kept."""
        rows = [r for r in self.evaluations() if r.feasible]
        if not rows:
            return []
        keep = non_dominated(np.array([r.minimised for r in rows], float))
        return sorted((r for r, k in zip(rows, keep, strict=True) if k), key=lambda r: r.minimised[0])

    def count_by_status(self, generation: int | None = None) -> dict[str, int]:
        where, args = ("WHERE generation=?", (generation,)) if generation is not None else ("", ())
        rows = self._db.execute(f"SELECT status, COUNT(*) FROM evaluations {where} GROUP BY status", args)
        return {status: n for status, n in rows}

    # ------------------------------------------------------------------------------------- generations
    def add_generation(self, row: GenerationRow) -> None:
        with self._db:
            self._db.execute(
                "INSERT INTO generations (generation, members, rank, crowding, offspring, feasible_offspring, "
                "feasible_share, cache_hits, hypervolume, rng_state, finished, search) "
                "VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                (row.generation, dumps(row.members), dumps(row.rank), dumps(row.crowding), dumps(row.offspring),
                 row.feasible_offspring, row.feasible_share, row.cache_hits, row.hypervolume,
                 json.dumps(row.rng_state), row.finished, None if row.search is None else dumps(row.search)))

    def generations(self) -> list[GenerationRow]:
        return [_generation(r) for r in self._db.execute("SELECT * FROM generations ORDER BY generation")]

    def last_generation(self) -> GenerationRow | None:
        row = self._db.execute("SELECT * FROM generations ORDER BY generation DESC LIMIT 1").fetchone()
        return None if row is None else _generation(row)


def non_dominated(F: np.ndarray, chunk: int = 256) -> np.ndarray:
    """``(n,)`` mask of the rows of ``F (n, m)`` that no other row dominates (≤ in every column, < in one);
    minimisation. Compared in chunks of rows: memory ``chunk × n × m``."""
    F = np.asarray(F, float)
    keep = np.ones(len(F), bool)
    for i in range(0, len(F), chunk):
        a = F[i:i + chunk, None, :]
        dominated = np.all(F[None] <= a, axis=2) & np.any(F[None] < a, axis=2)
        keep[i:i + chunk] = ~dominated.any(axis=1)
    return keep


def _evaluation(r: sqlite3.Row) -> EvaluationRow:
    return EvaluationRow(
        key=r["key"], generation=r["generation"], x=loads(r["x"]), parameters=loads(r["parameters"]),
        status=r["status"], reason=r["reason"], convergence=r["class"], objectives=loads(r["objectives"]),
        minimised=loads(r["minimised"]), constraints=loads(r["constraints"]), figures=loads(r["figures"]),
        monitors=loads(r["monitors"]), cells=r["cells"], iterations=r["iterations"], seconds=loads(r["seconds"]),
        wall_seconds=r["wall_seconds"], worker=r["worker"], submitted=r["submitted"], finished=r["finished"])


def _generation(r: sqlite3.Row) -> GenerationRow:
    return GenerationRow(
        generation=r["generation"], members=loads(r["members"]), rank=loads(r["rank"]),
        crowding=loads(r["crowding"]), offspring=loads(r["offspring"]), feasible_offspring=r["feasible_offspring"],
        feasible_share=r["feasible_share"], cache_hits=r["cache_hits"], hypervolume=r["hypervolume"],
        rng_state=json.loads(r["rng_state"]), finished=r["finished"],
        search=loads(r["search"]) if "search" in r.keys() else None)
