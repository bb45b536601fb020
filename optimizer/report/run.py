"""A campaign run as the report and the NC export read it: the store, read-only, and nothing else.

Works on a campaign that is still running (SQLite WAL: readers never block the driver) and shows what is
finished. Each stored design gets a **design number**: the order in which the store received it (the
SQLite ``rowid`` of its ``evaluations`` row, 1, 2, …), which never changes once the design is stored;
``millfoil export RUN --id N`` and the report use it.

A damaged store raises :class:`~optimizer.campaign.store.StoreDamaged` (a bad input, exit status 2, its
message saying what is damaged and what can still be read) before anything is written.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import yaml

from optimizer.campaign.store import (
    STORE_NAME,
    CampaignRow,
    EvaluationRow,
    GenerationRow,
    Store,
    StoreDamaged,
    inspect_store,
    locate,
    stored,
)


class RunError(ValueError):
    """A run directory without a campaign store or whose store SQLite cannot open (a lock held too long, no
    permission), or a design it does not hold. A damaged store is :class:`StoreDamaged`."""


@dataclass(frozen=True)
class Design:
    """One stored evaluation with its design number (see the module docstring)."""

    number: int
    row: EvaluationRow

    @property
    def key(self) -> str:
        return self.row.key


@dataclass(frozen=True)
class Run:
    """Everything a report needs from one run directory (read once; a snapshot of a running campaign).

    directory: the run directory. campaign: the ``campaign`` row. config: the resolved campaign as a mapping
    (the stored YAML). designs: every stored evaluation in store order. generations: the finished
    generations. label: the name a report gives it where directory names alone collide (:func:`named_apart`).
    """

    directory: Path
    campaign: CampaignRow
    config: dict[str, Any]
    designs: tuple[Design, ...]
    generations: tuple[GenerationRow, ...] = field(default=())
    label: str = ""

    @property
    def name(self) -> str:
        return self.label or self.directory.resolve().name

    @property
    def analytic(self) -> bool:
        return bool(self.config.get("analytic"))

    @property
    def mode(self) -> str:
        return str((self.config.get("blade") or {}).get("mode", "design"))

    @property
    def continuity(self) -> str:
        return str((self.config.get("blade") or {}).get("continuity", "C2"))

    @property
    def objectives(self) -> list[dict[str, Any]]:
        return list(self.config.get("objectives") or [])

    @property
    def labels(self) -> list[str]:
        """Objective labels as the store keys them (``|fy|``, ``c_max``)."""
        return [("|" + o["figure"] + "|") if o.get("abs") else o["figure"] for o in self.objectives]

    @cached_property
    def by_key(self) -> dict[str, Design]:
        return {d.key: d for d in self.designs}

    def design(self, ident: str | int) -> Design:
        """A design by number (``12``: fewer than 6 digits) or by key or unique key prefix (at least 6
        hexadecimal characters)."""
        text = str(ident).strip()
        if text.isdigit() and len(text) < 6:
            for d in self.designs:
                if d.number == int(text):
                    return d
            last = self.designs[-1].number if self.designs else 0
            raise RunError(f"{self.directory}: no design number {text} (the store holds {len(self.designs)} "
                           f"designs, numbered 1 to {last})")
        if len(text) < 6:
            raise RunError(f"--id {text!r}: give a design number or at least 6 characters of a design key")
        found = [d for d in self.designs if d.key.startswith(text.lower())]
        if len(found) != 1:
            raise RunError(f"{self.directory}: {'no' if not found else str(len(found))} design key(s) start "
                           f"with {text!r}")
        return found[0]


def named_apart(runs: list[Run]) -> list[Run]:
    """``runs`` with names a reader can tell apart: a run whose directory name another run shares is named by
    the shortest tail of its path that no other run ends in (``coarse/design_g1`` beside
    ``medium/design_g1``), and the runs beside it in the same directory by a tail as long (``medium/toolpath_g1``),
    so that the runs of one study level read alike; the others keep their directory name."""
    parts = [r.directory.resolve().parts for r in runs]
    depths = []
    for mine in parts:
        others = [p for p in parts if p is not mine]
        depth = 1
        while depth < len(mine) and any(p[-depth:] == mine[-depth:] for p in others):
            depth += 1
        depths.append(depth)
    by_parent: dict[tuple[str, ...], int] = {}
    for mine, depth in zip(parts, depths, strict=True):
        by_parent[mine[:-1]] = max(by_parent.get(mine[:-1], 1), depth)
    out = []
    for r, mine in zip(runs, parts, strict=True):
        depth = min(by_parent[mine[:-1]], len(mine))
        out.append(replace(r, label="/".join(mine[-depth:])) if depth > 1 else r)
    return out


def run_directories(paths: list[Path]) -> list[Path]:
    """The run directories that ``paths`` name: a path holding a campaign store is a run; a path without one
    stands for every subdirectory of it that holds one (a study such as ``runs/examples/paper``, its levels
    one further down), in name order. Raises :class:`RunError` for a path that holds neither."""
    found: list[Path] = []
    for path in paths:
        if stored(path / STORE_NAME):
            found.append(path)
            continue
        inner = (_runs_in(path, "*") or _runs_in(path, "*/*")) if path.is_dir() else []
        if not inner:
            raise RunError(f"{path}: no campaign store ({STORE_NAME}) here or in its subdirectories; give a run "
                           "directory of `millfoil run`")
        found += inner
    return found


def _runs_in(path: Path, pattern: str) -> list[Path]:
    return sorted(d for d in path.glob(pattern) if d.is_dir() and stored(d / STORE_NAME))


def load_run(directory: str | Path) -> Run:
    """Read a run directory's store (read-only). Raises :class:`RunError` if there is none or it cannot be
    opened, :class:`StoreDamaged` if it is damaged."""
    directory = Path(directory)
    path = directory / STORE_NAME
    if not stored(path):
        raise RunError(f"{directory}: no campaign store ({STORE_NAME}); give a run directory of `millfoil run`")
    try:
        with Store(path, readonly=True) as store:
            campaign = store.campaign()
            rows = list(store.evaluations())
            generations = tuple(store.generations())
        numbers = _design_numbers(path)
    except sqlite3.Error as exc:
        inspection = inspect_store(path)
        if inspection.damaged:      # damaged between the store's check and the read of its design numbers
            raise StoreDamaged(inspection) from None
        raise RunError(f"{path}: cannot read the campaign store: {exc}") from None
    if campaign is None:
        raise RunError(f"{path}: the store holds no campaign yet")
    config = yaml.safe_load(campaign.config) or {}
    if not isinstance(config, dict):
        raise RunError(f"{path} is damaged: the stored campaign configuration is a YAML "
                       f"{type(config).__name__}, not a mapping of sections")
    designs = tuple(sorted((Design(numbers.get(r.key, 0), r) for r in rows), key=lambda d: d.number))
    return Run(directory, campaign, config, designs, generations)


def _design_numbers(path: Path) -> dict[str, int]:
    """``{key: rowid}`` of the ``evaluations`` table (the store's API does not expose the rowid)."""
    db = sqlite3.connect(f"file:{locate(path)[1]}?mode=ro", uri=True, timeout=30.0)
    try:
        return {key: rowid for rowid, key in db.execute("SELECT rowid, key FROM evaluations")}
    finally:
        db.close()
