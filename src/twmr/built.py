"""`Built`: a scenario built once and run again with other values, without reading or building it
anew (`twmr.build`).

    built = twmr.build("scenarios/paper_trajectory1_asmc.yaml")
    for k in (10, 20, 40):
        result = built.run({"ctrl.k": k})        # or ["ctrl.k=20"], the `--set` form

A run's values are overrides of the scenario as built (each run starts from it, not from the
previous run). When they change only parameter and initial values of blocks, the components
built the first time are set back to the values the build gave them and given the new ones,
checked as a build checks them; anything else (the experiment, a step multiple, a kind, a value
that sizes ports, a block made from a file such as an FMU) builds the system anew from the
structure read at the start. Either way the rows are those of a fresh `twmr.load` + `simulate`
with the same overrides.
"""
from __future__ import annotations

import copy
import json
from collections.abc import Mapping, Sequence
from typing import Any

from twmr.api import Result, Scenario, simulate
from twmr.core.component import Component, plain
from twmr.scenario.structure import ScenarioSpec
from twmr.scenario.system import System

#: a component's Python calls of its kernel, kept across runs (its `setup` resets them)
_KEPT = ("_kernel_calls",)


def _snapshot(comp: Component) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The component's attributes as built: (immutable values, values a run may change in
    place, copied), or None when it holds something that cannot be copied back (an FMU, a bus,
    a file)."""
    if comp.construction_parameters or comp.needs_realtime:
        return None
    fixed, mutable = {}, {}
    try:
        for k, v in comp.__dict__.items():
            if k in _KEPT or k == "variables":
                continue
            if plain(v) and not _holds_array((v,)):
                fixed[k] = v
            else:
                mutable[k] = copy.deepcopy(v)
    except Exception:  # noqa: BLE001 - whatever does not copy is rebuilt instead
        return None
    return fixed, mutable


def _holds_array(value: Any) -> bool:
    return isinstance(value, tuple) and any(
        type(v).__name__ == "ndarray" or _holds_array(v) for v in value)


def _restore(comp: Component, saved: tuple[dict[str, Any], dict[str, Any]],
             variables: dict[str, Any]) -> None:
    """The component's attributes set back in place to `saved` (its generated calls keep
    reading the same dict)."""
    d = comp.__dict__
    kept = {k: d[k] for k in _KEPT if k in d}
    fixed, mutable = saved
    d.clear()
    d.update(fixed)
    d.update({k: copy.deepcopy(v) for k, v in mutable.items()})
    d["variables"] = dict(variables)
    d.update(kept)


def _shape(spec: ScenarioSpec, system: System, base: ScenarioSpec | None = None,
           known: Any = None) -> Any:
    """Everything of a flat structure but the parameter and initial values of its blocks (the
    values that build the blocks themselves excepted). `known`: the shape of structure `base`,
    whose blocks and sections `spec` shares (the same objects: an override replaces what it
    changes) are taken from it."""
    e, r = spec.experiment, spec.record
    held = {} if base is None else dict(zip(base.components, known[0], strict=True))
    blocks = []
    for name, c in spec.components.items():
        if base is not None and base.components.get(name) is c:
            blocks.append(held[name])
            continue
        comp = system.components.get(name)
        made = () if comp is None else tuple(
            (k, repr(c.parameters[k].value)) for k in comp.construction_parameters
            if k in c.parameters)
        sizing = () if comp is None else tuple(
            (k, repr(c.parameters[k].value)) for k in sorted(comp.sizing_parameters)
            if k in c.parameters)
        blocks.append((name, c.kind.value, c.step_multiple.value, made, sizing))
    experiment = known[3] if base is not None and base.experiment is e else (*(
        None if g is None else repr(g.value) for g in (
            e.start, e.stop, e.step, e.algorithm, e.realtime)),
        tuple(sorted((k, repr(g.value)) for k, g in e.options.items())))
    events = tuple(tuple(None if g is None else repr(g.value) for g in (
        ev.at, ev.until, ev.port, ev.fault, ev.value, ev.seed, ev.set)) for ev in spec.events)
    return (tuple(blocks), tuple(g.value for g in spec.connections),
            tuple(g.value for g in spec.open), experiment,
            None if r.signals is None else tuple(g.value for g in r.signals),
            r.decimation.value, events)


def _values(spec: ScenarioSpec, name: str) -> Any:
    c = spec.components[name]
    return (tuple((k, repr(g.value)) for k, g in c.parameters.items()),
            tuple((k, repr(g.value)) for k, g in c.initial.items()))


class Built:
    """A scenario built once (`twmr.build`); `run(values)` runs it with those overrides."""

    def __init__(self, scenario: Scenario):
        from twmr.scenario.flatten import flatten, has_subsystems

        self.scenario = scenario
        self.spec = scenario.spec
        self.system = scenario.fresh_system()
        self._nested = has_subsystems(self.spec)
        self._flat = flatten(self.spec).spec if self._nested else self.spec
        self._shape = _shape(self._flat, self.system)
        saved = {name: _snapshot(comp) for name, comp in self.system.components.items()}
        self._saved: dict[str, tuple[dict[str, Any], dict[str, Any]]] | None = \
            None if any(s is None for s in saved.values()) else saved  # type: ignore[assignment]
        self._variables = {name: dict(comp.variables)
                           for name, comp in self.system.components.items()}
        self._fresh = True  # the system has not run yet
        self.rebuilt = 0  # runs that needed a new build
        #: the stepping time of the system's runs [s] and their count: once what a loop
        #: compiled for it would save (`OWN_LOOP_SAVING`) of these runs, and of the runs still
        #: expected (`expect`) at their mean, covers compiling that loop, the system runs by it
        #: (a ski-rental rule, `twmr.master.scenario_loop.own_loop`)
        self._stepped_s = 0.0
        self._runs = 0
        self._expected = 0

    def expect(self, runs: int) -> None:
        """Say that about `runs` runs of the built system are to come in all (those run so far
        included; a sweep's share of one worker), so the system takes the loop compiled for it
        as soon as those runs repay it, not only once the runs made have."""
        self._expected = max(self._expected, runs)

    def run(self, values: Mapping[str, Any] | Sequence[str] = (), *, out: Any = None,
            formats: Sequence[str] = (), metrics: Sequence[str] = (),
            observers: Sequence[Any] = (), header: dict[str, Any] | None = None) -> Result:
        """Run with `values` ({'comp.param': value} or ['comp.param=value', ...], on top of the
        scenario's own overrides); the other arguments as `twmr.simulate`'s."""
        texts = _texts(values)
        overrides = (*self.scenario.overrides, *texts)
        spec, system = self.system_for(texts)
        scenario = Scenario(self.scenario.source, spec, self.scenario.base_dir, overrides,
                            _system=system, _spec=spec)
        result = simulate(scenario, out, formats=formats, metrics=metrics,
                          observers=observers, header=header)
        if system is self.system:
            from twmr.master.scenario_loop import OWN_LOOP_SAVING

            self._stepped_s += float(result.summary.get("wall_time_s") or 0.0)
            self._runs += 1
            to_come = max(0, self._expected - self._runs) * self._stepped_s / self._runs
            system.own_loop_budget_s = (self._stepped_s + to_come) * OWN_LOOP_SAVING
        return result

    def system_for(self, texts: Sequence[str]) -> tuple[ScenarioSpec, System]:
        """The structure with the override `texts` applied, and a system ready for a run of it:
        the one built, set to those values, or (another shape) a new one."""
        from twmr.scenario.build import build_system, reconfigure, scenario_spec
        from twmr.scenario.flatten import flatten

        spec = scenario_spec(self.spec, overrides=texts) if texts else self.spec
        if self._fresh and not texts:
            self._fresh = False
            return spec, self.system
        flat = self._flat if not texts else flatten(spec).spec if self._nested else spec
        if self._saved is None or \
                _shape(flat, self.system, self._flat, self._shape) != self._shape:
            self.rebuilt += 1
            return spec, build_system(spec)
        self._fresh = False
        for name, comp in self.system.components.items():
            _restore(comp, self._saved[name], self._variables[name])
        base = self._flat.components
        changed = [n for n, c in flat.components.items()  # an override replaces what it sets
                   if c is not base[n] and _values(flat, n) != _values(self._flat, n)]
        if changed:  # a failure leaves them changed: the next run restores every component
            reconfigure(flat, self.system, changed)
        return spec, self.system


def _texts(values: Mapping[str, Any] | Sequence[str]) -> list[str]:
    if isinstance(values, Mapping):
        return [f"{k}={json.dumps(v)}" for k, v in values.items()]
    return [str(v) for v in values]


def build(scenario: Scenario | str | Any, overrides: Sequence[str] = ()) -> Built:
    """A scenario (as `twmr.load` takes it, or a loaded `Scenario`) built once, to run again
    and again with other values (`Built.run`)."""
    from twmr.api import load

    if not isinstance(scenario, Scenario):
        scenario = load(scenario, overrides)
    elif overrides:
        scenario = load(scenario.spec, overrides)
    return Built(scenario)
