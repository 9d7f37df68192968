"""A scenario's `events:` in SSP, in our annotation beside the experiment (`twmr:Events`, one
`twmr:Event` per event, each key an attribute, the values as JSON): `twmr export --ssp` writes
them, reading the SSP back gives them again; another tool reads the system without them. The
components they name are written as the SSP's elements (`robot__plant.pose`).
"""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from typing import Any

from twmr.scenario.structure import EventSpec, Given

#: an event's keys, in the order written
KEYS = ("name", "at", "until", "port", "fault", "value", "seed", "set", "when", "hysteresis",
        "duration")
#: the keys that name a component's port or parameter ('comp.port')
_NAMED = ("port", "set")
_CONDITION = re.compile(r"^(\s*)([A-Za-z_][\w.]*?)(\.[A-Za-z_]\w*(?:\[\d+\])?\s*(?:>=|<=|>|<).*)$")


def events_element(events: tuple[EventSpec, ...], tag: str,
                   element: Callable[[str], str]) -> ET.Element:
    """The `tag` (twmr:Events) element of `events`, components named by `element`."""
    out = ET.Element(tag)
    for event in events:
        attrs = {}
        for key in KEYS:
            given = getattr(event, key)
            if given is None or given.value is None:
                continue
            value = given.value
            if key in _NAMED:
                comp, _, name = str(value).strip().rpartition(".")
                value = f"{element(comp)}.{name}"
            elif key == "when":
                found = _CONDITION.match(str(value))
                if found is not None:
                    value = f"{found[1]}{element(found[2])}{found[3]}"
            attrs[key] = json.dumps(value)
        ET.SubElement(out, tag.replace("Events", "Event"), attrs)
    return out


def read_events(events: Any, located: Callable[[Any, str], Any]) -> tuple[EventSpec, ...]:
    """The `EventSpec`s of a `twmr:Events` element (None: none), each value located by
    `located(xml element, what)`."""
    if events is None:
        return ()
    out = []
    for e in events:
        where = located(e, "twmr Event")
        given: dict[str, Any] = {}
        for key in KEYS:
            text = e.get(key)
            if text is None:
                continue
            try:
                value = json.loads(text)
            except ValueError:
                value = text
            given[key] = Given(value, located(e, f"twmr Event {key}"))
        out.append(EventSpec(given.get("at", Given(None, where)), given.get("until"),
                             given.get("port"), given.get("fault"), given.get("value"),
                             given.get("seed"), where, given.get("set"), given.get("when"),
                             given.get("hysteresis"), given.get("duration"),
                             given.get("name")))
    return tuple(out)
