"""The SystemStructureCommon (ssc:) parts every SSP file kind shares: unit definitions,
enumerations and the transformations of connections and parameter mappings."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from twmr.core.errors import Location
from twmr.core.units import Unit
from twmr.fmi.ssp.xmlsafe import NS, at, tag

_BASES = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def units(parent: Any) -> dict[str, Unit]:
    """The ssc:Unit definitions under `parent`'s Units element (SI = factor * value + offset)."""
    found: dict[str, Unit] = {}
    for u in parent.iterfind("*/ssc:Unit", NS):
        base = u.find("ssc:BaseUnit", NS)
        b = base.attrib if base is not None else {}
        found[u.get("name")] = Unit(u.get("name"), float(b.get("factor", 1.0)),
                                    tuple(int(b.get(k, 0)) for k in _BASES),
                                    float(b.get("offset", 0.0)))
    return found


def enumerations(parent: Any) -> dict[str, dict[str, int]]:
    """The ssc:Enumeration definitions under `parent`'s Enumerations element: name -> items."""
    return {e.get("name"): {i.get("name"): int(i.get("value")) for i in
                            e.iterfind("ssc:Item", NS)}
            for e in parent.iterfind("*/ssc:Enumeration", NS)}


@dataclass(frozen=True)
class Transformation:
    """A connection's or mapping's transformation: 'linear' (factor, offset) or a mapping
    ('boolean', 'integer', 'enumeration') from source to target values."""

    kind: str
    factor: float = 1.0
    offset: float = 0.0
    table: tuple[tuple[Any, Any], ...] = ()
    where: Location = field(default_factory=Location)


_MAPPINGS: dict[str, tuple[str, Callable[[str], Any]]] = {
    "BooleanMappingTransformation": ("boolean", lambda v: v in ("true", "1")),
             "IntegerMappingTransformation": ("integer", int),
             "EnumerationMappingTransformation": ("enumeration", str)}


def transformation(parent: Any, source: str) -> Transformation | None:
    """The transformation written under `parent` (a connection or mapping entry), if any."""
    for child in parent:
        if not isinstance(child.tag, str) or child.tag.split("}")[0][1:] != NS["ssc"]:
            continue
        name = child.tag.split("}")[1]
        if name == "LinearTransformation":
            return Transformation("linear", float(child.get("factor", 1.0)),
                                  float(child.get("offset", 0.0)), where=at(source, child))
        if name in _MAPPINGS:
            kind, cast = _MAPPINGS[name]
            table = tuple((cast(e.get("source")), cast(e.get("target")))
                          for e in child.iterfind("ssc:MapEntry", NS))
            return Transformation(kind, table=table, where=at(source, child, tag(child)))
    return None
