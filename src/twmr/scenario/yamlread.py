"""Read YAML into plain Python data and remember the line of every key and list item.

`read(text, source)` returns the data and a `Lines` map from key paths (tuples of keys and list
indices) to 1-based line numbers, so every later problem can name file:line.
"""
from __future__ import annotations

from typing import Any

import yaml

from twmr.core.errors import Location, Problem, ScenarioError

Path_ = tuple[Any, ...]


class Lines:
    """Line numbers by key path; `at(path)` falls back to the nearest enclosing path."""

    def __init__(self, source: str):
        self.source = source
        self.lines: dict[Path_, int] = {}

    def at(self, *path: Any) -> Location:
        p = tuple(path)
        while p and p not in self.lines:
            p = p[:-1]
        return Location(self.source, self.lines.get(p, 0), _dotted(path))


def _dotted(path: tuple[Any, ...]) -> str:
    out = ""
    for k in path:
        out += f"[{k + 1}]" if isinstance(k, int) else (f".{k}" if out else str(k))
    return out


def _convert(node: yaml.Node, path: Path_, lines: Lines, loader: yaml.SafeLoader) -> Any:
    lines.lines.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if isinstance(key, (list, dict)):
                raise ScenarioError(Problem(Location(lines.source, key_node.start_mark.line + 1),
                                            "a key must be a plain name, not a list or mapping.",
                                            "write `name: value`."))
            if key in out:
                raise ScenarioError(Problem(
                    Location(lines.source, key_node.start_mark.line + 1, _dotted(path + (key,))),
                    f"the key '{key}' appears twice.", "keep one of them."))
            lines.lines[path + (key,)] = key_node.start_mark.line + 1
            out[key] = _convert(value_node, path + (key,), lines, loader)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_convert(item, path + (i,), lines, loader) for i, item in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def read(text: str, source: str) -> tuple[Any, Lines]:
    """Parse `text` (YAML). Raises ScenarioError with file:line for syntax errors."""
    lines = Lines(source)
    try:
        loader = yaml.SafeLoader(text)
        try:
            node = loader.get_single_node()
            data = None if node is None else _convert(node, (), lines, loader)
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line = mark.line + 1 if mark is not None else 0
        what = " ".join(x for x in (err.context, err.problem) if x)
        raise ScenarioError(Problem(Location(source, line), f"YAML syntax error: {what}.",
                                    "check the indentation and the ':' / '-' / quotes on this "
                                    "line and the one before.")) from None
    except yaml.YAMLError as err:
        raise ScenarioError(Problem(Location(source, 0), f"YAML error: {err}.",
                                    "check the file is valid YAML.")) from None
    return data, lines
