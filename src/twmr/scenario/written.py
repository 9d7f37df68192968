"""A scenario's YAML text with values set (`twmr tune`'s best.yaml, `twmr fit`'s fitted.yaml):
each `NAME=VALUE` — a component's parameter (`plant.scale`), an element of a parameter or
initial state (`plant.pose[1]`), a component's `step_multiple`, an experiment setting
(`experiment.stop`) — written where the scenario's own file holds it."""
from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

log = logging.getLogger(__name__)


def yaml_with(scenario: Any, settings: Sequence[str | tuple[str, Any]], head: str = ""
              ) -> str | None:
    """`scenario`'s YAML with `settings` ('NAME=VALUE' with the value as YAML, or (NAME, value))
    set, after `head`; None (a warning logged) for a scenario that is no YAML text (an SSP) or a
    name inside a subsystem (set it in the subsystem's file)."""
    import yaml

    if not isinstance(scenario.content, str):
        log.warning("%s is not a YAML scenario: the values are not written into it",
                    scenario.source)
        return None
    data = yaml.safe_load(scenario.content)
    for setting in settings:
        if isinstance(setting, str):
            name, _, text = setting.partition("=")
            value = yaml.safe_load(text)
        else:
            name, value = setting
            value = value.item() if hasattr(value, "item") else value  # numpy scalars
        comp, _, key = name.strip().rpartition(".")
        key, _, index = key.partition("[")
        if comp == "experiment":
            data.setdefault("experiment", {})[key] = value
            continue
        entry = data.get("components", {}).get(comp)
        if not isinstance(entry, dict):
            log.warning("%s is inside a subsystem (or no component of %s): set it in the "
                        "subsystem's file", name, scenario.source)
            return None
        if key == "step_multiple":
            entry[key] = value
            continue
        section = _section(scenario, comp, key, entry)
        held = entry.setdefault(section, {})
        if index:
            whole = list(held.get(key, _current(scenario, comp, key)))
            whole[int(index.rstrip("]")) - 1] = value
            value = whole
        held[key] = value
    return head + yaml.safe_dump(data, sort_keys=False)


def _section(scenario: Any, comp: str, key: str, entry: dict[str, Any]) -> str:
    """'initial' for a state or input, else 'parameters'."""
    if key in entry.get("initial", {}):
        return "initial"
    if key in entry.get("parameters", {}):
        return "parameters"
    var = scenario.system.components[comp].variables.get(key)
    return "initial" if var is not None and var.kind in ("state", "input") else "parameters"


def _current(scenario: Any, comp: str, key: str) -> list[Any]:
    return list(scenario.system.components[comp].get(key))
