"""Read YAML into plain Python data and remember the line of every key and list item.

`read(text, source)` returns the data and a `Lines` map from key paths (tuples of keys and list
indices) to 1-based line numbers, so every later problem can name file:line.
"""
from __future__ import annotations

import re
import stat
from pathlib import Path
from typing import Any

import yaml

from twmr.core.errors import Location, Problem, ScenarioError

Path_ = tuple[Any, ...]

#: values (mapping entries, list items, scalars) a scenario may expand to; a YAML alias bomb
#: of a few hundred bytes expands to billions
MAX_VALUES = 1_000_000


class Lines:
    """Line numbers by key path; `at(path)` falls back to the nearest enclosing path."""

    def __init__(self, source: str):
        self.source = source
        self.lines: dict[Path_, int] = {}
        #: the text of a plain scalar that YAML read as a number or a boolean it does not print
        #: back ('01234567' is the octal 342391 to YAML 1.1, '1.10' is 1.1, 'on' is True)
        self.texts: dict[Path_, str] = {}
        self.count = 0  # values converted so far

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
    lines.count += 1
    if lines.count > MAX_VALUES:
        raise ScenarioError(Problem(Location(lines.source, node.start_mark.line + 1),
                                    f"the scenario expands to more than {MAX_VALUES:,} values "
                                    f"(YAML aliases that repeat each other?).",
                                    "write the values out, or use fewer nested aliases."))
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)  # YAML merge keys (<<: *base)
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if not isinstance(key, str):
                shown = key if not isinstance(key, bool) else f"{key} (yes/no/on/off)"
                raise ScenarioError(Problem(Location(lines.source, key_node.start_mark.line + 1),
                                            f"the key {shown!r} is not a name: YAML reads it as "
                                            f"a {type(key).__name__}.",
                                            "write names as text; quote keys such as '7' or "
                                            "'on'."))
            if key in out:
                raise ScenarioError(Problem(
                    Location(lines.source, key_node.start_mark.line + 1, _dotted((*path, key))),
                    f"the key '{key}' appears twice.", "keep one of them."))
            key_path = (*path, key)
            lines.lines[key_path] = key_node.start_mark.line + 1
            out[key] = _convert(value_node, key_path, lines, loader)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_convert(item, (*path, i), lines, loader) for i, item in enumerate(node.value)]
    value = loader.construct_object(node, deep=True)
    if isinstance(value, str) and not node.style and _FLOAT_1_2.fullmatch(value):
        value = float(value)
    if isinstance(value, (int, float)) and not node.style and node.value != str(value):
        lines.texts[path] = node.value
    return value


#: a YAML 1.2 float that YAML 1.1 reads as text: an exponent without a dot ('1e-5', '2E3')
_FLOAT_1_2 = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+")


#: the largest scenario file read [bytes]
MAX_FILE_BYTES = 16 * 2**20


def read_file(path: Path) -> str:
    """The text of a scenario file: a regular file (not a folder, FIFO or device) of at most
    `MAX_FILE_BYTES`, in UTF-8 (a byte-order mark is allowed). ScenarioError otherwise."""
    def refuse(why: str, fix: str) -> ScenarioError:
        return ScenarioError(Problem(Location(str(path)), f"cannot read the scenario: {why}.",
                                     fix))
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            what = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
            raise refuse(f"it is {what}", "give the path of a YAML file.")
        if info.st_size > MAX_FILE_BYTES:
            raise refuse(f"it has {info.st_size:,} bytes, more than the limit of "
                         f"{MAX_FILE_BYTES:,}", "split it, or generate the scenario as a dict "
                         "in Python (twmr.load accepts one).")
        with open(path, "rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)
        return data.decode("utf-8-sig")
    except ScenarioError:
        raise
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise ScenarioError(Problem(Location(str(path), line), "the file is not UTF-8 text "
                                    f"(byte 0x{data[err.start]:02x} at offset {err.start}).",
                                    "save the scenario as UTF-8.")) from None
    except OSError as err:
        raise refuse(str(err.strerror or err), "check the path and its permissions.") from None


def read(text: str, source: str) -> tuple[Any, Lines]:
    """Parse `text` (YAML). Raises ScenarioError with file:line for syntax errors."""
    if FAST is not yaml.SafeLoader:
        try:
            return _parse(text, source, FAST)
        except (yaml.YAMLError, RecursionError):
            pass  # the pure-Python parser reports it, in its own words
    try:
        return _parse(text, source, yaml.SafeLoader)
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line = mark.line + 1 if mark is not None else 0
        what = " ".join(x for x in (err.context, err.problem) if x)
        raise ScenarioError(Problem(Location(source, line), f"YAML syntax error: {what}.",
                                    "check the indentation and the ':' / '-' / quotes on this "
                                    "line and the one before.")) from None
    except yaml.reader.ReaderError as err:
        line = text.count("\n", 0, err.position) + 1
        raise ScenarioError(Problem(Location(source, line), f"character {err.character!r} is not "
                                    f"allowed in YAML ({err.reason}).",
                                    "remove control characters; save the file as UTF-8 text."
                                    )) from None
    except yaml.YAMLError as err:
        raise ScenarioError(Problem(Location(source, 0), f"YAML error: {err}.",
                                    "check the file is valid YAML.")) from None
    except RecursionError:
        raise ScenarioError(Problem(Location(source, 0), "the YAML is nested too deeply to read.",
                                    "flatten the structure.")) from None


#: libyaml's parser when PyYAML was built with it: the same nodes and marks, ten times faster
FAST: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _parse(text: str, source: str, loader_class: type[yaml.SafeLoader]) -> tuple[Any, Lines]:
    lines = Lines(source)
    loader = loader_class(text)
    try:
        node = loader.get_single_node()
        return (None if node is None else _convert(node, (), lines, loader)), lines
    finally:
        loader.dispose()
