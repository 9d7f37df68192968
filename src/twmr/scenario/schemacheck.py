"""A quick yes/no check of an instance against the scenario's JSON Schema, without jsonschema.

`conforms(instance, schema)` answers True only when the instance satisfies every keyword (the
subset of Draft 2020-12 that `scenario.schema.json` uses); False when it breaks one or the
schema uses a keyword this check does not know. The loaders run jsonschema itself only on
False, to word and locate each problem, so a valid scenario never imports it.
"""
from __future__ import annotations

import re
from functools import cache
from typing import Any

#: keywords that describe and never constrain
_ANNOTATIONS = frozenset(("$schema", "$id", "title", "description", "$defs", "default",
                          "examples", "$comment"))
_TYPES: dict[str, Any] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    "number": lambda v: isinstance(v, int | float) and not isinstance(v, bool),
    "integer": lambda v: (isinstance(v, int) and not isinstance(v, bool))
    or (isinstance(v, float) and v.is_integer()),
}


@cache
def _pattern(text: str) -> re.Pattern[str]:
    return re.compile(text)


def conforms(instance: Any, schema: dict[str, Any], root: dict[str, Any] | None = None) -> bool:
    """Whether `instance` satisfies `schema` (`root`: where '#/...' references start, default
    `schema`); False too for a keyword outside the supported subset."""
    root = schema if root is None else root
    for key, want in schema.items():
        if key in _ANNOTATIONS:
            continue
        check = _KEYWORDS.get(key)
        if check is None or not check(instance, want, schema, root):
            return False
    return True


def _type(v: Any, want: Any, _s: dict[str, Any], _r: dict[str, Any]) -> bool:
    names = [want] if isinstance(want, str) else list(want)
    return any(name in _TYPES and _TYPES[name](v) for name in names)


def _properties(v: Any, want: dict[str, Any], _s: dict[str, Any], root: dict[str, Any]) -> bool:
    return not isinstance(v, dict) or all(conforms(v[k], sub, root)
                                          for k, sub in want.items() if k in v)


def _additional(v: Any, want: Any, schema: dict[str, Any], root: dict[str, Any]) -> bool:
    if not isinstance(v, dict):
        return True
    extra = [k for k in v if k not in schema.get("properties", {})]
    return want is True or (want is not False and all(conforms(v[k], want, root)
                                                      for k in extra)) or not extra


def _required(v: Any, want: list[str], _s: dict[str, Any], _r: dict[str, Any]) -> bool:
    return not isinstance(v, dict) or all(k in v for k in want)


def _items(v: Any, want: Any, _s: dict[str, Any], root: dict[str, Any]) -> bool:
    return not isinstance(v, list) or (isinstance(want, dict)
                                       and all(conforms(x, want, root) for x in v))


def _pattern_kw(v: Any, want: str, _s: dict[str, Any], _r: dict[str, Any]) -> bool:
    return not isinstance(v, str) or _pattern(want).search(v) is not None


def _number(test: Any) -> Any:
    def check(v: Any, want: Any, _s: dict[str, Any], _r: dict[str, Any]) -> bool:
        return not _TYPES["number"](v) or test(v, want)
    return check


def _size(kind: type[dict[Any, Any]] | type[list[Any]] | type[str]) -> Any:
    def check(v: Any, want: int, _s: dict[str, Any], _r: dict[str, Any]) -> bool:
        return not isinstance(v, kind) or len(v) >= want
    return check


def _property_names(v: Any, want: dict[str, Any], _s: dict[str, Any],
                    root: dict[str, Any]) -> bool:
    return not isinstance(v, dict) or all(conforms(k, want, root) for k in v)


def _ref(v: Any, want: str, _s: dict[str, Any], root: dict[str, Any]) -> bool:
    if not want.startswith("#/"):
        return False
    target: Any = root
    for part in want[2:].split("/"):
        if not isinstance(target, dict) or part not in target:
            return False
        target = target[part]
    return isinstance(target, dict) and conforms(v, target, root)


def _enum(v: Any, want: list[Any], _s: dict[str, Any], _root: dict[str, Any]) -> bool:
    return any(v == w and type(v) is type(w) for w in want)


def _one_of(v: Any, want: list[dict[str, Any]], _s: dict[str, Any],
            root: dict[str, Any]) -> bool:
    return sum(conforms(v, sub, root) for sub in want) == 1


_KEYWORDS: dict[str, Any] = {
    "type": _type, "properties": _properties, "additionalProperties": _additional,
    "required": _required, "items": _items, "pattern": _pattern_kw,
    "minimum": _number(lambda v, w: v >= w), "exclusiveMinimum": _number(lambda v, w: v > w),
    "minProperties": _size(dict), "minItems": _size(list), "minLength": _size(str),
    "propertyNames": _property_names, "$ref": _ref, "oneOf": _one_of, "enum": _enum,
}
