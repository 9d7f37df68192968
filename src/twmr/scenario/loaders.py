"""Loaders: a scenario file, YAML text or a dict -> `ScenarioSpec`, checked against the JSON Schema.

`load_structure(path)` picks the loader of the file's suffix from the entry-point group
`twmr.loaders` (`loader_of`: the one place `twmr.load`, `twmr.scenario.load` and the CLI ask;
an installed package adds a format with one entry point); `read_structure(source)` reads YAML
text or a dict of the same shape. A YAML value's location is its file, line and key path; a
dict's is its key path. SSP (`.ssp`, `.ssd`, an unpacked folder) is read by `twmr.fmi.ssp`.
"""
from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.registry import suggest
from twmr.scenario.schemacheck import conforms
from twmr.scenario.structure import (
    EXPERIMENT_KEYS,
    ComponentSpec,
    EventSpec,
    ExperimentSpec,
    Exposure,
    Given,
    RecordingSpec,
    ScenarioSpec,
)
from twmr.scenario.yamlread import Lines, read, read_file

#: where a key path (tuple of keys and 0-based list indices) was given
At = Callable[..., Location]


@lru_cache(maxsize=1)
def schema() -> dict[str, Any]:
    """The JSON Schema of scenario files (src/twmr/scenario/scenario.schema.json)."""
    text = resources.files("twmr.scenario").joinpath("scenario.schema.json").read_text()
    return json.loads(text)


def schema_problems(instance: Any, at: At, prefix: tuple[Any, ...] = (),
                    part: dict[str, Any] | None = None) -> list[Problem]:
    """Every way `instance` breaks the schema (or the `part` of it found at key path `prefix`),
    each located by `at(*key path)`. jsonschema words them; it is imported only when the quick
    check (`twmr.scenario.schemacheck`) finds one."""
    whole = schema()
    if conforms(instance, part if part is not None else whole, whole):
        return []
    import jsonschema

    validator = jsonschema.Draft202012Validator(part if part is not None else whole)
    problems: list[Problem] = []
    for err in sorted(validator.iter_errors(instance), key=lambda e: list(e.absolute_path)):
        path = (*prefix, *err.absolute_path)
        if err.validator == "additionalProperties":
            allowed = list(err.schema.get("properties", {}))
            for key in (k for k in err.instance if k not in allowed):
                problems.append(unknown_key(at(*path, key), str(key), allowed))
        elif err.validator == "required":
            problems.append(Problem(at(*path), f"{err.message}.", "add the missing key."))
        else:
            what = "/".join(str(p) for p in path) or "the file"
            desc = err.schema.get("description") if isinstance(err.schema, dict) else None
            problems.append(Problem(at(*path), f"{what}: {err.message}.",
                                    desc or "see src/twmr/scenario/scenario.schema.json."))
    return problems


def option_problems(algorithm: str, options: dict[str, Given[Any]], where: Location
                    ) -> list[Problem]:
    """What is wrong with the experiment's `options` (its keys beyond `EXPERIMENT_KEYS`) for
    `algorithm`: a key its schema does not have (an option of another algorithm, or a misspelt
    key), a value its schema refuses, a number that is not finite. Imports the algorithm (a
    registered one; an unknown name is reported elsewhere)."""
    from twmr.core.errors import CosimError
    from twmr.master.algorithm import options_schema
    from twmr.registry import ALGORITHMS, plugins

    if algorithm not in plugins(ALGORITHMS):
        return []
    try:
        schema = options_schema(algorithm)
    except CosimError as err:
        return [Problem(where, str(err))]
    problems: list[Problem] = []
    for key, g in options.items():
        if key not in schema:
            problems.append(_not_an_option(key, g.where, algorithm, schema))
        elif isinstance(g.value, float) and not math.isfinite(g.value):
            problems.append(Problem(g.where, f"'{key}' is {g.value}; it must be a finite "
                                    f"number.", f"give {key} as a finite number, or leave it "
                                    f"out for the default."))
        else:
            problems += schema_problems(g.value, lambda *_, w=g.where: w, ("experiment", key),
                                        schema[key])
    return problems


def _not_an_option(key: str, where: Location, name: str, schema: dict[str, Any]) -> Problem:
    """The problem of experiment key `key` that algorithm `name` does not read: an option of
    other algorithms, or a misspelt key."""
    from twmr.core.errors import CosimError
    from twmr.master.algorithm import options_schema
    from twmr.registry import ALGORITHMS, plugins

    owners = []
    for other in sorted(plugins(ALGORITHMS)):
        try:
            if other != name and key in options_schema(other):
                owners.append(other)
        except (CosimError, ImportError):
            continue
    if owners:
        return Problem(where, f"'{key}' applies to algorithm: {' or '.join(owners)} only, but "
                       f"the experiment's algorithm is '{name}'.",
                       f"set 'algorithm: {owners[0]}', or remove '{key}'.")
    known = [*EXPERIMENT_KEYS, *schema]
    has = f"the options {', '.join(schema)}" if schema else "no options of its own"
    return Problem(where, f"unknown experiment key '{key}'{suggest(key, known)} (algorithm "
                   f"'{name}' has {has}).", f"allowed here: {', '.join(known)}.")


def unknown_key(where: Location, key: str, allowed: list[str]) -> Problem:
    """The problem of a key the schema does not know here."""
    return Problem(where, f"unknown key '{key}'{suggest(key, allowed)}.",
                   f"allowed here: {', '.join(allowed)}.")


def _maybe(given: Any, *path: Any) -> Given[Any] | None:
    """The value at `path` as given, None when it is not written."""
    found = given(*path)
    return None if found.value is None else found


def _experiment_option_problems(data: dict[str, Any], at: At) -> list[Problem]:
    """`option_problems` of the experiment as written (its algorithm's name a text)."""
    exp = data.get("experiment")
    if not isinstance(exp, dict):
        return []
    options = {str(k): Given(v, at("experiment", k)) for k, v in exp.items()
               if k not in EXPERIMENT_KEYS}
    name = exp.get("algorithm", "gauss_seidel")
    if not options or not isinstance(name, str):
        return []
    return option_problems(name, options, at("experiment", "algorithm"))


def from_data(data: Any, lines: Lines, base_dir: Path) -> ScenarioSpec:
    """The structure of YAML-shaped data whose locations `lines` knows; ScenarioError listing
    every way it breaks the schema."""
    source = lines.source
    if not isinstance(data, dict):
        raise ScenarioError(Problem(Location(source, 1), "a scenario must be a mapping with "
                                    "'components:' and 'experiment:'.",
                                    "see docs/contracts.md for the format."))
    problems = schema_problems(data, lines.at) + _experiment_option_problems(data, lines.at)
    if "experiment" not in data and not data.keys() & {"inputs", "outputs"}:
        problems.append(Problem(Location(source, 1), "'experiment' is a required property.",
                                "add 'experiment: {stop: ..., step: ...}' (only a subsystem "
                                "file, one that exposes inputs: or outputs:, may leave it out)."))
    if problems:
        raise ScenarioError(problems)
    at = lines.at

    def given(*path: Any, default: Any = None) -> Given[Any]:
        node: Any = data
        for i, key in enumerate(path):
            missing = default if i == len(path) - 1 else None  # a section may be left out
            node = node.get(key, missing) if isinstance(node, dict) else \
                missing if node is None else node[key]
        return Given(node, at(*path), lines.texts.get(path))

    comps = {}
    for name, spec in data["components"].items():
        where = ("components", name)
        kind = given(*where, "kind")
        parameters = {k: given(*where, "parameters", k) for k in spec.get("parameters") or {}}
        initial = {k: given(*where, "initial", k) for k in spec.get("initial") or {}}
        inner = None
        if kind.value == "system":
            from twmr.scenario.include import subsystem

            inner = subsystem(name, parameters, initial, at(*where), source, base_dir)
            parameters, initial = {k: v for k, v in parameters.items() if k == "path"}, {}
        body = {k: given(*where, "body", k) for k in spec.get("body") or {}}
        comps[name] = ComponentSpec(
            name, kind, parameters, initial, given(*where, "step_multiple", default=1),
            at(*where), spec.get("description", ""), inner, body)
    e = ("experiment",)
    others = [k for k in data.get("experiment") or {} if k not in EXPERIMENT_KEYS]
    experiment = ExperimentSpec(given(*e, "start", default=0.0), given(*e, "stop"),
                                given(*e, "step"), given(*e, "algorithm", default="gauss_seidel"),
                                given(*e, "realtime"), at(*e),
                                **{k: given(*e, k) for k in ("fmu_terminate", "loops",
                                                              "loop_solver")},
                                options={str(k): given(*e, k) for k in others})
    exposed = {side: {n: _exposure(n, data[side][n], at, side) for n in data.get(side) or {}}
               for side in ("inputs", "outputs")}
    rec = data.get("record") or {}
    signals = None if rec.get("signals") is None else tuple(
        given("record", "signals", i) for i in range(len(rec["signals"])))
    record = RecordingSpec(signals, Given(rec.get("decimation", 1), at("record", "decimation")),
                           at("record"))
    return ScenarioSpec(
        source, base_dir, comps,
        tuple(given("connections", i) for i in range(len(data.get("connections") or []))),
        tuple(given("open", i) for i in range(len(data.get("open") or []))),
        experiment, record, data.get("description", ""),
        {key: at(key) for key in data}, exposed["inputs"], exposed["outputs"],
        tuple(EventSpec(given("events", i, "at"), _maybe(given, "events", i, "until"),
                        _maybe(given, "events", i, "port"), _maybe(given, "events", i, "fault"),
                        _maybe(given, "events", i, "value"), _maybe(given, "events", i, "seed"),
                        at("events", i), _maybe(given, "events", i, "set"),
                        *(_maybe(given, "events", i, key)
                          for key in ("when", "hysteresis", "duration", "name")))
              for i in range(len(data.get("events") or []))))


def _exposure(name: str, value: Any, at: At, side: str) -> Exposure:
    """An exposed port as written: 'comp.port' or {port: 'comp.port', unit: ...}."""
    if isinstance(value, str):
        return Exposure(name, Given(value, at(side, name)), None, at(side, name))
    unit = Given(value["unit"], at(side, name, "unit")) if "unit" in value else None
    return Exposure(name, Given(value["port"], at(side, name, "port")), unit, at(side, name))


def read_structure(source: str | dict[str, Any], name: str = "<string>",
                   base_dir: str | Path | None = None) -> ScenarioSpec:
    """The structure of a scenario given as YAML text, or as a dict of the same shape (located
    by key paths). `base_dir` (default: the working folder) is where relative paths start."""
    folder = Path(base_dir or Path.cwd())
    if isinstance(source, dict):
        return from_data(copy.deepcopy(source), Lines(name), folder)
    return from_data(*read(source, name), folder)


def load_yaml(path: Path) -> ScenarioSpec:
    """The structure of a YAML scenario file (relative paths start at its folder)."""
    return read_structure(read_file(path), str(path), path.resolve().parent)


def load_ssp(path: Path) -> ScenarioSpec:
    """The structure of an SSP archive, folder or .ssd file (`twmr.fmi.ssp`)."""
    from twmr.fmi.ssp import load_ssp as load

    return load(path)


def loader_of(path: str | Path) -> Callable[[Path], ScenarioSpec] | None:
    """The loader registered for the suffix of `path` (entry-point group `twmr.loaders`, named
    by the suffix without its dot; 'x.ssp#variant' has the suffix '.ssp'); a folder is an
    unpacked SSP; None: no loader claims it."""
    from twmr.registry import LOADERS, plugin, plugins

    path = Path(path)
    if path.is_dir():
        return load_ssp
    name = Path(path.name.split("#", 1)[0]).suffix.lower().lstrip(".")
    return plugin(LOADERS, name, "scenario format") if name in plugins(LOADERS) else None


def load_structure(path: str | Path) -> ScenarioSpec:
    """The structure of the scenario file at `path`, by the loader of its suffix (YAML for a
    suffix no loader claims); a folder holding SystemStructure.ssd is an unpacked SSP."""
    path = Path(path)
    return (loader_of(path) or load_yaml)(path)
