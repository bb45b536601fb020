"""Packed stores: a campaign's store compressed into one file, for archives and repositories.

``millfoil pack RUN`` writes the store's content (its write-ahead log folded in) to ``campaign.sqlite.xz``
(LZMA, about a fifth of the size: a store is mostly JSON text) and removes ``campaign.sqlite``;
``millfoil unpack RUN`` does the reverse. Every reading command (``status``, ``report``, ``export``)
reads a packed store as it is, through an unpacked copy in the temporary directory made once per process
and removed when the process ends; ``millfoil resume`` unpacks it in place first, since a campaign
continues in its store. Both take the run directory's driver lock, so a running campaign is never packed
under its driver.

Both write the new file beside the old one and rename it onto its name only once it has been read back
and found equal, so an interruption leaves the run directory as it was.
"""

from __future__ import annotations

import atexit
import contextlib
import lzma
import os
import shutil
import sqlite3
import tempfile
from dataclasses import dataclass
from pathlib import Path

from optimizer.campaign.lock import DriverLock

#: Suffix of a packed store: ``campaign.sqlite`` becomes ``campaign.sqlite.xz``.
PACKED_SUFFIX = ".xz"

_copies: dict[tuple[str, int, int], Path] = {}
_scratch: Path | None = None


class PackError(RuntimeError):
    """A run directory that cannot be packed or unpacked as asked (its message says why)."""


@dataclass(frozen=True)
class Packing:
    """What :func:`pack` or :func:`unpack` did: the file written and the sizes (bytes) before and after."""

    written: Path
    before: int
    after: int


def packed_path(store: str | Path) -> Path:
    """``campaign.sqlite.xz`` beside ``store``."""
    store = Path(store)
    return store.with_name(store.name + PACKED_SUFFIX)


def unpacked_copy(packed: str | Path) -> Path:
    """A read-only SQLite file with the content of ``packed``, in this process's temporary directory (made
    once per packed file and content, removed when the process ends). Raises ``lzma.LZMAError`` or
    ``EOFError`` if the file is not a whole LZMA stream."""
    global _scratch
    packed = Path(packed)
    stat = packed.stat()
    key = (str(packed.resolve()), stat.st_mtime_ns, stat.st_size)
    if key in _copies and _copies[key].exists():
        return _copies[key]
    if _scratch is None:
        _scratch = Path(tempfile.mkdtemp(prefix="millfoil-unpacked-"))
        atexit.register(shutil.rmtree, _scratch, True)
    copy = _scratch / f"{len(_copies)}-{packed.name.removesuffix(PACKED_SUFFIX)}"
    with lzma.open(packed, "rb") as source, open(copy, "wb") as target:
        shutil.copyfileobj(source, target, 1 << 20)
    copy.chmod(0o444)
    _copies[key] = copy
    return copy


def pack(store: str | Path) -> Packing:
    """Pack the store at ``store`` (``RUN/campaign.sqlite``) into ``RUN/campaign.sqlite.xz`` and remove it.

    Holds the run directory's driver lock (:class:`~optimizer.campaign.lock.DirectoryInUse` while a driver
    runs there). The write-ahead log is folded into the file first, so the packed store is whole."""
    store = Path(store)
    target = packed_path(store)
    with DriverLock(store.parent, "pack"):
        if not store.exists():
            what = f"it is packed already ({target.name})" if target.exists() else "there is no campaign store"
            raise PackError(f"{store.parent}: nothing to pack: {what}")
        with contextlib.closing(sqlite3.connect(store, timeout=30.0)) as db:   # fold the WAL in; readers go on
            db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        partial = target.with_name(f".{target.name}.partial")
        with open(store, "rb") as source, lzma.open(partial, "wb", preset=9 | lzma.PRESET_EXTREME) as packed:
            shutil.copyfileobj(source, packed, 1 << 20)
        _same_or_fail(partial, store)
        os.replace(partial, target)
        before = store.stat().st_size
        for name in (store.name, f"{store.name}-wal", f"{store.name}-shm"):
            (store.parent / name).unlink(missing_ok=True)
        return Packing(target, before, target.stat().st_size)


def unpack(store: str | Path, *, locked: bool = False) -> Packing:
    """Unpack ``RUN/campaign.sqlite.xz`` into ``store`` (``RUN/campaign.sqlite``) and remove the packed file.
    Holds the run directory's driver lock, like :func:`pack` (``locked``: the caller holds it already)."""
    store = Path(store)
    source = packed_path(store)
    with contextlib.nullcontext() if locked else DriverLock(store.parent, "unpack"):
        if store.exists():
            raise PackError(f"{store.parent}: {store.name} is there already"
                            + (f"; {source.name} is an older copy: remove it or pack again" if source.exists() else ""))
        if not source.exists():
            raise PackError(f"{store.parent}: nothing to unpack: no {source.name}")
        partial = store.with_name(f".{store.name}.partial")
        try:
            with lzma.open(source, "rb") as packed, open(partial, "wb") as target:
                shutil.copyfileobj(packed, target, 1 << 20)
        except (lzma.LZMAError, EOFError) as exc:
            partial.unlink(missing_ok=True)
            raise PackError(f"{source}: the packed store cannot be unpacked ({exc})") from None
        os.replace(partial, store)
        before = source.stat().st_size
        source.unlink()
        return Packing(store, before, store.stat().st_size)


def _same_or_fail(packed: Path, original: Path) -> None:
    """Read ``packed`` back and compare it with ``original`` byte for byte (PackError and the partial file
    removed if they differ: a disk that lost a write)."""
    with lzma.open(packed, "rb") as a, open(original, "rb") as b:
        while True:
            x, y = a.read(1 << 20), b.read(1 << 20)
            if x != y:
                packed.unlink(missing_ok=True)
                raise PackError(f"{original}: the packed copy does not read back equal; nothing was changed")
            if not x:
                return
