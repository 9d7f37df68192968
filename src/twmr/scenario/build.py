"""`ScenarioSpec` -> `System`: create and configure the components, wire and check the graph.

The loaders (`twmr.scenario.loaders`: YAML, a dict) make the spec and `--set` overrides
(`twmr.scenario.overrides`) change it; the builder only reads it. Every problem found is
collected and reported together, each with where it was given (file:line, or the `--set` text),
the component and port at fault, and a fix."""
from __future__ import annotations

import fnmatch
import itertools
import logging
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

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
from twmr.core.port import CLOCK, STRING, TEXT_TYPES
from twmr.core.units import conversion, known_unit
from twmr.registry import ALGORITHMS, kinds, lookup, plugins, suggest
from twmr.scenario.events import Change, Watch, insert_faults, parameter_changes
from twmr.scenario.flatten import Exposed, Flat, Wire, flatten
from twmr.scenario.graph import (
    Loop,
    describe_cycle,
    find_loops,
    find_port,
    order,
    parse_end,
    resolve_end,
    terminal_wires,
    wire,
)
from twmr.scenario.kinds import KindError, code_failure
from twmr.scenario.loaders import load_structure, option_problems, read_structure, schema
from twmr.scenario.overrides import OVERRIDE, SETTABLE, apply_overrides
from twmr.scenario.structure import ComponentSpec, Given, ScenarioSpec
from twmr.scenario.system import Connection, Experiment, LoopSolver, RecordSpec, System

log = logging.getLogger("twmr")

__all__ = ["MAX_STEPS", "build_system", "load", "loads", "reconfigure", "scenario_spec", "schema"]

#: the most base steps one run may take (1e9 steps: ~1.5 h at 5 us a step)
MAX_STEPS = 1e9
_NOUNS = {"Real": ("a number", "numbers"), "Integer": ("an integer", "integers"),
          "Boolean": ("true or false", "booleans")}
_NAMED = re.compile(r"^\s*([A-Za-z_][\w.]*)\.([A-Za-z_]\w*)")  # the port a wire's end names
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z1][\w./-]*)\s*$")


def load(path: str | Path, overrides: Sequence[str] = ()) -> System:
    """Build the System of the scenario file at `path` (with `--set` overrides)."""
    return build_system(guarded(str(path), lambda: apply_overrides(load_structure(path),
                                                                    overrides)))


def loads(text: str | dict[str, Any], source: str = "<string>",
          base_dir: str | Path | None = None, overrides: Sequence[str] = ()) -> System:
    """Build the System of a scenario given as YAML text, or as a dict of the same shape.
    Raises a `CosimError` subclass."""
    return build_system(scenario_spec(text, source, base_dir, overrides))


def scenario_spec(text: str | dict[str, Any] | ScenarioSpec, source: str = "<string>",
                        base_dir: str | Path | None = None, overrides: Sequence[str] = ()
                  ) -> ScenarioSpec:
    """The structure of a scenario given as YAML text, a dict or a structure already, with
    `--set` overrides applied. Raises a `CosimError` subclass."""
    if isinstance(text, ScenarioSpec):
        spec = text
        return guarded(spec.source, lambda: apply_overrides(spec, overrides))
    return guarded(source, lambda: apply_overrides(read_structure(text, source, base_dir),
                                                    overrides))


def build_system(spec: ScenarioSpec) -> System:
    """The System of a scenario's structure (subsystems flattened into blocks named by their
    path, `twmr.scenario.flatten`): components created and configured, wires checked, order
    found. Raises a `CosimError` subclass listing every problem."""
    return guarded(spec.source, lambda: _Builder(flatten(spec)).build())


def reconfigure(flat: ScenarioSpec, system: System, names: Sequence[str]) -> None:
    """Set again, on components `names` of `system` (built from a structure of the same shape,
    their values since restored to what the build gave them), the parameters and initial values
    that the flat structure `flat` gives them, checked as `build_system` checks them. Raises a
    `ScenarioError` listing every problem."""
    def run() -> None:
        builder = _Builder(Flat(flat))
        comps = {name: system.components[name] for name in names}
        for name, comp in comps.items():
            spec = flat.components[name]
            params = {k: v for k, v in spec.parameters.items()
                      if k not in comp.construction_parameters}
            builder.configure(comp, name, params, "parameters", ("parameter",))
            builder.configure(comp, name, spec.initial, "initial", ("state", "input"))
            builder.report(name, comp.check(frozenset(spec.parameters)))
        if not builder.problems:
            builder.check_steps(comps, system.experiment.step)
        builder.fail_if_problems()
    guarded(flat.source, run)


def guarded(source: str, make: Any) -> Any:
    """`make()`, with any failure that is not a CosimError reported as a ScenarioError."""
    try:
        return make()
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
    def __init__(self, flat: Flat):
        self.spec = flat.spec
        self.exposed = flat.exposed
        self.flat_problems = flat.problems
        self.problems: list[Problem] = []
        self.miswired: set[tuple[str, str]] = set(flat.miswired)  # inputs of wires refused
        self.broken: set[int] = set()  # ids of the exposures found wrong

    def fail_if_problems(self, kind: type[ScenarioError] = ScenarioError) -> None:
        if self.problems:
            raise kind(self.problems)

    # -- the steps -----------------------------------------------------------------------------
    def build(self) -> System:
        comps = self.components()
        experiment = self.experiment()
        if not self.problems:
            self.check_steps(comps, experiment.step)
            self.check_pace(comps, experiment)
        self.fail_if_problems()
        marks: list[Any] = []
        changes: list[Change] = []
        watches: list[Watch] = []
        if self.spec.events:
            changes, found, marks = parameter_changes(self.spec, comps, experiment)
            self.problems += found
            self.spec, found, faults, watches = insert_faults(self.spec, comps, experiment)
            self.problems += found
            marks = [*faults, *marks]
            self.fail_if_problems()
        self.problems += self.flat_problems
        self.check_exposed(comps)
        conns = self.connections(comps)
        self.check_drivers(comps, conns)
        self.fail_if_problems(WiringError)
        loops: list[Loop] = []
        if experiment.loops == "solve":
            loops = self.solvable_loops(comps, conns, experiment.algorithm)
            self.fail_if_problems(AlgebraicLoopError)
        exec_order, cycle = order(comps, conns, loops)
        if cycle and experiment.algorithm == "jacobi":
            # every input from the snapshot of the outputs after the step before: a
            # feedthrough cycle closes one step later, as libcosim and Ecos run it
            exec_order, cycle = list(comps), []
        if cycle:
            loc = self.cycle_location(cycle, conns)
            raise AlgebraicLoopError(Problem(
                loc, f"algebraic loop: {describe_cycle(cycle)} — each output in this cycle "
                f"depends directly ('=>', declared by its block's `depends_on`) on the input "
                f"before it, so no order can compute them.",
                "break the loop with a `delay` component on one of these wires, use a block "
                "whose output does not depend directly on its input (e.g. a state-space block "
                "with D = 0), or let the master iterate it ('loops: solve' under 'experiment:', "
                "docs/algorithms.md). A block may declare feedthrough conservatively: check "
                "that each '=>' output really reads that input at the same instant."))
        record = self.record(comps)
        bodies = self.bodies(comps)
        self.fail_if_problems()
        multiples = {n: int(c.step_multiple.value) for n, c in self.spec.components.items()}
        return System(comps, conns, exec_order, experiment, record, multiples, self.spec.source,
                      events=tuple(marks), changes=tuple(changes), bodies=bodies,
                      watches=tuple(watches))

    def cycle_location(self, cycle: list[tuple[str, str]], conns: list[Connection]) -> Location:
        """Where the first wire of `cycle` (a closed walk of ports) is written."""
        wires = set(itertools.pairwise(cycle))
        return next((c.location for c in conns
                     if ((c.src, c.src_port), (c.dst, c.dst_port)) in wires),
                    self.spec.at("connections"))

    def solvable_loops(self, comps: dict[str, Component], conns: list[Connection],
                       algorithm: str) -> list[Loop]:
        """The loops `loops: solve` iterates (`find_loops`), after a problem for each that cannot
        be: one through no Real input, one under Jacobi, one whose blocks differ in
        step_multiple."""
        loops, stuck = find_loops(comps, conns)
        for cycle in stuck:
            self.problems.append(Problem(
                self.cycle_location(cycle, conns), f"algebraic loop: {describe_cycle(cycle)} "
                f"passes through no Real input, so the master cannot iterate it (the unknowns "
                f"of the iteration are Real inputs).", "break the loop with a `delay` "
                "component on one of these wires."))
        where = self.spec.experiment.loops
        at = where.where if where is not None else self.spec.at("experiment")
        if loops and algorithm == "jacobi":
            log.warning("note: %s: under jacobi every input is taken from the outputs of the "
                        "step before, so the loop through %s closes one step later and needs "
                        "no solving; 'loops: solve' has nothing to do (use gauss_seidel or "
                        "adaptive to solve it at each point).", at,
                        ", ".join(loops[0].components))
            return []
        for lp in loops:
            multiples = {n: int(self.spec.components[n].step_multiple.value)
                         for n in lp.components}
            if len(set(multiples.values())) > 1:
                self.problems.append(Problem(
                    at, f"the algebraic loop through {', '.join(lp.components)} mixes step "
                    f"multiples ({', '.join(f'{n}: {m}' for n, m in multiples.items())}); a "
                    f"loop is solved at the points where all its blocks sample their inputs.",
                    "give the loop's blocks one step_multiple."))
        return loops

    def components(self) -> dict[str, Component]:
        comps: dict[str, Component] = {}
        for name, spec in self.spec.components.items():
            cls = self.kind_class(spec)
            if cls is None:
                continue
            kind = spec.kind.value
            params = dict(spec.parameters)
            construction = {k: params.pop(k) for k in cls.construction_parameters if k in params}
            try:
                comp = cls.create(name, self.spec.base_dir,
                                  **{k: _as_given(v, getattr(cls, k, None))
                                     for k, v in construction.items()})
            except CosimError as err:
                where = next((v.where for v in construction.values()), spec.where)
                self.problems.append(Problem(where, str(err)))
                continue
            except (TypeError, ValueError, OSError) as err:
                self.problems.append(Problem(spec.where, f"component '{name}' ({kind}) cannot be "
                                             f"created: {err}.", "check its parameters."))
                continue
            except Exception as err:  # noqa: BLE001 - a user block's own code
                failure = code_failure(err, f"creating {cls.__qualname__}", _file_of(cls))
                self.problems.append(Problem(spec.where, f"component '{name}' ({kind}) cannot "
                                             f"be created: {failure.message}", failure.fix))
                continue
            self.configure(comp, name, params, "parameters", ("parameter",))
            self.configure(comp, name, spec.initial, "initial", ("state", "input"))
            given = frozenset(params) | frozenset(construction)
            self.report(name, comp.check(given))
            comps[name] = comp
        for name, comp in comps.items():
            self.report(name, comp.check_peers(comps))
        return comps

    def report(self, name: str, problems: list[tuple[str, str, str]]) -> None:
        """`Component.check`-style problems of component `name`, each at the parameter at fault
        when the scenario sets it."""
        spec = self.spec.components[name]
        for key, message, fix in problems:
            where = spec.parameters[key].where if key in spec.parameters else spec.where
            self.problems.append(Problem(where, f"component '{name}' ({spec.kind.value}): "
                                         f"{message}", fix))

    def check_steps(self, comps: dict[str, Component], step: float) -> None:
        """Each component's problems with its step (the base step times its step_multiple)."""
        for name, comp in comps.items():
            multiple = self.spec.components[name].step_multiple
            h = step * int(multiple.value)
            self.report(name, comp.check_step(h))
            clocks = [n for n, v in comp.variables.items() if v.type == CLOCK]
            if clocks and int(multiple.value) != 1:
                self.problems.append(Problem(multiple.where, f"component '{name}' has clocks "
                                             f"({', '.join(clocks[:3])}) and step_multiple "
                                             f"{multiple.value}: a tick lasts one base step, so "
                                             f"the others would see it {multiple.value} times.",
                                             "remove step_multiple from this component (its "
                                             "events happen at their own times anyway)."))

    def kind_class(self, spec: ComponentSpec) -> type[Component] | None:
        """The class of a component's kind, or None after adding the problem."""
        kind, name = spec.kind.value, spec.name
        try:
            cls: type[Component] = lookup(kind, self.spec.base_dir)
        except KindError as err:
            self.problems.append(Problem(spec.kind.where, f"component '{name}' (kind "
                                         f"'{kind}'): {err.message}", err.fix))
            return None
        except KeyError:
            self.problems.append(Problem(
                spec.kind.where, f"component '{name}': unknown kind "
                f"'{kind}'{suggest(kind, [*kinds(), 'system'])}.",
                f"use one of: {', '.join(sorted(kinds()))} (`twmr components` lists them), or "
                f"a class of your own: 'my_block.py:MyBlock' (a file next to the scenario) or "
                f"'package.module:MyBlock', or 'system' with 'parameters: {{path: file.yaml}}' "
                f"(another scenario file as a block, docs/systems.md)."))
            return None
        except ImportError as err:
            from twmr.core.extras import missing

            extra = missing(err, f"kind '{kind}'")
            fix = str(extra).partition("Fix: ")[2] if extra else "install what it needs."
            self.problems.append(Problem(spec.kind.where, f"component '{name}': kind '{kind}' "
                                         f"cannot be loaded ({err}).", fix))
            return None
        return cls

    def configure(self, comp: Component, name: str, values: dict[str, Given[Any]],
                  section: str, allowed: tuple[str, ...]) -> None:
        # sizing parameters first, elements ('pose[1]') after the whole values they change
        for key, given in sorted(values.items(), key=lambda kv: (kv[0] not in
                                 comp.sizing_parameters, "[" in kv[0])):
            loc, value = given.where, _as_given(given, comp.variables.get(key))
            element = _ELEMENT_KEY.match(key)
            if element and element["name"] in comp.variables:
                self.configure_element(comp, name, element["name"], int(element["index"]),
                                       given, section, allowed)
                continue
            var = comp.variables.get(key)
            base = comp.aliases.get(key)
            if base is not None:
                also = f" ('{base}' is set as well)" if base in values else ""
                self.problems.append(Problem(loc, f"component '{name}': '{key}' is an alias of "
                                             f"'{base}'{also}: one variable of the FMU under "
                                             f"two names, which is set only as '{base}'.",
                                             f"set '{base}' only (and drop '{key}')."))
                continue
            if var is None:
                known_as = comp.unknown_parameter(str(key))
                if known_as is not None:
                    self.problems.append(Problem(loc, f"component '{name}' "
                                                 f"({type(comp).__name__}): {known_as[0]}",
                                                 known_as[1]))
                    continue
                names = [n for n, v in comp.variables.items() if v.kind in allowed]
                what = "parameter" if section == "parameters" else "state or input"
                self.problems.append(Problem(loc, f"component '{name}' ({type(comp).__name__}) "
                                             f"has no {what} '{key}'{suggest(str(key), names)}.",
                                             f"known: {', '.join(names) or '(none)'}."))
                continue
            if var.kind not in SETTABLE:
                names = [n for n, v in comp.variables.items() if v.kind in allowed]
                self.problems.append(Problem(loc, f"'{name}.{key}' is an {var.kind}: the "
                                             f"component computes it; nothing sets it.",
                                             f"set a parameter, or the start value of a state "
                                             f"or an input (here: {', '.join(names[:8])}"
                                             f"{', ...' if len(names) > 8 else ''})."))
                continue
            if var.kind not in allowed and not (loc.file == OVERRIDE and var.kind in SETTABLE):
                other = "initial" if section == "parameters" else "parameters"
                self.problems.append(Problem(loc, f"'{name}.{key}' is {_a(var.kind)}; it is not "
                                             f"set under '{section}:'.",
                                             f"move it under '{other}:'."))
                continue
            try:
                comp.set_parameter(key, _value(value, var))
            except (ValueError, TypeError, UnitError) as err:
                self.problems.append(Problem(
                    loc, f"component '{name}', {var.kind} '{key}' = {value!r}: {err}.",
                    f"give {_expected(var)}."))

    def configure_element(self, comp: Component, name: str, key: str, index: int,
                          given: Given[Any], section: str, allowed: tuple[str, ...]) -> None:
        """Element `index` (1-based) of vector `key` set to the given value, the others kept."""
        var = comp.variables[key]
        where = f"'{name}.{key}[{index}]'"
        if var.kind not in allowed and not (given.where.file == OVERRIDE and
                                            var.kind in SETTABLE):
            self.problems.append(Problem(given.where, f"{where}: '{key}' is {_a(var.kind)}; it "
                                         f"is not set under '{section}:'.",
                                         "set a parameter, a state or an input."))
            return
        current = comp.get(key)
        if not isinstance(current, tuple) or not 1 <= index <= len(current):
            size = len(current) if isinstance(current, tuple) else 0
            self.problems.append(Problem(
                given.where, f"{where}: '{name}.{key}' has "
                f"{f'{size} elements' if size else 'no elements (a scalar)'}.",
                f"index from 1 to {size}." if size else f"set {name}.{key}=value."))
            return
        try:
            values = list(current)
            values[index - 1] = _quantity(given.value, var, index - 1)
            comp.set_parameter(key, values)
        except (ValueError, TypeError, UnitError) as err:
            self.problems.append(Problem(given.where, f"component '{name}', {where} = "
                                         f"{given.value!r}: {err}.", "give a number."))

    def experiment(self) -> Experiment:
        e = self.spec.experiment
        times = {"start": e.start, "stop": e.stop, "step": e.step}
        if e.stop.value is None or e.step.value is None:
            self.problems.append(Problem(e.where, f"{self.spec.source} has no 'experiment:' "
                                         f"(it is a subsystem: it exposes ports), so it does not "
                                         f"run on its own.", "include it from a scenario with "
                                         "'kind: system', or give it 'experiment: {stop: ..., "
                                         "step: ...}'."))
            return Experiment()
        start, stop, step = (float(g.value) for g in times.values())
        bad = [k for k, v in (("start", start), ("stop", stop), ("step", step))
               if not math.isfinite(v)]
        if bad:
            self.problems.append(Problem(times[bad[0]].where, f"{bad[0]} is "
                                         f"{times[bad[0]].value}; times must be finite numbers.",
                                         "give start, stop and step in seconds."))
        elif not step > 0:
            self.problems.append(Problem(e.step.where, f"the step must be > 0, not {step}.",
                                         "give a positive base step in seconds, e.g. 1.0e-3."))
        elif not stop > start:
            self.problems.append(Problem(e.stop.where, f"stop ({stop}) must be after start "
                                         f"({start}).", "make stop > start."))
        else:
            n = (stop - start) / step
            if round(n) < 1:
                self.problems.append(Problem(e.step.where, f"the step ({step:g} s) is longer "
                                             f"than the run ({stop - start:g} s): no step "
                                             f"would be taken.", "give a step that divides "
                                             "the duration, e.g. (stop - start) / 1000."))
            elif n > MAX_STEPS:
                self.problems.append(Problem(e.stop.where, f"(stop - start) / step = {n:.3g} "
                                             f"steps, more than the limit of {MAX_STEPS:.0e}.",
                                             "shorten the run or take a larger step (see "
                                             "docs/limits.md)."))
            elif not math.isclose(n, round(n), rel_tol=1e-9, abs_tol=1e-9):
                self.problems.append(Problem(e.step.where, f"(stop - start) / step = {n:.6g} is "
                                             f"not a whole number of steps.",
                                             "choose a step that divides the duration."))
        known = plugins(ALGORITHMS)
        if e.algorithm.value not in known:
            self.problems.append(Problem(e.algorithm.where, f"unknown master algorithm "
                                         f"'{e.algorithm.value}'"
                                         f"{suggest(str(e.algorithm.value), known)}.",
                                         f"use one of: {', '.join(sorted(known))} (the "
                                         f"'twmr.algorithms' entry points)."))
        ending = e.fmu_terminate.value if e.fmu_terminate is not None else None
        return Experiment(start, stop, step, e.algorithm.value, e.realtime.value,
                          options=self.algorithm_options(step, stop - start),
                          fmu_terminate=ending or "error", **self.loop_options())

    def check_pace(self, comps: dict[str, Component], experiment: Experiment) -> None:
        """A real-time factor is a finite positive number, and 1 with hardware in the loop (its
        drives run on the wall clock)."""
        given = experiment.realtime
        if given is None or isinstance(given, bool):
            return
        where = self.spec.experiment.realtime.where
        if not math.isfinite(given):
            self.problems.append(Problem(where, f"realtime: {given} is no real-time factor.",
                                         "give a finite factor (2: twice as fast as the wall "
                                         "clock), true or false."))
            return
        hardware = [n for n, c in comps.items() if c.needs_realtime]
        if hardware and given != 1:
            self.problems.append(Problem(where, f"realtime: {given:g} with hardware in the loop "
                                         f"({', '.join(hardware[:3])}), which runs on the wall "
                                         f"clock.", "give realtime: true (a factor of 1), or "
                                         "run without the hardware."))

    def loop_options(self) -> dict[str, Any]:
        """The experiment's `loops` and `loop_solver` (the schema checked their values;
        `loop_solver` needs `loops: solve`)."""
        e = self.spec.experiment
        loops = e.loops.value if e.loops is not None and e.loops.value is not None else "refuse"
        given = e.loop_solver.value if e.loop_solver is not None else None
        if not given:
            return {"loops": loops}
        assert e.loop_solver is not None
        if loops != "solve":
            self.problems.append(Problem(e.loop_solver.where, "'loop_solver' applies to "
                                         "'loops: solve' only, but algebraic loops are "
                                         "refused.", "set 'loops: solve', or remove "
                                         "'loop_solver'."))
            return {"loops": loops}
        for key, value in given.items():
            if isinstance(value, float) and not math.isfinite(value):
                self.problems.append(Problem(e.loop_solver.where, f"loop_solver '{key}' is "
                                             f"{value}; it must be a finite number.",
                                             f"give {key} as a number, or leave it out for "
                                             f"the default."))
                return {"loops": loops}
        return {"loops": loops, "loop_solver": LoopSolver(**given)}

    def algorithm_options(self, step: float, duration: float) -> dict[str, Any]:
        """The experiment's keys beyond the common ones (`EXPERIMENT_KEYS`) as options of its
        algorithm: each a key of the algorithm's own schema and valid by it
        (`option_problems`), then read by the algorithm (`twmr.master.algorithm.read_options`:
        defaults, checks across keys)."""
        from twmr.master.algorithm import OptionError, read_options

        e = self.spec.experiment
        given = {k: g for k, g in e.options.items() if g.value is not None}
        name = e.algorithm.value
        if not given or name not in plugins(ALGORITHMS):
            return {}
        found = option_problems(name, given, e.algorithm.where)
        if found:
            self.problems += found
            return {}
        try:
            return read_options(name, {k: g.value for k, g in given.items()}, step, duration)
        except OptionError as err:
            where = given[err.key].where if err.key in given else e.where
            self.problems.append(Problem(where, err.what, err.fix))
            return {}

    def check_exposed(self, comps: dict[str, Component]) -> None:
        """Every exposed port names an inner port of its side, with a declared unit that
        converts to the inner port's (one per element when a list)."""
        for ex in self.exposed:
            where, kind = ex.via.exposure.port.where, "input" if ex.side == "dst" else "output"
            what = f"exposed {kind} '{ex.via.path}' ({ex.via.exposure.port.value})"
            found: list[Problem] = []
            var = find_port(comps, ex.end, where, found)
            if var is not None and (var.kind == "input") != (kind == "input"):
                other = "outputs" if kind == "input" else "inputs"
                found.append(Problem(where, f"'{ex.end.text}' is {_article(var.kind)} "
                                     f"{var.kind}, not an {kind}.",
                                     f"expose it under '{other}:', or name an {kind} here."))
            elif var is not None and ex.via.exposure.unit is not None:
                found += self.exposed_units(ex, var, ex.via.exposure.unit)
            for p in found:
                self.problems.append(Problem(p.location, f"{what}: {p.message}", p.hint))
            if found:
                self.broken.add(id(ex.via.exposure))

    def exposed_units(self, ex: Exposed, var: Any, unit: Given[Any]) -> list[Problem]:
        """The problems of an exposed port's declared `unit` (one, or one per element) against
        the inner port's."""
        where = unit.where
        elements = ex.end.index if ex.end.index is not None else tuple(range(var.width))
        if isinstance(unit.value, list) and len(unit.value) != len(elements):
            return [Problem(where, f"{len(unit.value)} unit(s) declared for "
                            f"{len(elements)} element(s) of '{ex.end.text}'.",
                            f"give one unit for all, or a list of {len(elements)}.")]
        problems: list[Problem] = []
        for k, i in enumerate(elements):
            inner, outer = var.element_unit(i), ex.via.unit(k)
            if not inner or inner == outer:
                continue
            a, b = known_unit(outer), known_unit(inner, var.unit_definitions)
            try:
                if a is None or b is None:
                    raise UnitError(outer)
                conversion(a, b)
            except UnitError:
                problems.append(Problem(where, f"declared unit '{outer}' (element {k + 1}) "
                                        f"cannot be converted to '{inner}' of "
                                        f"'{ex.end.text}'.", f"declare '{inner}' or a unit of "
                                        f"the same quantity."))
                break
        return problems

    def connections(self, comps: dict[str, Component]) -> list[Connection]:
        conns: list[Connection] = []
        for given in self.spec.connections:
            loc, text = given.where, given.value
            left, _, right = text.partition("->")
            try:
                src, dst = parse_end(left), parse_end(right)
            except ValueError as err:
                self.problems.append(Problem(loc, f"cannot read the connection '{text}': {err}.",
                                             "write 'component.output -> component.input', "
                                             "an element selection 1-based within the port's "
                                             "size: 'plant.pose[1:2] -> ctrl.xy'."))
                named = _NAMED.match(right)
                if named:  # reported; its input is not reported again as unconnected
                    self.miswired.add((named.group(1), named.group(2)))
                continue
            src_via, dst_via = (given.src_via, given.dst_via) if isinstance(given, Wire) \
                else ((), ())
            if any(id(v.exposure) in self.broken for v in (*src_via, *dst_via)):
                self.miswired.add((dst.comp, dst.port))  # reported where it is exposed
                continue
            src, dst = resolve_end(comps, src), resolve_end(comps, dst)
            members = terminal_wires(comps, src, dst, loc, self.problems)
            if members is not None:
                for a, b in members:
                    made = wire(comps, a, b, loc, self.problems, src_via, dst_via)
                    if not made:
                        self.miswired.add((b.comp, b.port))
                    conns += made
                continue
            made = wire(comps, src, dst, loc, self.problems, src_via, dst_via)
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
        opened = self.opened(comps)
        for name, comp in comps.items():
            for port, var in comp.inputs.items():
                missing = [j for j in range(var.width) if (name, port, j) not in driven
                           and (name, port, j) not in opened]
                if missing and (name, port) not in self.miswired and not var.optional:
                    which = "" if len(missing) == var.width else \
                        f" (elements {', '.join(str(j + 1) for j in missing)})"
                    self.problems.append(Problem(
                        self.spec.components[name].where, f"input '{name}.{port}'{which} is not "
                        f"connected.", f"wire an output to it ('x.y -> {name}.{port}'), or list "
                        f"'{name}.{port}' under 'open:' to keep its start value "
                        f"{comp.get(port)!r}."))

    def opened(self, comps: dict[str, Component]) -> set[tuple[str, str, int]]:
        """The input elements `open:` keeps at their start values: entries `comp.input`,
        wildcards (`ft.*`, `*.u`) and elements (`lag.u[3]`, `lag.u[1,3]`)."""
        opened: set[tuple[str, str, int]] = set()
        every = [(f"{n}.{p}", n, p, v) for n, c in comps.items() for p, v in c.inputs.items()]
        by_name = {full: (n, p, v) for full, n, p, v in every}
        for given in self.spec.open:
            text = str(given.value).strip()
            m = _OPEN.match(text)
            pattern, chosen = (m["pattern"], m["elements"]) if m else (text, None)
            if not _WILD.search(pattern):  # one input by its name
                matched = [by_name[pattern]] if pattern in by_name else []
            else:  # a wildcard, translated once and matched against every input
                match = re.compile(fnmatch.translate(pattern)).match
                matched = [(n, p, v) for full, n, p, v in every if match(full)]
            if not matched:
                owner, _, port = pattern.rpartition(".")
                inputs = list(comps[owner].inputs) if owner in comps else []
                self.problems.append(Problem(given.where, f"'{text}' in 'open:' is no input"
                                             f"{suggest(port, inputs)}.",
                                             "list inputs as component.input, with wildcards "
                                             "(ft.*) or elements (lag.u[3]) if needed."))
                continue
            for n, p, v in matched:
                indices = range(v.width) if chosen is None else \
                    [int(i) - 1 for i in chosen.split(",")]
                bad = [i + 1 for i in indices if not 0 <= i < v.width]
                if bad:
                    self.problems.append(Problem(given.where, f"'{text}' in 'open:': '{n}.{p}' "
                                                 f"has {v.width} element(s), not {bad[0]}.",
                                                 f"index from 1 to {v.width}."))
                    continue
                opened |= {(n, p, i) for i in indices}
        return opened

    def bodies(self, comps: dict[str, Component]) -> dict[str, dict[str, float]]:
        """The vehicles the scenario describes (`body:`), by pose port ('plant.pose'), each
        dimension not given from its defaults; a port that is no output of 3 elements is a
        problem at its line."""
        found: dict[str, dict[str, float]] = {}
        for name, spec in self.spec.components.items():
            comp = comps.get(name)
            if comp is None:
                continue
            for port, given in spec.body.items():
                var = comp.variables.get(port)
                if var is None or var.kind not in ("output", "state") or var.width != 3:
                    poses = [n for n, v in comp.variables.items()
                             if v.kind in ("output", "state") and v.width == 3]
                    self.problems.append(Problem(
                        given.where, f"component '{name}' ({spec.kind.value}): body: '{port}' "
                        f"is not a planar pose it outputs (x, y, heading: an output of 3 "
                        f"elements).", f"name one of its outputs of 3 elements "
                        f"({', '.join(poses) or 'it has none'})."))
                    continue
                dims = {k: float(v) for k, v in given.value.items()}
                r, b = dims["wheel_radius"], dims["half_track"]
                found[f"{name}.{port}"] = {"wheel_radius": r, "half_track": b,
                                           "length": dims.get("length", 2.0 * b),
                                           "width": dims.get("width", 1.6 * b),
                                           "height": dims.get("height", r),
                                           "ahead": dims.get("ahead", 0.0)}
        return found

    def record(self, comps: dict[str, Component]) -> RecordSpec:
        spec = self.spec.record
        everything = [(n, p) for n, c in comps.items() for p, v in c.variables.items()
                      if v.kind != "parameter" and v.type != STRING]  # Binary: at its ticks
        if spec.signals is None:
            chosen = [(n, p) for n, c in comps.items() for p, v in c.outputs.items()
                      if v.type not in TEXT_TYPES]
        else:
            chosen = []
            for given in spec.signals:
                pat = given.value
                hits = [s for s in everything if fnmatch.fnmatchcase(f"{s[0]}.{s[1]}", pat)]
                text = [f"{n}.{p}" for n, c in comps.items() for p, v in c.variables.items()
                        if v.type == STRING and fnmatch.fnmatchcase(f"{n}.{p}", pat)]
                if not hits and text:
                    self.problems.append(Problem(given.where, f"'{pat}' names String port(s) "
                                                 f"{', '.join(text)}, which are not recorded "
                                                 f"(numbers, clocks and Binary ports are).",
                                                 "leave it out of 'record: signals', or record "
                                                 "a numeric output that carries it."))
                elif not hits:
                    known = [f"{n}.{p}" for n, p in everything]
                    self.problems.append(Problem(given.where,
                                                 f"'{pat}' matches no port{suggest(pat, known)}.",
                                                 "record component.port, wildcards allowed "
                                                 "('ctrl.*')."))
                chosen += [h for h in hits if h not in chosen]
        return RecordSpec(tuple(chosen), int(spec.decimation.value))


#: the characters that make an fnmatch pattern more than a name
_WILD = re.compile(r"[*?\[]")
_OPEN = re.compile(r"^(?P<pattern>[^\[\]]+?)\s*(?:\[(?P<elements>[\d,\s]+)\])?$")
_ELEMENT_KEY = re.compile(r"^(?P<name>\w+)\[(?P<index>\d+)\]$")


def _as_given(given: Given[Any], var: Any) -> Any:
    """The value of `given` for variable `var`: the text as written for a String variable."""
    if given.text is not None and getattr(var, "type", None) == STRING:
        return given.text
    return given.value


def _value(value: Any, var: Any) -> Any:
    """A number with a unit ('30 cm') converted to the variable's unit, also as the elements
    of a list (each to its element's unit); other values as they are."""
    if isinstance(value, list) and var.size is not None:
        return [_quantity(v, var, i if var.size else 0) for i, v in enumerate(value)]
    return _quantity(value, var, 0)


def _quantity(value: Any, var: Any, index: int) -> Any:
    """One value: text such as '30 cm' converted to the unit of element `index`."""
    if var.type in TEXT_TYPES or not isinstance(value, str):
        return value
    try:
        return float(value)  # YAML 1.1 reads '1e-4' (no dot) as text
    except ValueError:
        pass
    m = _QUANTITY.match(value)
    if not m:
        raise ValueError(f"cannot read '{value}' as a number with a unit")
    unit = known_unit(var.element_unit(index), var.unit_definitions)
    if unit is None:
        raise ValueError(f"its unit '{var.element_unit(index)}' is not one that can be "
                         f"converted to; give a plain number")
    gain, offset = conversion(m.group(2), unit)
    return float(m.group(1)) * gain + offset


def _article(word: str) -> str:
    return "an" if word[0] in "aeiou" else "a"


def _file_of(cls: type) -> Path | None:
    """The source file of a class's module, if it has one."""
    file = getattr(sys.modules.get(cls.__module__), "__file__", None)
    return Path(file) if file else None


def _expected(var: Any) -> str:
    """What a value of `var` must be, e.g. 'a list of 3 numbers in (m, m, rad) within [0, inf]'."""
    one, many = _NOUNS.get(var.type, (f"a {var.type}", f"{var.type} values"))
    what = one if var.size is None else f"a list of {f'{var.size} ' if var.size else ''}{many}"
    rng = ""
    if var.min is not None or var.max is not None:
        rng = f" within [{var.min if var.min is not None else '-inf'}, " \
              f"{var.max if var.max is not None else 'inf'}]"
    unit = f" in {var.unit_text}" if var.unit_text not in ("1", "") else ""
    return f"{what}{unit}{rng}"


def _a(word: str) -> str:
    """`word` with its indefinite article: 'an input', 'a state'."""
    return f"{'an' if word[:1] in 'aeiou' else 'a'} {word}"
