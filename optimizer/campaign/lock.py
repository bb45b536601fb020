"""One driver per run directory: an operating-system lock that dies with its process.

``millfoil run`` and ``millfoil resume`` hold an exclusive POSIX record lock (``fcntl.lockf``) on
``RUN/driver.lock`` for as long as they drive the campaign. A second driver on the same directory — a
resubmitted cluster job whose predecessor still runs, two shells — is refused before it reads or writes
anything, with the holder's host, process id and start time, which the holder writes into the file. The
kernel releases the lock when its process ends, however it ends (``kill -9``, a node's out-of-memory
killer, a job's wall time), so a dead driver never blocks ``millfoil resume``; the file itself stays and
is rewritten by the next holder. The same lock tells ``millfoil status`` whether a campaign whose store
says "running" still has its driver (:func:`probe`): a driver killed outright cannot record that it
stopped.

POSIX locks (not ``flock``) because NFS carries them between nodes (through its lock manager) and a
forked child does not inherit them: a worker process that outlives its driver holds nothing. On a file
system that supports no locks at all, the driver says so and runs unguarded.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import time
from datetime import UTC, datetime
from pathlib import Path

#: The lock file in a run directory.
LOCK_NAME = "driver.lock"

#: How long a driver tries again before it refuses a held directory: :func:`probe` holds the lock for an
#: instant, and a driver starting in that instant must not take the reader for a second driver.
PROBE_PATIENCE = 0.5

#: The lock files this process holds (resolved paths), which :func:`probe` must not touch.
_HELD_HERE: set[Path] = set()


class DirectoryInUse(RuntimeError):
    """Another live driver holds the run directory."""


class DriverLock:
    """The lock of one run directory (a context manager; :meth:`acquire` / :meth:`release`).

    directory: the run directory (created if missing); command: what the holder is doing (``run``,
    ``resume``), written into the file for the refusal message; warn: called with one line when the
    file system refuses locks altogether.
    """

    def __init__(self, directory: str | Path, command: str, warn=None):
        self.directory = Path(directory)
        self.path = self.directory / LOCK_NAME
        self.command = command
        self.warn = warn or (lambda _line: None)
        self._file = None

    def acquire(self) -> DriverLock:
        self.directory.mkdir(parents=True, exist_ok=True)
        handle = open(self.path, "a+", encoding="utf-8")      # noqa: SIM115 (held until release)
        try:
            _lock_patiently(handle)
        except OSError as exc:
            if exc.errno in (errno.EACCES, errno.EAGAIN):
                holder = _holder(handle)
                handle.close()
                raise DirectoryInUse(f"{self.directory} is in use by another millfoil driver ({holder}): one "
                                     "driver per run directory; wait for it to end, or stop it, then "
                                     f"`millfoil resume {self.directory}`") from None
            if exc.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                self.warn(f"the file system of {self.directory} supports no file locks: nothing stops a second "
                          "driver on this run directory")
            else:
                handle.close()
                raise
        handle.seek(0)
        handle.truncate()
        handle.write(json.dumps({"host": socket.gethostname(), "pid": os.getpid(), "command": self.command,
                                 "since": datetime.now(UTC).isoformat(timespec="seconds")}) + "\n")
        handle.flush()
        self._file = handle
        _HELD_HERE.add(self.path.resolve())
        return self

    def release(self) -> None:
        if self._file is not None:
            self._file.close()            # closing the descriptor releases the POSIX lock
            self._file = None
            _HELD_HERE.discard(self.path.resolve())

    def __enter__(self) -> DriverLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def _lock_patiently(handle) -> None:
    """The exclusive lock on ``handle``, tried again for :data:`PROBE_PATIENCE` seconds while it is held."""
    deadline = time.monotonic() + PROBE_PATIENCE
    while True:
        try:
            fcntl.lockf(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except OSError as exc:
            if exc.errno not in (errno.EACCES, errno.EAGAIN) or time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def probe(directory: str | Path) -> tuple[bool | None, str]:
    """Whether a live driver holds ``directory`` now: ``(True, holder)`` with the holder's line as a refusal
    names it, ``(False, "")`` when none does (the last one ended or was killed), ``(None, why)`` when the
    lock cannot tell (no lock file: a run copied without it, or a store from elsewhere; a file system
    without locks).

    The probe takes a shared lock for an instant and lets it go. It never opens the lock file of its own
    process's driver: POSIX locks belong to the process, and closing any descriptor of the file would
    release that driver's lock.
    """
    path = Path(directory) / LOCK_NAME
    if path.resolve() in _HELD_HERE:
        return True, f"this process, pid {os.getpid()}"
    try:
        handle = open(path, encoding="utf-8")              # noqa: SIM115 (closed below)
    except OSError:
        return None, f"no readable {LOCK_NAME}"
    with handle:
        try:
            fcntl.lockf(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EACCES, errno.EAGAIN):
                return True, _holder(handle)
            return None, f"the file system refuses locks ({os.strerror(exc.errno)})"
        fcntl.lockf(handle, fcntl.LOCK_UN)
        return False, ""


def _holder(handle, patience: float = 1.0) -> str:
    """``millfoil run, pid 123 on node7 since 2026-…`` from the lock file (what its holder wrote).

    The holder writes the file just after it takes the lock, so a driver refused in that instant finds it
    empty or half written: read again for up to ``patience`` seconds before calling the holder unknown.
    """
    deadline = time.monotonic() + patience
    while True:
        handle.seek(0)
        try:
            info = json.loads(handle.read() or "{}")
            return f"millfoil {info['command']}, pid {info['pid']} on {info['host']} since {info['since']}"
        except (ValueError, KeyError, TypeError):
            if time.monotonic() > deadline:
                return "holder unknown"
            time.sleep(0.02)
