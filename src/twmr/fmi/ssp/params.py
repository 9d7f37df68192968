"""Parameter sets (ssv:ParameterSet, in an .ssv file or inline) and parameter mappings
(ssm:ParameterMapping, in an .ssm file or inline) read into plain values with their lines."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.core.units import Unit
from twmr.fmi.ssp.common import Transformation, transformation, units
from twmr.fmi.ssp.xmlsafe import NS, at

_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration", "Binary")
_READ: dict[str, Callable[[str], Any]] = {"Real": float, "Integer": int,
                                          "Boolean": lambda v: v in ("true", "1")}


@dataclass(frozen=True)
class Value:
    """One parameter value: its name in the set, SSP type, value (an enumeration's item name
    as text), unit (None: not given) and where it was written."""

    name: str
    type: str
    value: Any
    unit: str | None
    where: Location


@dataclass(frozen=True)
class Entry:
    """One mapping entry: the name it gives a source parameter, and a transformation."""

    target: str
    transform: Transformation | None
    suppress_units: bool
    where: Location


def parameter_set(root: Any, source: str) -> tuple[list[Value], dict[str, Unit]]:
    """The values of an ssv:ParameterSet element and the units it defines."""
    values = []
    for p in root.iterfind("ssv:Parameters/ssv:Parameter", NS):
        typed = next((c for c in p if isinstance(c.tag, str) and c.tag.split("}")[1] in _TYPES),
                     None)
        if typed is None:
            continue
        kind = typed.tag.split("}")[1]
        where = at(source, typed, f"ssv:Parameter {p.get('name')}")
        if kind == "Binary":
            raise ScenarioError(Problem(where, f"the parameter '{p.get('name')}' is of type "
                                        f"Binary, which twmr does not bind.",
                                        "remove it from the parameter set."))
        raw = typed.get("value")
        value: Any = _READ.get(kind, str)(raw)
        values.append(Value(p.get("name"), kind, value, typed.get("unit"), where))
    return values, units(root)


def parameter_mapping(root: Any, source: str) -> dict[str, Entry]:
    """The entries of an ssm:ParameterMapping element, by source name."""
    return {e.get("source"): Entry(e.get("target"), transformation(e, source),
                                   e.get("suppressUnitConversion") in ("true", "1"),
                                   at(source, e, f"ssm:MappingEntry {e.get('source')}"))
            for e in root.iterfind("ssm:MappingEntry", NS)}
