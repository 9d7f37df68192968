"""`--set` overrides applied to a `ScenarioSpec`: each value given on the command line (or to
`twmr.load`) replaces the scenario's, located at its `--set` text.

`comp.name=value` sets a parameter (or the initial value of an input or state) or the
component's `step_multiple`; `experiment.name=value` an experiment setting. Values are YAML
scalars or flow lists; each is checked against the same JSON Schema as the file's values.
"""
from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Sequence
from typing import Any

import yaml

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.registry import lookup, suggest
from twmr.scenario.loaders import schema, schema_problems, unknown_key
from twmr.scenario.structure import ComponentSpec, Given, ScenarioSpec

_FORM = "write component.parameter=value or experiment.stop=value."


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
    loc = Location("--set", 0, text)
    key, sep, value = text.partition("=")
    comp, dot, name = _split(spec, key.strip())
    if not sep or not dot or not name:
        problems.append(Problem(loc, f"cannot read the override '{text}'.", _FORM))
        return spec
    ok, parsed = _parse(text, key.strip(), value, loc, problems)
    if not ok:
        return spec
    if comp == "experiment":
        if isinstance(parsed, str):
            with contextlib.suppress(ValueError):
                parsed = float(parsed)  # YAML 1.1 reads '1e-5' (no dot) as text
        allowed = schema()["properties"]["experiment"]["properties"]
        if name not in allowed:
            problems.append(unknown_key(loc, name, list(allowed)))
            return spec
        found = schema_problems(parsed, lambda *_: loc, ("experiment", name), allowed[name])
        problems += found
        if found:
            return spec
        changes: dict[str, Any] = {name: Given(parsed, loc)}
        return dataclasses.replace(spec, experiment=dataclasses.replace(spec.experiment,
                                                                        **changes))
    target = spec.components.get(comp)
    if target is None:
        problems.append(Problem(loc, f"no component '{comp}'{suggest(comp, list(spec.components))}"
                                f".", "use a component name of the scenario, or 'experiment'."))
        return spec
    if name == "step_multiple":
        part = schema()["properties"]["components"]["additionalProperties"]["properties"]
        found = schema_problems(parsed, lambda *_: loc, ("components", comp, "step_multiple"),
                                part["step_multiple"])
        problems += found
        changed = target if found else dataclasses.replace(target,
                                                           step_multiple=Given(parsed, loc))
    else:
        changed = _set_value(spec, target, name, Given(parsed, loc))
    return dataclasses.replace(spec, components={**spec.components, comp: changed})


def _split(spec: ScenarioSpec, key: str) -> tuple[str, str, str]:
    """(component, '.', name) of 'comp.name'; a dotted instance name ('sub.comp.k', an SSP
    nested system) is the longest one the scenario has."""
    parts = key.split(".")
    for i in range(len(parts) - 1, 1, -1):
        if ".".join(parts[:i]) in spec.components:
            return ".".join(parts[:i]), ".", ".".join(parts[i:])
    return key.partition(".")


def _set_value(spec: ScenarioSpec, comp: ComponentSpec, name: str,
               value: Given[Any]) -> ComponentSpec:
    """`comp` with `name` set under 'initial' (an input or state of its kind) or 'parameters'."""
    section = "parameters"
    try:
        var = lookup(comp.kind.value, spec.base_dir).declared().get(name)
        if var is not None and var.kind in ("state", "input"):
            section = "initial"
    except Exception:  # noqa: BLE001 - a kind that does not load is reported by the builder
        pass
    changes: dict[str, Any] = {section: {**getattr(comp, section), name: value}}
    return dataclasses.replace(comp, **changes)
