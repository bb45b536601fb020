"""YAML read with the line of every key, so that a configuration error can say where it is.

:func:`read_yaml` returns the plain data (as :func:`yaml.safe_load` would) together with a
:class:`Source`: the file name and the 1-based line of every mapping key and sequence item, addressed by
its path (``("objectives", 0, "sense")``). :meth:`Source.where` turns the location of a validation error
(pydantic's ``loc``, or any path into the data) into ``FILE:LINE``; a path that does not exist in the file
(a default, or a key added by an override) falls back to its nearest ancestor that does.

What a document may be is bounded before any of it is built (each limit is documented in
``docs/reference/errors.md``): the file at most :data:`MAX_FILE_BYTES` of UTF-8 text, at most :data:`MAX_VALUES`
values once YAML aliases are expanded (an alias bomb is refused, not built), nesting at most
:data:`MAX_DEPTH` deep, no alias that contains itself, numbers of at most :data:`MAX_NUMBER_CHARS`
characters, and no key twice in one mapping (the last one would silently win).

Used by every configuration loader (:func:`optimizer.config.load_config` and the campaign schema) and by
``--set`` overrides, so that all configuration errors look the same.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

Path_ = tuple[Any, ...]

#: Largest configuration file read, bytes (the shipped ones are below 4 KiB).
MAX_FILE_BYTES = 1 << 20
#: Most values (mapping keys, values and sequence items, counted after alias expansion) in one document.
MAX_VALUES = 10_000
#: Deepest nesting of mappings and sequences in one document (configurations are at most 4 deep).
MAX_DEPTH = 32
#: Longest number, in characters (a float has 17 significant digits; 5000 digits is a mistake).
MAX_NUMBER_CHARS = 100

_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
_MERGE_TAG = "tag:yaml.org,2002:merge"


class YamlSourceError(ValueError):
    """A file that cannot be read, is not valid YAML or is beyond a limit; the message names file and line."""


@dataclass(frozen=True)
class Source:
    """Where the values of one YAML document came from.

    name: the file name as given (``"<defaults>"`` for no file). lines: ``{path: line}``, 1-based, for
    every mapping key (the line of the key) and sequence item (the line of the item). overridden:
    ``{path: "--set KEY=VALUE"}`` for the values a command line set over the file's (:meth:`with_overrides`).
    """

    name: str
    lines: dict[Path_, int] = field(default_factory=dict)
    overridden: dict[Path_, str] = field(default_factory=dict)

    def with_overrides(self, given: Mapping[Path_, str]) -> Source:
        """This source with the values at the paths of ``given`` located at its ``--set`` items instead."""
        return replace(self, overridden={**self.overridden, **{_normalise(p): s for p, s in given.items()}})

    def line(self, path: Sequence[Any]) -> int | None:
        """Line of ``path`` or of its nearest ancestor present in the file; None if none is."""
        path = tuple(path)
        for n in range(len(path), 0, -1):
            line = self.lines.get(_normalise(path[:n]))
            if line is not None:
                return line
        return None

    def gives(self, path: Sequence[Any]) -> bool:
        """Whether the file or a ``--set`` gave the value at ``path`` itself (not an embedded default)."""
        path = _normalise(tuple(path))
        return path in self.lines or any(path[:n] in self.overridden for n in range(1, len(path) + 1))

    def where(self, path: Sequence[Any] = ()) -> str:
        """``FILE:LINE`` of ``path`` (see :meth:`line`), or just ``FILE`` when no line is known; ``--set
        KEY=VALUE`` when the command line set ``path`` or a section holding it. For a section in which the
        command line set keys (an error of the section as a whole, such as two of its keys that disagree):
        those ``--set`` items, followed by ``(with FILE:LINE)`` where the file gives the section too."""
        path = _normalise(tuple(path))
        for n in range(len(path), 0, -1):
            if path[:n] in self.overridden:
                return self.overridden[path[:n]]
        below = [item for p, item in self.overridden.items() if path and len(p) > len(path) and p[:len(path)] == path]
        line = self.line(path)
        file = self.name if line is None else f"{self.name}:{line}"
        if below:
            given = ", ".join(below)
            return f"{given} (with {file})" if path in self.lines else given
        return file


def _normalise(path: Path_) -> Path_:
    # pydantic reports list indices as ints and mapping keys as strings; YAML keys may be ints too.
    return tuple(p if isinstance(p, int) else str(p) for p in path)


def read_yaml(path: str | Path) -> tuple[Any, Source]:
    """The data of the YAML file ``path`` and its :class:`Source` (raises :class:`YamlSourceError`)."""
    return parse_yaml(read_text(path), str(path))


def read_text(path: str | Path) -> str:
    """The text of the configuration file ``path``: UTF-8 (a byte-order mark is allowed), at most
    :data:`MAX_FILE_BYTES` (only that much is read, so a device or a huge file costs nothing)."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise YamlSourceError(f"cannot read configuration file {path}: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise YamlSourceError(f"{path}: configuration file larger than {MAX_FILE_BYTES // 1024} KiB; "
                              "a configuration is a short YAML text")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise YamlSourceError(f"{path}:{line}: not a UTF-8 text file (byte 0x{data[exc.start]:02x} at offset "
                              f"{exc.start}); a configuration file is YAML text") from None


def parse_yaml(text: str, name: str = "<string>", *, lines: bool = True) -> tuple[Any, Source]:
    """The data of the YAML document ``text`` and its :class:`Source` named ``name``.

    Errors start ``NAME:LINE:``; with ``lines=False`` (a one-line text such as an override's value) they
    start ``NAME:`` and give the column instead.
    """
    loader = None
    try:
        loader = yaml.SafeLoader(text)
        node = loader.get_single_node()
        if node is not None:
            _check(node, name, lines)
        data = loader.construct_document(node) if node is not None else None
    except yaml.MarkedYAMLError as exc:
        raise YamlSourceError(f"{_at(name, exc.problem_mark or exc.context_mark, lines)}: not valid YAML: "
                              f"{exc.problem or exc.context}") from None
    except yaml.reader.ReaderError as exc:
        raise YamlSourceError(f"{name}: not valid YAML: unacceptable character #x{exc.character:04x} at "
                              f"offset {exc.position} ({exc.reason})") from None
    except yaml.YAMLError as exc:
        raise YamlSourceError(f"{name}: not valid YAML: {exc}") from None
    except RecursionError:
        raise YamlSourceError(f"{name}: nested more than {MAX_DEPTH} levels deep") from None
    finally:
        if loader is not None:
            loader.dispose()
    line_of: dict[Path_, int] = {}
    if node is not None:
        _record(node, (), line_of)
    return data, Source(name, line_of)


def _at(name: str, mark: yaml.Mark | None, lines: bool) -> str:
    """``NAME:LINE`` of ``mark`` (or ``NAME, column C`` for a one-line text)."""
    if mark is None:
        return name
    return f"{name}:{mark.line + 1}" if lines else f"{name} (column {mark.column + 1})"


def _check(root: yaml.Node, name: str, lines: bool) -> None:
    """Refuse a document beyond the module's limits, before any of it is built. Every node is visited
    once (aliases share their node), so the cost is that of the text, whatever the aliases expand to."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def fail(node: yaml.Node, what: str) -> None:
        raise YamlSourceError(f"{_at(name, node.start_mark, lines)}: {what}")

    def size(node: yaml.Node, depth: int) -> int:
        """Values below and including ``node`` with aliases expanded (memoised per node)."""
        if id(node) in sizes:
            return sizes[id(node)]
        if id(node) in open_nodes:
            fail(node, "an alias refers to a value that contains it (a recursive alias)")
        if depth > MAX_DEPTH:
            fail(node, f"nested more than {MAX_DEPTH} levels deep")
        if isinstance(node, yaml.ScalarNode):
            if node.tag in _NUMBER_TAGS and len(node.value) > MAX_NUMBER_CHARS:
                fail(node, f"a number of {len(node.value)} characters; numbers are limited to "
                     f"{MAX_NUMBER_CHARS} characters")
            sizes[id(node)] = 1
            return 1
        open_nodes.add(id(node))
        if isinstance(node, yaml.MappingNode):
            _refuse_duplicate_keys(node, fail)
            children = [n for pair in node.value for n in pair]
        else:
            children = list(node.value)
        total = 1
        for child in children:
            total += size(child, depth + 1)
            if total > MAX_VALUES:
                fail(root, f"expands to more than {MAX_VALUES} values (YAML aliases repeat what they refer "
                     f"to); a configuration is limited to {MAX_VALUES}")
        open_nodes.discard(id(node))
        sizes[id(node)] = total
        return total

    size(root, 0)


def _refuse_duplicate_keys(node: yaml.MappingNode, fail) -> None:
    """A key given twice in one mapping is an error naming the key and both lines."""
    seen: dict[tuple[str, str], yaml.Node] = {}
    for key_node, _ in node.value:
        if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == _MERGE_TAG:
            continue
        key = (key_node.tag, key_node.value)
        if key in seen:
            first = seen[key].start_mark.line + 1
            fail(key_node, f"duplicate key {_short(key_node.value)!r} (first given on line {first}); a key may "
                 "appear once in a mapping")
        seen[key] = key_node


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[:limit - 1] + "…"


def _record(node: yaml.Node, path: Path_, lines: dict[Path_, int]) -> None:
    """Fill ``lines`` with the line of every key and item below ``node`` (bounded: :func:`_check` ran)."""
    if isinstance(node, yaml.MappingNode):
        for key_node, value_node in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else None
            if key is None:
                continue
            child = (*path, _key(key_node))
            lines.setdefault(_normalise(child), key_node.start_mark.line + 1)
            _record(value_node, child, lines)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            lines.setdefault((*path, i), item.start_mark.line + 1)
            _record(item, (*path, i), lines)


def _key(node: yaml.ScalarNode) -> Any:
    """The key as safe_load reads it where that matters for a path: an int key stays an int."""
    if node.tag == "tag:yaml.org,2002:int":
        try:
            return int(node.value, 0)
        except ValueError:
            return node.value
    return node.value
