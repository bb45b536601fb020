"""YAML read with the line of every key, so that a configuration error can say where it is.

:func:`read_yaml` returns the plain data (as :func:`yaml.safe_load` would) together with a
:class:`Source`: the file name and the 1-based line of every mapping key and sequence item, addressed by
its path (``("objectives", 0, "sense")``). :meth:`Source.where` turns the location of a validation error
(pydantic's ``loc``, or any path into the data) into ``FILE:LINE``; a path that does not exist in the file
(a default, or a key added by an override) falls back to its nearest ancestor that does.

Used by every configuration loader (:func:`optimizer.config.load_config` and the campaign schema), so that
all configuration errors look the same.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

Path_ = tuple[Any, ...]


class YamlSourceError(ValueError):
    """A file that cannot be read or is not valid YAML; the message names the file and line."""


@dataclass(frozen=True)
class Source:
    """Where the values of one YAML document came from.

    name: the file name as given (``"<defaults>"`` for no file). lines: ``{path: line}``, 1-based, for
    every mapping key (the line of the key) and sequence item (the line of the item).
    """

    name: str
    lines: dict[Path_, int] = field(default_factory=dict)

    def line(self, path: Sequence[Any]) -> int | None:
        """Line of ``path`` or of its nearest ancestor present in the file; None if none is."""
        path = tuple(path)
        for n in range(len(path), 0, -1):
            line = self.lines.get(_normalise(path[:n]))
            if line is not None:
                return line
        return None

    def where(self, path: Sequence[Any] = ()) -> str:
        """``FILE:LINE`` of ``path`` (see :meth:`line`), or just ``FILE`` when no line is known."""
        line = self.line(path)
        return self.name if line is None else f"{self.name}:{line}"


def _normalise(path: Path_) -> Path_:
    # pydantic reports list indices as ints and mapping keys as strings; YAML keys may be ints too.
    return tuple(p if isinstance(p, int) else str(p) for p in path)


def read_yaml(path: str | Path) -> tuple[Any, Source]:
    """The data of the YAML file ``path`` and its :class:`Source` (raises :class:`YamlSourceError`)."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise YamlSourceError(f"cannot read configuration file {path}: {exc.strerror}") from None
    return parse_yaml(text, str(path))


def parse_yaml(text: str, name: str = "<string>") -> tuple[Any, Source]:
    """The data of the YAML document ``text`` and its :class:`Source` named ``name``."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        at = f"{name}:{mark.line + 1}" if mark is not None else name
        raise YamlSourceError(f"{at}: not valid YAML: {exc.problem or exc}") from None
    except yaml.YAMLError as exc:
        raise YamlSourceError(f"{name}: not valid YAML: {exc}") from None
    lines: dict[Path_, int] = {}
    if node is not None:
        _record(node, (), lines)
    return data, Source(name, lines)


def _record(node: yaml.Node, path: Path_, lines: dict[Path_, int]) -> None:
    """Fill ``lines`` with the line of every key and item below ``node``."""
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
