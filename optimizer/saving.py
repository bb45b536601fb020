"""Writing results: output locations checked before any work, files written whole or not at all.

A folder of one evaluation holds what exists of ``mesh.msh`` (gmsh 2.2), ``fields.vtu`` (cell fields),
``wall.csv`` (:meth:`~optimizer.evaluation.WallDistribution.to_csv`), ``result.json``
(:meth:`~optimizer.evaluation.Evaluation.to_json`, strict JSON) and the resolved ``config.yaml``
(:meth:`~optimizer.config.Config.to_yaml`; ``millfoil evaluate config.yaml`` runs it again).

Every output of a command goes through :class:`Outputs`: each file is written under a temporary name in
its own directory and renamed onto its name (:func:`os.replace`, atomic on one file system) only when all
of them are written, so a failure part-way — a plot that cannot be drawn after the CSV, a full disk —
leaves no file, half-written or not; :func:`write_atomic` does the same for one file.
:func:`check_output_file` and :func:`check_output_directory` refuse a location that cannot be written
before the first stage runs (:class:`OutputError`, exit status 2).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from optimizer.config import Config, ConfigError
from optimizer.evaluation import Evaluation

#: The files of a saved evaluation, in the order they are written.
FILES = ("config.yaml", "mesh.msh", "fields.vtu", "wall.csv", "result.json")
#: Suffixes a figure may have (formats matplotlib writes without extra packages).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps")
#: Suffixes a mesh file may have (meshio formats that hold a mixed quad/triangle 2D mesh).
MESH_SUFFIXES = (".msh", ".vtu", ".vtk", ".su2", ".inp")


class OutputError(ConfigError):
    """An output location that cannot be written (a bad input: exit status 2); the message names the option."""


class WriteFailure(RuntimeError):
    """Writing an output failed after its location was checked (a full disk, a figure that cannot be drawn);
    nothing was left behind (exit status 4)."""


def write_all(files: Iterable[tuple[str | Path, Callable[[Path], object]]], jobs: int = 1) -> list[Path]:
    """Write every ``(path, write)`` of ``files`` through one :class:`Outputs`: all of them, or none and
    WriteFailure naming the file and the reason. ``jobs`` > 1 runs the writers in that many forked
    processes (:meth:`Outputs.stage_all`; each writer must only write its file). Returns the paths written."""
    path = None
    try:
        with Outputs() as outputs:
            if jobs > 1:
                outputs.stage_all(list(files), jobs)
            else:
                for path, write in files:
                    outputs.stage(path, write)
            return outputs.commit()
    except _WriterFailed as exc:
        raise WriteFailure(f"cannot write {exc.path}: {exc.reason}; no file was written") from None
    except Exception as exc:     # any writer's error: the files are discarded, the user gets one line
        raise WriteFailure(f"cannot write {path}: {type(exc).__name__}: {exc}; no file was written") from exc


def write_atomic(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Write one file whole or not at all: ``write(temporary path)`` beside ``path`` (same suffix), then
    renamed onto ``path`` (:class:`Outputs`; the directory is created). A writer's exception propagates
    and leaves nothing behind. Returns ``path``."""
    with Outputs() as outputs:
        outputs.stage(path, write)
        return outputs.commit()[0]


def check_output_file(path: str | Path, option: str, suffixes: Iterable[str]) -> Path:
    """``path`` if a file can be written there: a known suffix, not a directory or a device, in an
    existing directory where a file can be created (tried, not guessed from permissions); else OutputError."""
    path, suffixes = Path(path), tuple(suffixes)
    if path.is_dir():
        raise OutputError(f"{option} {path} is a directory; give a file name ending in {' or '.join(suffixes)}")
    if path.suffix.lower() not in suffixes:
        raise OutputError(f"{option} {path}: unknown file type {path.suffix or '(no suffix)'!s}; allowed: "
                          f"{', '.join(suffixes)}")
    if path.exists() and not path.is_file():
        raise OutputError(f"{option} {path} exists and is not a regular file")
    _check_writable_directory(path.parent, option, path)
    return path


def check_output_directory(path: str | Path, option: str, files: Iterable[str] = FILES) -> Path:
    """``path`` if the ``files`` can be written into it: an existing directory, or one that can be created
    below its nearest existing ancestor; else OutputError. Nothing is created here."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise OutputError(f"{option} {path} exists and is not a directory")
        for name in files:
            if (path / name).is_dir():
                raise OutputError(f"{option} {path}: {path / name} is a directory; nothing was written")
            if (path / name).exists() and not (path / name).is_file():
                raise OutputError(f"{option} {path}: {path / name} exists and is not a regular file")
        _check_writable_directory(path, option, path)
        return path
    ancestor = next(p for p in path.absolute().parents if p.exists())
    if not ancestor.is_dir():
        raise OutputError(f"{option} {path}: {ancestor} is not a directory")
    _check_writable_directory(ancestor, option, path)
    return path


def _check_writable_directory(directory: Path, option: str, target: Path) -> None:
    """OutputError unless ``directory`` exists and a file can be created in it (tried with a probe file)."""
    directory = directory if str(directory) else Path(".")
    if not directory.is_dir():
        raise OutputError(f"{option} {target}: directory {directory} does not exist")
    try:
        fd, probe = tempfile.mkstemp(dir=directory, prefix=".millfoil-probe-")
    except OSError as exc:
        raise OutputError(f"{option} {target}: cannot create a file in {directory} "
                          f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


class _WriterFailed(Exception):
    """A writer of :meth:`Outputs.stage_all` raised: ``path`` its file, ``reason`` ``"Type: message"``."""

    def __init__(self, path: Path, reason: str):
        super().__init__(f"{path}: {reason}")
        self.path, self.reason = path, reason


#: The writers of the :meth:`Outputs.stage_all` call under way, for its forked processes to find by index.
_PENDING: list[tuple[Path, Callable[[Path], object]]] = []


def _write(temporary: Path, write: Callable[[Path], object]) -> str | None:
    """Run one writer: None, or ``"Type: message"`` of what it raised."""
    try:
        write(temporary)
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def _write_pending(i: int) -> str | None:
    return _write(*_PENDING[i])


def can_fork_safely() -> bool:
    """Whether this process may fork workers that run Python: the ``fork`` start method exists and no other
    Python thread is running (a thread pool, a dask client's event loop) whose locks the child would inherit."""
    import multiprocessing
    import threading

    return "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1


class Outputs:
    """Files written together: :meth:`stage` writes each under a temporary name beside it, :meth:`commit`
    renames them all onto their names; leaving the ``with`` block by an exception removes every staged file
    (and a directory :meth:`stage` created, if left empty)."""

    def __init__(self) -> None:
        self._staged: list[tuple[Path, Path]] = []
        self._created: list[Path] = []

    def stage(self, path: str | Path, write: Callable[[Path], object]) -> Path:
        """Call ``write(temporary path)``; the temporary name keeps ``path``'s suffix (writers choose the
        format by it). Returns ``path``."""
        path = Path(path)
        temporary = self._temporary(path)
        write(temporary)
        os.chmod(temporary, 0o666 & ~_umask())   # mkstemp makes it private; the file gets the usual mode
        return path

    def _temporary(self, path: Path) -> Path:
        """A new empty file beside ``path`` with its suffix, staged to be renamed onto it."""
        self._make_directory(path.parent)
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".partial{path.suffix}")
        os.close(fd)
        temporary = Path(name)
        self._staged.append((temporary, path))
        return temporary

    def stage_all(self, files: list[tuple[str | Path, Callable[[Path], object]]], jobs: int) -> list[Path]:
        """:meth:`stage` every ``(path, write)`` of ``files``, the writers run in up to ``jobs`` forked
        processes, in the order given as workers come free (a report's figures: matplotlib draws on one core).
        The temporary files are made here first, so :meth:`commit` renames in the order given. A fork inherits
        the writers as they are, nothing is pickled. The writers run here, one after the other, where processes
        cannot be forked safely: no ``fork`` start method, or other threads running in this process (a fork
        copies the locks they hold, held, and its writer could wait on them for ever). A worker that dies
        raises instead of leaving the rest waiting. The first writer that raises, in the order given, raises
        :class:`_WriterFailed`."""
        global _PENDING
        pending = []
        for path, write in files:
            try:
                pending.append((self._temporary(Path(path)), write))
            except OSError as exc:
                raise _WriterFailed(Path(path), f"{type(exc).__name__}: {exc}") from exc
        if jobs < 2 or len(pending) < 2 or not can_fork_safely():
            reasons = [_write(temporary, write) for temporary, write in pending]
        else:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor
            from concurrent.futures.process import BrokenProcessPool

            _PENDING = pending
            try:
                with ProcessPoolExecutor(min(jobs, len(pending)), mp_context=multiprocessing.get_context("fork")) \
                        as pool:
                    reasons = list(pool.map(_write_pending, range(len(pending))))
            except BrokenProcessPool:
                raise _WriterFailed(Path(files[0][0]).parent, "a writer process ended abruptly (killed, or out "
                                    "of memory)") from None
            finally:
                _PENDING = []
        for (temporary, _), (path, _), reason in zip(pending, files, reasons, strict=True):
            if reason is not None:
                raise _WriterFailed(Path(path), reason)
            os.chmod(temporary, 0o666 & ~_umask())
        return [Path(path) for path, _ in files]

    def commit(self) -> list[Path]:
        """Rename every staged file onto its name; returns the names."""
        for temporary, path in self._staged:
            os.replace(temporary, path)
        written = [path for _, path in self._staged]
        self._staged, self._created = [], []
        return written

    def discard(self) -> None:
        """Remove every staged file and the directories made for them that are left empty."""
        for temporary, _ in self._staged:
            temporary.unlink(missing_ok=True)
        for directory in reversed(self._created):
            try:
                directory.rmdir()
            except OSError:
                pass
        self._staged, self._created = [], []

    def _make_directory(self, directory: Path) -> None:
        missing = [p for p in (directory, *directory.parents) if not p.exists()]
        directory.mkdir(parents=True, exist_ok=True)
        self._created += reversed(missing)

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            self.discard()


def save(evaluation: Evaluation, config: Config, directory: str | Path) -> list[Path]:
    """Write what exists of :data:`FILES` for ``evaluation`` of ``config`` into ``directory`` (created),
    all or none of them (:func:`write_all`: WriteFailure); returns the paths written."""
    out = Path(directory)
    built = evaluation.artifacts
    writers = {
        "config.yaml": lambda path: path.write_text(config.to_yaml()),
        "mesh.msh": None if built.mesh is None else built.mesh.write,
        "fields.vtu": None if built.flow is None else built.flow.write_vtu,
        "wall.csv": None if evaluation.wall is None else evaluation.wall.to_csv,
        "result.json": lambda path: path.write_text(evaluation.to_json(indent=2)),
    }
    return write_all((out / name, writers[name]) for name in FILES if writers[name] is not None)
