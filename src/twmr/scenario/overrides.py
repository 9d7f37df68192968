"""`--set` overrides applied to a `ScenarioSpec`: each value given on the command line (or to
`twmr.load`) replaces the scenario's, located at its `--set` text.

`comp.name=value` sets a parameter (or the initial value of an input or state) or the
component's `step_multiple`; `experiment.name=value` an experiment setting;
`events.<name or number>.<key>=value` a key of an event (its time, value, condition...). A
block inside a subsystem is named by its path: `robot.plant.scale=2` (the last dot separates the
name); `assign` is the same for values an including file sets (`parameters: {plant.scale: 2}`).
Values are YAML scalars or flow lists; each is checked against the same JSON Schema as the
file's values.
"""
from __future__ import annotations

import contextlib
import dataclasses
import re
from collections.abc import Sequence
from typing import Any

import yaml

from twmr.core.component import Component
from twmr.core.errors import Location, Problem, ScenarioError
from twmr.core.port import Variable
from twmr.registry import lookup, suggest
from twmr.scenario.loaders import schema, schema_problems
from twmr.scenario.structure import ComponentSpec, Given, ScenarioSpec
from twmr.scenario.yamlread import FAST

#: the file of an override's `Location`: a value named, not a section of the file
OVERRIDE = "--set"
#: what an override may set: a parameter, or the initial value of a state or an input
SETTABLE = ("parameter", "state", "input")
_FORM = "write component.parameter=value or experiment.stop=value."
#: a decimal integer or a decimal fraction without exponent: YAML reads it as Python does
_DECIMAL = re.compile(r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?")


def apply_overrides(spec: ScenarioSpec, texts: Sequence[str]) -> ScenarioSpec:
    """`spec` with the overrides `texts` applied; ScenarioError listing every override that
    cannot be applied."""
    problems: list[Problem] = []
    for text in texts:
        spec = _apply(spec, str(text), problems)
    if problems:
        raise ScenarioError(problems)
    return spec


def _parse(text: str, key: str, value: str, loc: Location, problems: list[Problem]
           ) -> tuple[bool, Any]:
    """(read, the value) of the text after '='."""
    if _DECIMAL.fullmatch(value):  # what YAML reads as this int or float (a sweep's values)
        return True, float(value) if "." in value else int(value)
    with contextlib.suppress(yaml.YAMLError):  # libyaml first; PyYAML words a problem
        return True, yaml.load(value, Loader=FAST)  # noqa: S506 - a safe loader
    try:
        return True, yaml.safe_load(value)
    except yaml.YAMLError as err:
        what = str(getattr(err, "problem", None) or str(err).splitlines()[0])
        what = what.replace("'<stream end>'", "the end")
        problems.append(Problem(loc, f"cannot read the value '{value}' of '{text}': it is not "
                                f"a YAML value ({what}).",
                                f"give a number ({key}=2.5), a number with a unit "
                                f"({key}='30 cm'), true or false, a list in brackets "
                                f"({key}=[1, 2]) or text in quotes ({key}=\"'fast'\"); quote "
                                f"the whole --set argument in the shell."))
        return False, None


def _apply(spec: ScenarioSpec, text: str, problems: list[Problem]) -> ScenarioSpec:
    loc = Location(OVERRIDE, 0, text)
    key, sep, value = text.partition("=")
    if key.strip().startswith("events.") and "events" not in spec.components:
        ok, parsed = _parse(text, key.strip(), value, loc, problems) if sep else (False, None)
        if not sep:
            problems.append(Problem(loc, f"cannot read the override '{text}'.",
                                    "write events.<name or number>.<key>=value."))
        return _set_event(spec, key.strip(), parsed, loc, problems) if ok else spec
    path, name = _split(spec, key.strip())
    comp = ".".join(path)
    if not sep or not path or not name or not comp:
        problems.append(Problem(loc, f"cannot read the override '{text}'.", _FORM))
        return spec
    ok, parsed = _parse(text, key.strip(), value, loc, problems)
    if not ok:
        return spec
    if comp == "experiment":
        parsed = {k: _number(v) for k, v in parsed.items()} if isinstance(parsed, dict) \
            else _number(parsed)
        allowed = schema()["properties"]["experiment"]["properties"]
        if name not in allowed:  # an option of the algorithm: checked by it when built
            options = {**spec.experiment.options, name: Given(parsed, loc)}
            return dataclasses.replace(spec, experiment=dataclasses.replace(spec.experiment,
                                                                            options=options))
        found = schema_problems(parsed, lambda *_: loc, ("experiment", name), allowed[name])
        problems += found
        if found:
            return spec
        changes: dict[str, Any] = {name: Given(parsed, loc)}
        return dataclasses.replace(spec, experiment=dataclasses.replace(spec.experiment,
                                                                        **changes))
    written = value.strip()
    as_written = written if isinstance(parsed, (int, float)) and written != str(parsed) else None
    return assign(spec, path, name, Given(parsed, loc, as_written), problems)


#: what an override may change in an event: every key of an event but its name
_EVENT_KEYS = ("at", "until", "value", "seed", "when", "hysteresis", "duration")


def event_key(spec: ScenarioSpec, key: str) -> tuple[int, str]:
    """(the 0-based index, the key) of the event `events.<name or number>.<key>` names;
    ValueError saying what is wrong and the fix."""
    _, _, rest = key.partition(".")
    which, _, field = rest.rpartition(".")
    names = [str(e.name.value) if e.name is not None else str(k)
             for k, e in enumerate(spec.events, 1)]
    index = names.index(which) if which in names else (
        int(which) - 1 if which.isdigit() and 1 <= int(which) <= len(spec.events) else -1)
    if index < 0:
        there = ", ".join(names) or "none"
        raise ValueError(f"'{key}': the scenario has no event '{which}'"
                         f"{suggest(which, names)} (its events: {there}). Fix: name an event "
                         f"by its name: or its number from 1, e.g. events.1.at=5.0.")
    if field not in _EVENT_KEYS:
        raise ValueError(f"'{key}': an event has no '{field}' to set"
                         f"{suggest(field, list(_EVENT_KEYS))}. Fix: set one of: "
                         f"{', '.join(_EVENT_KEYS)}.")
    return index, field


def _set_event(spec: ScenarioSpec, key: str, value: Any, loc: Location,
               problems: list[Problem]) -> ScenarioSpec:
    """`spec` with `events.<name or 1-based number>.<key>` set to `value` (a fault campaign's
    sweep: `--vary events.drop.at=uniform:5:25`), or unchanged after the problem."""
    try:
        index, field = event_key(spec, key)
    except ValueError as err:
        message, _, fix = str(err).partition(" Fix: ")
        problems.append(Problem(loc, message, fix))
        return spec
    allowed = schema()["properties"]["events"]["items"]["properties"][field]
    found = schema_problems(_number(value) if field != "when" else value, lambda *_: loc,
                            ("events", index, field), allowed)
    problems += found
    if found:
        return spec
    given = Given(_number(value) if field != "when" else value, loc)
    event = dataclasses.replace(spec.events[index], **{field: given})  # type: ignore[arg-type]
    events = (*spec.events[:index], event, *spec.events[index + 1:])
    return dataclasses.replace(spec, events=events)


def _number(value: Any) -> Any:
    """A text that reads as a number, as that number (YAML 1.1 reads '1e-5', no dot, as text)."""
    if isinstance(value, str):
        with contextlib.suppress(ValueError):
            return float(value)
    return value


def assign(spec: ScenarioSpec, path: Sequence[str], name: str, value: Given[Any],
           problems: list[Problem], outer: str = "") -> ScenarioSpec:
    """`spec` with `name` of the component at `path` (instance names, outermost first: a block
    inside subsystems) set to `value`, or unchanged after adding the problem. `outer` is the
    dotted path of `spec` itself inside the scenario ('' at the top)."""
    loc = value.where
    head, full = path[0], ".".join((*([outer] if outer else []), *path))
    target = spec.components.get(head)
    if target is None:
        inside = f" in the subsystem '{outer}' ({spec.source})" if outer else ""
        problems.append(Problem(loc, f"no component '{head}'{inside}"
                                f"{suggest(head, list(spec.components))}.",
                                f"use one of: {', '.join(spec.components)}"
                                f"{'' if outer else ', or experiment'}."))
        return spec
    here = f"{outer}.{head}" if outer else head
    if len(path) > 1:
        if target.system is None:
            problems.append(Problem(loc, f"'{here}' ({target.kind.value}) is a block, not a "
                                    f"subsystem, so '{full}.{name}' names nothing.",
                                    f"write {here}.{path[1]}=value."))
            return spec
        changed = dataclasses.replace(target, system=assign(target.system, path[1:], name,
                                                            value, problems, here))
    elif name == "step_multiple":
        part = schema()["properties"]["components"]["additionalProperties"]["properties"]
        found = schema_problems(value.value, lambda *_: loc,
                                ("components", head, "step_multiple"), part["step_multiple"])
        problems += found
        changed = target if found else dataclasses.replace(target, step_multiple=value)
    elif target.system is not None:
        blocks = ", ".join(f"{here}.{b}" for b in target.system.components)
        problems.append(Problem(loc, f"'{here}' is a subsystem ({target.system.source}); "
                                f"'{name}' is not one of its values.",
                                f"set a value of one of its blocks ({blocks}): "
                                f"{here}.<block>.{name}=value."))
        return spec
    else:
        changed = _set_value(spec, target, name, value)
    return dataclasses.replace(spec, components={**spec.components, head: changed})


def _split(spec: ScenarioSpec, key: str) -> tuple[list[str], str]:
    """(instance path, value name) of 'comp.name': the longest instance name the scenario has
    (a flattened SSP system's 'sub.comp'; an FMU's dotted names such as 'Add1.gain.k' stay
    whole), through subsystems ('robot.plant.scale'); the text before the last dot when no
    instance matches (the error names it)."""
    parts = key.split(".")
    for i in range(len(parts) - 1, 0, -1):
        head = ".".join(parts[:i])
        target = spec.components.get(head)
        if target is None:
            continue
        if target.system is not None and i < len(parts) - 1:
            inner, name = _split(target.system, ".".join(parts[i:]))
            return [head, *inner], name
        return [head], ".".join(parts[i:])
    comp, _, name = key.rpartition(".")
    return (comp.split(".") if comp else []), name


def _set_value(spec: ScenarioSpec, comp: ComponentSpec, name: str,
               value: Given[Any]) -> ComponentSpec:
    """`comp` with `name` set under 'initial' (an input or state of its kind) or 'parameters'."""
    section = "parameters"
    try:
        var = _declared(lookup(comp.kind.value, spec.base_dir), name.partition("[")[0])
        if var is not None and var.kind in ("state", "input"):
            section = "initial"
    except Exception:  # noqa: BLE001 - a kind that does not load is reported by the builder
        pass
    changes: dict[str, Any] = {section: {**getattr(comp, section), name: value}}
    return dataclasses.replace(comp, **changes)


#: the function of `Component.declared`
_DECLARED = vars(Component)["declared"].__func__


def _declared(cls: type[Component], name: str) -> Variable | None:
    """`cls.declared().get(name)`, without collecting the others (the most derived class that
    declares `name` a variable has it)."""
    if getattr(cls.declared, "__func__", None) is not _DECLARED:
        return cls.declared().get(name)  # a class of its own making
    for klass in cls.__mro__:
        var = vars(klass).get(name)
        if isinstance(var, Variable):
            return var
    return None
