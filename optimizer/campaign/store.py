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

A damaged store (a truncated or overwritten file, a table dropped, a row whose JSON or configuration YAML
does not parse) raises :class:`StoreDamaged` — a bad input, exit status 2 — when it is opened or read,
never a bare SQLite, JSON or YAML error; :func:`inspect_store` says what is damaged and what can still be
read, table by table.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import json
import lzma
import math
import os
import sqlite3
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from optimizer.campaign.packed import PACKED_SUFFIX, packed_path, unpacked_copy
from optimizer.campaign.status import EvaluationStatus
from optimizer.config import ConfigError
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


#: Columns holding JSON text, by table: every table of the store (a store lacking one is damaged).
JSON_COLUMNS = {
    "campaign": ("reference",),
    "evaluations": ("x", "parameters", "objectives", "minimised", "constraints", "figures", "monitors", "seconds"),
    "generations": ("members", "rank", "crowding", "offspring", "rng_state", "search"),
}
TABLES = tuple(JSON_COLUMNS)
#: The first bytes of every SQLite database file.
_SQLITE_HEADER = b"SQLite format 3\x00"
#: Invalid rows a damage message names before it counts the rest.
_NAMED_ROWS = 3


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


# ------------------------------------------------------------------------------------------ damage
class StoreDamaged(ConfigError):
    """A store that cannot be read whole: a truncated or overwritten file, a missing table, a row whose JSON
    or whose configuration YAML does not parse. A bad input (exit status 2), raised before anything reads
    or writes past the damage; ``inspection`` (:func:`inspect_store`) says what is damaged and what can
    still be read, and the message is ``PATH is damaged: WHAT; WHAT CAN STILL BE READ``."""

    def __init__(self, inspection: StoreInspection):
        self.inspection = inspection
        super().__init__(f"{inspection.path} is damaged: {inspection.damage}; {inspection.readable}")


@dataclass(frozen=True)
class TableState:
    """One table as :func:`inspect_store` found it.

    present: the table exists. rows: rows SQLite could read; complete: all of them (else ``error`` is
    SQLite's reason for stopping). invalid: ``(row, column, why)`` of every value that does not parse,
    the row named as a user knows it (``design 12``, ``generation 3``, ``the campaign row``).
    """

    name: str
    present: bool
    rows: int = 0
    complete: bool = True
    error: str | None = None
    invalid: tuple[tuple[str, str, str], ...] = ()

    @property
    def damaged(self) -> bool:
        return not self.present or not self.complete or bool(self.invalid)

    @property
    def readable_rows(self) -> int:
        """Rows read whose every value parses."""
        return self.rows - len({row for row, _, _ in self.invalid})


@dataclass(frozen=True)
class StoreInspection:
    """What :func:`inspect_store` found in a store file.

    size: bytes. error: why nothing of it can be read (an empty file, not an SQLite database, an
    unreadable schema), else None. tables: :data:`TABLES` in order. campaign: the campaign row's plain
    columns (state, seed, version, started, ended, message) where readable. by_status: evaluations per
    status where readable.
    """

    path: Path
    size: int
    error: str | None = None
    tables: tuple[TableState, ...] = ()
    campaign: dict[str, Any] | None = None
    by_status: dict[str, int] | None = None

    @property
    def damaged(self) -> bool:
        return self.error is not None or any(t.damaged for t in self.tables)

    @property
    def damage(self) -> str:
        """What is damaged, in a few words (``the generations table is missing``)."""
        if self.error is not None:
            return self.error
        parts = []
        for t in self.tables:
            if not t.present:
                parts.append(f"the {t.name} table is missing")
            elif not t.complete:
                parts.append(f"the {t.name} table cannot be read" + (f" past its row {t.rows}" if t.rows else "")
                             + f" ({t.error})")
            for row, column, why in t.invalid[:_NAMED_ROWS]:
                what = ("the stored campaign configuration is not valid YAML" if column == "config"
                        else f"{row} has invalid JSON in its {column!r} column")
                parts.append(f"{what} ({why})")
            if len(t.invalid) > _NAMED_ROWS:
                parts.append(f"{len(t.invalid) - _NAMED_ROWS} more invalid value(s) in the {t.name} table")
        return ", ".join(parts) or "nothing (it reads whole)"

    @property
    def readable(self) -> str:
        """What can still be read (``still readable: the campaign table (1 row), ...``)."""
        if self.error is not None or not any(t.present and t.rows for t in self.tables):
            hint = (f"; `sqlite3 {self.path} .recover` may salvage rows" if self.error and "malformed" in self.error
                    else "")
            return "nothing in it can be read" + hint
        parts = []
        for t in self.tables:
            if not t.present or (not t.rows and not t.complete):
                continue
            if not t.complete:
                count = f"its first {t.rows} row{'s' * (t.rows != 1)}"
            elif t.name == "campaign" and t.invalid:
                count = "1 row, not its configuration"
            elif t.invalid:
                count = f"{t.readable_rows} of {t.rows} rows"
            else:
                count = f"{t.rows} row{'s' * (t.rows != 1)}"
            parts.append(f"the {t.name} table ({count})")
        return "still readable: " + ", ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able form (``millfoil status --json`` of a damaged store)."""
        return {"path": str(self.path), "size": self.size, "damaged": self.damaged, "damage": self.damage,
                "readable": self.readable, "error": self.error, "campaign": self.campaign,
                "by_status": self.by_status,
                "tables": {t.name: {"present": t.present, "rows": t.rows, "complete": t.complete, "error": t.error,
                                    "readable_rows": t.readable_rows,
                                    "invalid": [{"row": r, "column": c, "why": w} for r, c, w in t.invalid]}
                           for t in self.tables}}


def locate(path: str | Path) -> tuple[Path, Path]:
    """(the store's name for messages, the file to read it from) for the store at ``path``: ``path``
    itself, or where only its packed form (:mod:`optimizer.campaign.packed`) is there, that file and an
    unpacked copy of it (``path`` may also name the packed file). A packed file that does not unpack raises
    :class:`StoreDamaged`."""
    path = Path(path)
    packed = path if path.name.endswith(PACKED_SUFFIX) else packed_path(path)
    if packed != path and (path.exists() or not packed.exists()):
        return path, path
    if not packed.exists():
        return path, path
    try:
        return packed, unpacked_copy(packed)
    except (lzma.LZMAError, EOFError) as exc:
        raise StoreDamaged(StoreInspection(packed, packed.stat().st_size,
                                           f"the packed store cannot be unpacked ({_short(exc)})")) from None


def stored(path: str | Path) -> bool:
    """Whether there is a store at ``path``, as it is or packed."""
    return Path(path).exists() or packed_path(path).exists()


def inspect_store(path: str | Path, cause: str | None = None) -> StoreInspection:
    """Read a store file as far as it goes, table by table, and say what is damaged (never raises).

    Every row of every table is read and its JSON values and the campaign's configuration YAML are parsed;
    SQLite's own errors stop a table's reading where they occur. ``cause``: an error already met (what
    the inspection reports if it finds nothing else). A packed store is inspected through its unpacked
    copy and named as the packed file.
    """
    try:
        shown, source = locate(path)
    except StoreDamaged as exc:
        return exc.inspection
    if source != shown:
        return dataclasses.replace(inspect_store(source, cause), path=shown)
    path = Path(path)
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(len(_SQLITE_HEADER))
    except OSError as exc:
        return StoreInspection(path, 0, f"it cannot be read ({exc.strerror or exc})")
    if size == 0:
        return StoreInspection(path, 0, "the file is empty (0 bytes)")
    if head != _SQLITE_HEADER:
        return StoreInspection(path, size, f"the file ({size} bytes) is not an SQLite database")
    try:
        db = sqlite3.connect(_readonly_uri(path), uri=True, timeout=30.0)
    except sqlite3.Error as exc:
        return StoreInspection(path, size, f"SQLite cannot open it ({exc})")
    db.row_factory = sqlite3.Row
    try:
        try:
            names = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            return StoreInspection(path, size, _unreadable(exc))
        tables = tuple(_inspect_table(db, name) if name in names else TableState(name, False) for name in TABLES)
        campaign = by_status = None
        if "campaign" in names:
            try:
                row = db.execute("SELECT state, seed, version, started, ended, message FROM campaign WHERE id=1"
                                 ).fetchone()
                campaign = None if row is None else dict(row)
            except (sqlite3.DatabaseError, UnicodeDecodeError):
                pass
        if "evaluations" in names:
            try:
                by_status = {s: n for s, n in db.execute("SELECT status, COUNT(*) FROM evaluations GROUP BY status")}
            except (sqlite3.DatabaseError, UnicodeDecodeError):
                pass
    finally:
        db.close()
    found = StoreInspection(path, size, None, tables, campaign, by_status)
    if not found.damaged and cause is not None:
        return StoreInspection(path, size, _unreadable(cause), tables, campaign, by_status)
    return found


def _unreadable(error: object) -> str:
    """The damage of a file SQLite refuses as a whole."""
    text = _short(error)
    if "malformed" in text:
        return f"SQLite finds it malformed, as a truncated or overwritten file is ({text})"
    return f"SQLite cannot read it ({text})"


def _inspect_table(db: sqlite3.Connection, name: str) -> TableState:
    """Every row of table ``name`` read and its values parsed (see :func:`inspect_store`)."""
    rows, invalid = 0, []
    try:
        columns = {r[1] for r in db.execute(f"PRAGMA table_info({name})")}
        parsed = [c for c in JSON_COLUMNS[name] if c in columns]
        for row in db.execute(f"SELECT rowid AS store_rowid, * FROM {name} ORDER BY rowid"):
            rows += 1
            label = _row_label(name, row)
            for column in parsed:
                why = _json_problem(row[column])
                if why is not None:
                    invalid.append((label, column, why))
            if name == "campaign":
                why = _yaml_problem(row["config"])
                if why is not None:
                    invalid.append((label, "config", why))
    except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:      # text that is not UTF-8: overwritten bytes
        return TableState(name, True, rows, False, _short(exc), tuple(invalid))
    return TableState(name, True, rows, True, None, tuple(invalid))


def _row_label(table: str, row: sqlite3.Row) -> str:
    try:
        if table == "evaluations":
            return f"design {row['store_rowid']}"
        if table == "generations":
            return f"generation {int(row['generation']) + 1}"
    except (IndexError, KeyError, TypeError, ValueError):
        pass
    return "the campaign row" if table == "campaign" else f"row {row['store_rowid']}"


def _json_problem(text: Any) -> str | None:
    """Why ``text`` (a JSON column's value; None is allowed) does not parse, or None."""
    if text is None:
        return None
    try:
        json.loads(text)
    except (ValueError, TypeError) as exc:
        return _short(exc)
    return None


def _yaml_problem(text: Any) -> str | None:
    """Why ``text`` (the stored configuration) does not parse as YAML, or None."""
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or type(exc).__name__
        return f"line {mark.line + 1}: {problem}" if mark is not None else _short(problem)
    except (TypeError, ValueError) as exc:
        return _short(exc)
    del data
    return None


def _short(value: Any, limit: int = 80) -> str:
    text = " ".join(str(value).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _readonly_uri(path: Path) -> str:
    """The SQLite URI that opens ``path`` read-only (any character in the path quoted)."""
    return f"{path.absolute().as_uri()}?mode=ro"


def _transient(exc: sqlite3.DatabaseError) -> bool:
    """An SQLite error that says nothing about the file's content (a lock held too long, no permission)."""
    text = str(exc).lower()
    return isinstance(exc, sqlite3.OperationalError) and any(
        word in text for word in ("locked", "busy", "unable to open", "readonly", "read-only", "disk i/o"))


def _damage_found(db: sqlite3.Connection) -> bool:
    """A quick look for damage when a store is opened: every table present, the JSON columns valid (by
    SQLite's ``json_valid``, confirmed by Python's parser) and the configuration valid YAML. Reads
    every row once; SQLite's errors propagate."""
    names = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    if not set(TABLES) <= names:
        return True
    for table, columns in JSON_COLUMNS.items():
        have = {r[1] for r in db.execute(f"PRAGMA table_info({table})")}
        present = [c for c in columns if c in have]
        where = " OR ".join(f"NOT json_valid({c})" for c in present)
        for values in db.execute(f"SELECT {', '.join(present)} FROM {table} WHERE {where}"):
            if any(_json_problem(v) is not None for v in values):
                return True
    row = db.execute("SELECT config FROM campaign WHERE id=1").fetchone()
    return row is not None and _yaml_problem(row[0]) is not None


def _check(db: sqlite3.Connection, path: Path) -> None:
    """StoreDamaged if :func:`_damage_found` finds damage or SQLite cannot read the file (see :class:`Store`)."""
    try:
        damaged, cause = _damage_found(db), None
    except sqlite3.DatabaseError as exc:
        if _transient(exc):
            raise
        damaged, cause = True, str(exc)
    except UnicodeDecodeError as exc:          # a text value that is not UTF-8: overwritten bytes
        damaged, cause = True, f"a text value is not UTF-8 ({_short(exc)})"
    if damaged:
        inspection = inspect_store(path, cause)
        if inspection.damaged:
            raise StoreDamaged(inspection)


def _create(path: Path) -> None:
    """A new, empty store at ``path``: its tables are created in a temporary file of the same directory,
    which is then renamed onto ``path``, so that a reader (``millfoil status`` the moment a run starts)
    never finds a store file without its tables."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.name}.partial")
    partial.unlink(missing_ok=True)
    db = sqlite3.connect(partial)
    try:
        with db:
            db.executescript(_SCHEMA)
            db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
    finally:
        db.close()
    os.replace(partial, path)


class Store:
    """The SQLite store of one run (see the module docstring).

    ``Store(path)`` opens (creating the tables if needed) for writing — only the driver does that;
    ``Store(path, readonly=True)`` opens an existing store for reading, safe while the driver runs.
    ``sync``: ``full`` (default) or ``normal``, SQLite's ``synchronous`` (see ``output.sync``).

    An existing store is checked when it is opened, before anything is written to it (every table
    present, every JSON value and the configuration parse: one pass over the rows in SQLite), and its
    reads are checked as they go: damage raises :class:`StoreDamaged`, never a bare SQLite, JSON or YAML
    error, and a damaged store is never "repaired" (a dropped table created again empty) by opening it.
    """

    def __init__(self, path: str | Path, *, readonly: bool = False, sync: str = "full"):
        self.path = Path(path)
        if readonly:
            self.path, source = locate(self.path)
            if not source.exists():
                raise FileNotFoundError(f"no campaign store at {self.path}")
            self._db = sqlite3.connect(_readonly_uri(source), uri=True, timeout=30.0)
            try:
                _check(self._db, self.path)
            except BaseException:
                self._db.close()
                raise
        else:
            if not self.path.exists() and packed_path(self.path).exists():
                raise FileExistsError(f"{packed_path(self.path)} is a packed store: `millfoil unpack "
                                      f"{self.path.parent}` before writing to it")
            if self.path.exists():
                with contextlib.closing(sqlite3.connect(_readonly_uri(self.path), uri=True, timeout=30.0)) as db:
                    _check(db, self.path)
            else:
                _create(self.path)
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

    @contextlib.contextmanager
    def _reading(self) -> Iterator[None]:
        """Reads inside: SQLite's errors about the file's content, and values that do not parse, become
        :class:`StoreDamaged` (a store damaged while it is open, after the check at opening)."""
        try:
            yield
        except StoreDamaged:
            raise
        except sqlite3.DatabaseError as exc:
            if _transient(exc):
                raise
            raise StoreDamaged(inspect_store(self.path, str(exc))) from None
        except (ValueError, TypeError, KeyError) as exc:
            raise StoreDamaged(inspect_store(self.path, f"a stored value does not parse: {_short(exc)}")) from None

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
        with self._reading():
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
        with self._reading():
            row = self._db.execute("SELECT * FROM evaluations WHERE key=?", (key,)).fetchone()
            return None if row is None else _evaluation(row)

    def get_many(self, keys: Iterable[str]) -> dict[str, EvaluationRow]:
        """``{key: row}`` for those of ``keys`` that are stored."""
        keys = list(dict.fromkeys(keys))
        found: dict[str, EvaluationRow] = {}
        with self._reading():
            for i in range(0, len(keys), 500):        # SQLite's host-parameter limit
                chunk = keys[i:i + 500]
                marks = ",".join("?" * len(chunk))
                for row in self._db.execute(f"SELECT * FROM evaluations WHERE key IN ({marks})", chunk):
                    found[row["key"]] = _evaluation(row)
        return found

    def evaluations(self, generation: int | None = None) -> Iterator[EvaluationRow]:
        """Stored evaluations in the order they finished (optionally of one generation)."""
        with self._reading():
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
        with self._reading():
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

    def verify(self) -> None:
        """SQLite's full integrity check (every page, every index against its table), which the check at
        opening leaves out: raises :class:`StoreDamaged` with its first findings. Reads the whole file
        (well under a second for thousands of designs)."""
        try:
            found = [r[0] for r in self._db.execute("PRAGMA integrity_check(3)")]
        except sqlite3.DatabaseError as exc:
            if _transient(exc):
                raise
            found = [str(exc)]
        if found != ["ok"]:
            raise StoreDamaged(inspect_store(self.path, f"SQLite's integrity check: {_short('; '.join(found), 200)}"))

    def generations(self) -> list[GenerationRow]:
        with self._reading():
            return [_generation(r) for r in self._db.execute("SELECT * FROM generations ORDER BY generation")]

    def last_generation(self) -> GenerationRow | None:
        with self._reading():
            row = self._db.execute("SELECT * FROM generations ORDER BY generation DESC LIMIT 1").fetchone()
            return None if row is None else _generation(row)


def non_dominated(F: np.ndarray, chunk: int = 256) -> np.ndarray:
    """``(n,)`` mask of the rows of ``F (n, m)`` that no other row dominates (≤ in every column, < in one);
    minimisation; equal rows keep each other. Two finite columns: one sweep in sorted order (n log n; a
    plain campaign's 5 000 designs in a millisecond). Otherwise compared in chunks of rows: memory
    ``chunk × n × m``."""
    F = np.asarray(F, float)
    if F.ndim == 2 and F.shape[1] == 2 and np.isfinite(F).all():
        return _non_dominated_2d(F)
    keep = np.ones(len(F), bool)
    for i in range(0, len(F), chunk):
        a = F[i:i + chunk, None, :]
        dominated = np.all(F[None] <= a, axis=2) & np.any(F[None] < a, axis=2)
        keep[i:i + chunk] = ~dominated.any(axis=1)
    return keep


def _non_dominated_2d(F: np.ndarray) -> np.ndarray:
    """:func:`non_dominated` of two finite columns. In lexicographic order every earlier row is no worse
    in the first column, so a row is dominated exactly when some earlier row that differs from it is no
    worse in the second; equal rows are adjacent, so "earlier and different" is "before its run of
    equal rows"."""
    order = np.lexsort((F[:, 1], F[:, 0]))
    a, b = F[order, 0], F[order, 1]
    new_run = np.ones(len(F), bool)
    new_run[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1])
    run_start = np.maximum.accumulate(np.where(new_run, np.arange(len(F)), 0))
    best_before = np.concatenate([[np.inf], np.minimum.accumulate(b)])[run_start]
    keep = np.empty(len(F), bool)
    keep[order] = b < best_before
    return keep


def _evaluation(r: sqlite3.Row) -> EvaluationRow:
    row = EvaluationRow(
        key=r["key"], generation=r["generation"], x=loads(r["x"]), parameters=loads(r["parameters"]),
        status=r["status"], reason=r["reason"], convergence=r["class"], objectives=loads(r["objectives"]),
        minimised=loads(r["minimised"]), constraints=loads(r["constraints"]), figures=loads(r["figures"]),
        monitors=loads(r["monitors"]), cells=r["cells"], iterations=r["iterations"], seconds=loads(r["seconds"]),
        wall_seconds=r["wall_seconds"], worker=r["worker"], submitted=r["submitted"], finished=r["finished"])
    where = f"the evaluation {str(r['key'])[:10]}"
    _shape(where, "key", row.key, str)
    _shape(where, "generation", row.generation, int)
    _shape(where, "x", row.x, list, item=_NUMBER)
    _shape(where, "minimised", row.minimised, list, item=_NUMBER)
    _shape(where, "parameters", row.parameters, dict, item=_NUMBER)
    _shape(where, "constraints", row.constraints, dict, item=_NUMBER)
    for column in ("objectives", "figures", "monitors", "seconds"):
        _shape(where, column, getattr(row, column), dict, nullable=True)
    return row


def _generation(r: sqlite3.Row) -> GenerationRow:
    row = GenerationRow(
        generation=r["generation"], members=loads(r["members"]), rank=loads(r["rank"]),
        crowding=loads(r["crowding"]), offspring=loads(r["offspring"]), feasible_offspring=r["feasible_offspring"],
        feasible_share=r["feasible_share"], cache_hits=r["cache_hits"], hypervolume=r["hypervolume"],
        rng_state=json.loads(r["rng_state"]), finished=r["finished"],
        search=loads(r["search"]) if "search" in r.keys() else None)
    where = f"generation {r['generation']}"
    _shape(where, "generation", row.generation, int)
    _shape(where, "members", row.members, list, item=str)
    _shape(where, "offspring", row.offspring, list, item=str)
    _shape(where, "rank", row.rank, list)
    _shape(where, "crowding", row.crowding, list)
    _shape(where, "rng_state", row.rng_state, dict)
    _shape(where, "search", row.search, dict, nullable=True)
    if not len(row.members) == len(row.rank) == len(row.crowding):
        raise ValueError(f"{where}: {len(row.members)} members but {len(row.rank)} ranks and {len(row.crowding)} "
                         "crowding distances")
    return row


def check_values(path: str | Path, rows: Iterable[EvaluationRow], labels: Sequence[str]) -> None:
    """StoreDamaged unless every evaluation with values (status ``ok``) has a number for each objective
    ``labels`` (the stored campaign's) and one minimised value per objective: what the driver, ``status``
    and ``report`` read from every such row."""
    for row in rows:
        if not row.ok:
            continue
        objectives = row.objectives or {}
        missing = [label for label in labels if not isinstance(objectives.get(label), _NUMBER)]
        if missing or len(row.minimised) != len(labels):
            what = (f"no value of {', '.join(map(repr, missing))}" if missing
                    else f"{len(row.minimised)} minimised values for {len(labels)} objectives")
            raise StoreDamaged(inspect_store(path, f"the evaluation {row.key[:10]} (ok) has {what}"))


#: A stored number: JSON's int or float (infinities are stored as strings and read back as floats).
_NUMBER = (int, float)


def _shape(where: str, column: str, value: Any, kind: type, *, item: Any = None, nullable: bool = False) -> None:
    """ValueError naming the row and column unless ``value`` is a ``kind`` (a list or dict of ``item``
    values where given; None where ``nullable``): valid JSON of the wrong shape is damage too."""
    if value is None and nullable:
        return
    good = isinstance(value, kind) and not isinstance(value, bool)
    if good and item is not None:
        values = value.values() if isinstance(value, dict) else value
        good = all(isinstance(v, item) and not isinstance(v, bool) for v in values)
        good = good and (not isinstance(value, dict) or all(isinstance(k, str) for k in value))
    if not good:
        raise ValueError(f"{where} has a {type(value).__name__} in its {column!r} column, where a "
                         f"{kind.__name__}{' of ' + _name(item) if item is not None else ''} belongs")


def _name(item: Any) -> str:
    return "numbers" if item is _NUMBER else f"{item.__name__}s"
