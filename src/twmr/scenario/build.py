"""Scenario file -> `System`: read, validate against the JSON Schema, create and configure the
components, wire and check the graph. Every problem found is collected and reported together, each
with file:line, the component and port at fault, and a fix."""
from __future__ import annotations

import contextlib
import copy
import fnmatch
import itertools
import json
import math
import re
from collections.abc import Sequence
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import yaml

from twmr.core.component import Component
from twmr.core.errors import (
    AlgebraicLoopError,
    CosimError,
    Location,
    Problem,
    ScenarioError,
    UnitError,
    WiringError,
)
from twmr.core.port import TEXT_TYPES
from twmr.core.units import conversion, known_unit
from twmr.registry import kinds, lookup, suggest
from twmr.scenario.graph import describe_cycle, order, parse_end, wire
from twmr.scenario.system import Connection, Experiment, RecordSpec, System
from twmr.scenario.yamlread import Lines, read, read_file

#: the most base steps one run may take (1e9 steps: ~1.5 h at 5 us a step)
MAX_STEPS = 1e9
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z1][\w./-]*)\s*$")


@lru_cache(maxsize=1)
def schema() -> dict[str, Any]:
    """The JSON Schema of scenario files (src/twmr/scenario/scenario.schema.json)."""
    text = resources.files("twmr.scenario").joinpath("scenario.schema.json").read_text()
    return json.loads(text)


def load(path: str | Path, overrides: Sequence[str] = ()) -> System:
    """Build the System of the scenario file at `path` (with `--set` overrides)."""
    path = Path(path)
    return loads(read_file(path), str(path), path.resolve().parent, overrides)


def loads(text: str | dict[str, Any], source: str = "<string>",
          base_dir: str | Path | None = None, overrides: Sequence[str] = ()) -> System:
    """Build the System of a scenario given as YAML text, or as a dict of the same shape.
    Raises a `CosimError` subclass."""
    try:
        return _Builder(text, source, Path(base_dir or Path.cwd()), overrides).build()
    except CosimError:
        raise
    except RecursionError:
        raise ScenarioError(Problem(Location(source), "the scenario is nested too deeply to "
                                    "read.", "flatten the YAML structure.")) from None
    except Exception as exc:  # noqa: BLE001 - a loader bug must still read as a scenario error
        raise ScenarioError(Problem(Location(source), f"cannot build the scenario "
                                    f"({type(exc).__name__}: {exc}).",
                                    "check the file against `twmr check`; report this if the "
                                    "file looks right.")) from exc


class _Builder:
    def __init__(self, text: str | dict[str, Any], source: str, base_dir: Path,
                 overrides: Sequence[str]):
        self.source = source
        self.base_dir = base_dir
        self.overrides = list(overrides)
        if isinstance(text, dict):
            self.data, self.lines = copy.deepcopy(text), Lines(source)
        else:
            self.data, self.lines = read(text, source)
        self.problems: list[Problem] = []
        self.overridden: dict[tuple[Any, ...], str] = {}
        self.miswired: set[tuple[str, str]] = set()  # inputs of wires refused

    def at(self, *path: Any) -> Location:
        for n in range(len(path), 0, -1):
            if path[:n] in self.overridden:
                return Location("--set", 0, self.overridden[path[:n]])
        return self.lines.at(*path)

    def fail_if_problems(self, kind: type[ScenarioError] = ScenarioError) -> None:
        if self.problems:
            raise kind(self.problems)

    # -- the steps -----------------------------------------------------------------------------
    def build(self) -> System:
        if not isinstance(self.data, dict):
            raise ScenarioError(Problem(Location(self.source, 1), "a scenario must be a mapping "
                                        "with 'components:' and 'experiment:'.",
                                        "see docs/contracts.md for the format."))
        self.apply_overrides()
        self.validate()
        comps = self.components()
        experiment = self.experiment()
        self.fail_if_problems()
        conns = self.connections(comps)
        self.check_drivers(comps, conns)
        self.fail_if_problems(WiringError)
        exec_order, cycle = order(comps, conns)
        if cycle:
            wires = set(itertools.pairwise(cycle))
            loc = next((c.location for c in conns
                        if ((c.src, c.src_port), (c.dst, c.dst_port)) in wires),
                       self.at("connections"))
            raise AlgebraicLoopError(Problem(
                loc, f"algebraic loop: {describe_cycle(cycle)} — each output in this cycle "
                f"depends directly ('=>', declared by its block's `depends_on`) on the input "
                f"before it, so no order can compute them.",
                "break the loop with a `delay` component on one of these wires, or use a block "
                "whose output does not depend directly on its input (e.g. a state-space block "
                "with D = 0). A block may declare feedthrough conservatively: check that each "
                "'=>' output really reads that input at the same instant."))
        record = self.record(comps)
        self.fail_if_problems()
        multiples = {n: int(s.get("step_multiple", 1))
                     for n, s in self.data["components"].items()}
        return System(comps, conns, exec_order, experiment, record, multiples, self.source)

    def validate(self) -> None:
        validator = jsonschema.Draft202012Validator(schema())
        for err in sorted(validator.iter_errors(self.data), key=lambda e: list(e.absolute_path)):
            path = tuple(err.absolute_path)
            if err.validator == "additionalProperties":
                allowed = list(err.schema.get("properties", {}))
                extra = [k for k in err.instance if k not in allowed]
                for key in extra:
                    self.problems.append(Problem(
                        self.at(*path, key), f"unknown key '{key}'{suggest(str(key), allowed)}.",
                        f"allowed here: {', '.join(allowed)}."))
            elif err.validator == "required":
                self.problems.append(Problem(self.at(*path), f"{err.message}.",
                                             "add the missing key."))
            else:
                what = "/".join(str(p) for p in path) or "the file"
                self.problems.append(Problem(self.at(*path), f"{what}: {err.message}.",
                                             _schema_hint(err)))
        self.fail_if_problems()

    def apply_overrides(self) -> None:
        """`comp.name=value` sets a parameter (or an input/state's initial value) or the
        component's `step_multiple`; `experiment.name=value` an experiment setting."""
        comps = self.data.get("components")
        if not isinstance(comps, dict):
            return  # the schema check reports it
        for text in self.overrides:
            loc = Location("--set", 0, text)
            key, sep, value = str(text).partition("=")
            comp, dot, name = key.strip().partition(".")
            if not sep or not dot or not name:
                self.problems.append(Problem(loc, f"cannot read the override '{text}'.",
                                             "write component.parameter=value or "
                                             "experiment.stop=value."))
                continue
            try:
                parsed = yaml.safe_load(value)
            except yaml.YAMLError:
                parsed = value
            if comp == "experiment":
                if isinstance(parsed, str):
                    with contextlib.suppress(ValueError):
                        parsed = float(parsed)  # YAML 1.1 reads '1e-5' (no dot) as text
                exp = self.data.setdefault("experiment", {})
                if isinstance(exp, dict):
                    exp[name] = parsed
                    self.overridden[("experiment", name)] = text
                continue
            spec = comps.get(comp)
            if not isinstance(spec, dict):
                self.problems.append(Problem(loc, f"no component '{comp}'"
                                             f"{suggest(comp, list(comps))}.",
                                             "use a component name of the scenario, or "
                                             "'experiment'."))
                continue
            if name == "step_multiple":
                spec["step_multiple"] = parsed
                self.overridden[("components", comp, "step_multiple")] = text
                continue
            section = "parameters"
            try:
                var = lookup(spec["kind"]).declared().get(name)
                if var is not None and var.kind in ("state", "input"):
                    section = "initial"
            except Exception:  # noqa: BLE001 - unknown kinds are reported when components are built
                pass
            if not isinstance(spec.get(section), dict):
                spec[section] = {}
            spec[section][name] = parsed
            self.overridden[("components", comp, section, name)] = text

    def components(self) -> dict[str, Component]:
        comps: dict[str, Component] = {}
        for name, spec in self.data["components"].items():
            kind = spec["kind"]
            try:
                cls = lookup(kind)
            except KeyError:
                self.problems.append(Problem(
                    self.at("components", name, "kind"), f"component '{name}': unknown kind "
                    f"'{kind}'{suggest(kind, list(kinds()))}.",
                    f"use one of: {', '.join(sorted(kinds()))} (`twmr components` lists them)."))
                continue
            except ImportError as err:
                self.problems.append(Problem(self.at("components", name, "kind"),
                                             f"component '{name}': kind '{kind}' cannot be "
                                             f"loaded ({err}).", "install what it needs."))
                continue
            params = dict(spec.get("parameters") or {})
            construction = {k: params.pop(k) for k in cls.construction_parameters if k in params}
            try:
                comp = cls.create(name, self.base_dir, **construction)
            except CosimError as err:
                where = next((("components", name, "parameters", k) for k in construction),
                             ("components", name))
                self.problems.append(Problem(self.at(*where), str(err)))
                continue
            except (TypeError, ValueError, OSError) as err:
                self.problems.append(Problem(self.at("components", name),
                                             f"component '{name}' ({kind}) cannot be created: "
                                             f"{err}.", "check its parameters."))
                continue
            self.configure(comp, name, params, "parameters", ("parameter",))
            self.configure(comp, name, dict(spec.get("initial") or {}), "initial",
                           ("state", "input"))
            given = frozenset(params) | frozenset(construction)
            for key, message, fix in comp.check(given):
                where = ("components", name, "parameters", key) if key in given else \
                    ("components", name)
                self.problems.append(Problem(self.at(*where), f"component '{name}' ({kind}): "
                                             f"{message}", fix))
            comps[name] = comp
        return comps

    def configure(self, comp: Component, name: str, values: dict[str, Any], section: str,
                  allowed: tuple[str, ...]) -> None:
        for key, value in sorted(values.items(), key=lambda kv: kv[0] not in
                                 comp.sizing_parameters):
            loc = self.at("components", name, section, key)
            var = comp.variables.get(key)
            names = [n for n, v in comp.variables.items() if v.kind in allowed]
            if var is None:
                what = "parameter" if section == "parameters" else "state or input"
                self.problems.append(Problem(loc, f"component '{name}' ({type(comp).__name__}) "
                                             f"has no {what} '{key}'{suggest(str(key), names)}.",
                                             f"known: {', '.join(names) or '(none)'}."))
                continue
            if var.kind not in allowed:
                other = "initial" if section == "parameters" else "parameters"
                self.problems.append(Problem(loc, f"'{name}.{key}' is a {var.kind}; it is not set "
                                             f"under '{section}:'.",
                                             f"move it under '{other}:'."))
                continue
            try:
                comp.set_parameter(key, self.quantity(value, var, name, key))
            except (ValueError, TypeError, UnitError) as err:
                self.problems.append(Problem(
                    loc, f"component '{name}', {var.kind} '{key}' = {value!r}: {err}.",
                    f"give {_expected(var)}."))

    def quantity(self, value: Any, var: Any, comp: str, key: str) -> Any:
        """A number with a unit ('30 cm') converted to the variable's unit; other values as is."""
        if var.type in TEXT_TYPES or not isinstance(value, str):
            return value
        try:
            return float(value)  # YAML 1.1 reads '1e-4' (no dot) as text
        except ValueError:
            pass
        m = _QUANTITY.match(value)
        if not m:
            raise ValueError(f"cannot read '{value}' as a number with a unit")
        unit = known_unit(var.element_unit(0), var.unit_definitions)
        if unit is None:
            raise ValueError(f"its unit '{var.element_unit(0)}' is not one that can be converted "
                             f"to; give a plain number")
        gain, offset = conversion(m.group(2), unit)
        return float(m.group(1)) * gain + offset

    def experiment(self) -> Experiment:
        e = self.data["experiment"]
        start, stop, step = float(e.get("start", 0.0)), float(e["stop"]), float(e["step"])
        bad = [k for k, v in (("start", start), ("stop", stop), ("step", step))
               if not math.isfinite(v)]
        if bad:
            self.problems.append(Problem(self.at("experiment", bad[0]), f"{bad[0]} is "
                                         f"{e.get(bad[0])}; times must be finite numbers.",
                                         "give start, stop and step in seconds."))
        elif not step > 0:
            self.problems.append(Problem(self.at("experiment", "step"),
                                         f"the step must be > 0, not {step}.",
                                         "give a positive base step in seconds, e.g. 1.0e-3."))
        elif not stop > start:
            self.problems.append(Problem(self.at("experiment", "stop"), f"stop ({stop}) must be "
                                         f"after start ({start}).", "make stop > start."))
        else:
            n = (stop - start) / step
            if n > MAX_STEPS:
                self.problems.append(Problem(self.at("experiment", "stop"), f"(stop - start) / "
                                             f"step = {n:.3g} steps, more than the limit of "
                                             f"{MAX_STEPS:.0e}.", "shorten the run or take a "
                                             "larger step (see docs/limits.md)."))
            elif not math.isclose(n, round(n), rel_tol=1e-9, abs_tol=1e-9):
                self.problems.append(Problem(self.at("experiment", "step"), f"(stop - start) / "
                                             f"step = {n:.6g} is not a whole number of steps.",
                                             "choose a step that divides the duration."))
        return Experiment(start, stop, step, e.get("algorithm", "gauss_seidel"),
                          e.get("realtime"))

    def connections(self, comps: dict[str, Component]) -> list[Connection]:
        conns: list[Connection] = []
        for i, text in enumerate(self.data.get("connections") or []):
            loc = self.at("connections", i)
            left, _, right = text.partition("->")
            try:
                src, dst = parse_end(left), parse_end(right)
            except ValueError as err:
                self.problems.append(Problem(loc, f"cannot read the connection '{text}': {err}.",
                                             "write 'component.output -> component.input'."))
                continue
            made = wire(comps, src, dst, loc, self.problems)
            if not made:  # reported; its input is not reported again as unconnected
                self.miswired.add((dst.comp, dst.port))
            conns += made
        return conns

    def check_drivers(self, comps: dict[str, Component], conns: list[Connection]) -> None:
        driven: dict[tuple[str, str, int], Connection] = {}
        for c in conns:
            width = comps[c.dst].variables[c.dst_port].width
            for j in c.dst_index if c.dst_index is not None else range(width):
                key = (c.dst, c.dst_port, j)
                if key in driven:
                    first = driven[key]
                    self.problems.append(Problem(
                        c.location, f"input '{c.dst}.{c.dst_port}' is driven twice: by "
                        f"'{first}' ({first.location}) and by '{c}'.",
                        "keep one wire per input (add a `sum` block to combine signals)."))
                driven[key] = c
        opened: set[tuple[str, str]] = set()
        for i, text in enumerate(self.data.get("open") or []):
            loc = self.at("open", i)
            comp, _, port = str(text).partition(".")
            var = comps[comp].variables.get(port) if comp in comps else None
            if var is None or var.kind != "input":
                inputs = [n for n, v in comps[comp].inputs.items()] if comp in comps else []
                self.problems.append(Problem(loc, f"'{text}' in 'open:' is not an input"
                                             f"{suggest(port, inputs)}.",
                                             "list inputs as component.input."))
                continue
            opened.add((comp, port))
        for name, comp in comps.items():
            for port, var in comp.inputs.items():
                missing = [j for j in range(var.width) if (name, port, j) not in driven]
                if missing and (name, port) not in opened | self.miswired and not var.optional:
                    which = "" if len(missing) == var.width else \
                        f" (elements {', '.join(str(j + 1) for j in missing)})"
                    self.problems.append(Problem(
                        self.at("components", name), f"input '{name}.{port}'{which} is not "
                        f"connected.", f"wire an output to it ('x.y -> {name}.{port}'), or list "
                        f"'{name}.{port}' under 'open:' to keep its start value {var.start!r}."))

    def record(self, comps: dict[str, Component]) -> RecordSpec:
        spec = self.data.get("record") or {}
        everything = [(n, p) for n, c in comps.items() for p, v in c.variables.items()
                      if v.kind != "parameter" and v.type not in TEXT_TYPES]
        patterns = spec.get("signals")
        if patterns is None:
            chosen = [(n, p) for n, c in comps.items() for p, v in c.outputs.items()
                      if v.type not in TEXT_TYPES]
        else:
            chosen = []
            for i, pat in enumerate(patterns):
                hits = [s for s in everything if fnmatch.fnmatchcase(f"{s[0]}.{s[1]}", pat)]
                if not hits:
                    known = [f"{n}.{p}" for n, p in everything]
                    self.problems.append(Problem(self.at("record", "signals", i),
                                                 f"'{pat}' matches no port{suggest(pat, known)}.",
                                                 "record component.port, wildcards allowed "
                                                 "('ctrl.*')."))
                chosen += [h for h in hits if h not in chosen]
        return RecordSpec(tuple(chosen), int(spec.get("decimation", 1)))


def _expected(var: Any) -> str:
    size = "" if var.size is None else (" a list of values" if var.size == 0 else
                                        f" a list of {var.size} values")
    rng = ""
    if var.min is not None or var.max is not None:
        rng = f" within [{var.min if var.min is not None else '-inf'}, " \
              f"{var.max if var.max is not None else 'inf'}]"
    unit = f" in {var.unit_text}" if var.unit_text not in ("1", "") else ""
    return f"{var.type}{size}{unit}{rng}".replace("Real", "a number", 1)


def _schema_hint(err: jsonschema.ValidationError) -> str:
    desc = err.schema.get("description") if isinstance(err.schema, dict) else None
    return desc or "see src/twmr/scenario/scenario.schema.json."
