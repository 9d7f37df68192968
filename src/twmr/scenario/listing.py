"""Text for `twmr check` (a built System, the tree of subsystems) and `twmr components` (the
known kinds)."""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from twmr.core.component import Component
from twmr.core.port import Variable
from twmr.registry import kinds, lookup
from twmr.scenario.graph import Loop, evaluation_plan, find_loops
from twmr.scenario.kinds import KindError
from twmr.scenario.structure import Exposure, ScenarioSpec
from twmr.scenario.system import System


def evaluation_order(system: System) -> list[str]:
    """The components whose feedthrough outputs are computed at each communication point, in
    the order the master calls `evaluate` (Gauss-Seidel: as the port graph asks; Jacobi: the
    step order, all from one snapshot)."""
    if system.experiment.algorithm == "jacobi":
        return [n for n in system.order if system.components[n].has_feedthrough]
    loops = _loops(system)
    actions, _ = evaluation_plan(system.components, system.connections, loops)
    names: list[str] = []
    for action, name, _ in actions:
        if action == "evaluate":
            names.append(name)
        elif action == "loop":
            names.append(f"loop {int(name) + 1} ({', '.join(loops[int(name)].components)})")
    return names


def _loops(system: System) -> list[Loop]:
    """The loops the master solves (`experiment.loops: solve`), else none."""
    if system.experiment.loops != "solve":
        return []
    return find_loops(system.components, system.connections)[0]


def describe(system: System) -> str:
    """Components, execution order, wires with units and conversions, open inputs, experiment."""
    exp = system.experiment
    lines = [f"scenario {system.source}",
             f"experiment: {exp.start:g} .. {exp.stop:g} s, step {exp.step:g} s "
             f"({exp.n_steps} steps), {exp.algorithm}{', real time' if system.paced else ''}",
             "components (the order they step in, `do_step`):"]
    for i, name in enumerate(system.order, 1):
        comp = system.components[name]
        mult = system.multiple(name)
        ft = " feedthrough" if comp.has_feedthrough else ""
        lines.append(f"  {i}. {name}: {type(comp).__name__}{ft}"
                     f"{f', every {mult} steps' if mult != 1 else ''}")
    evaluated = evaluation_order(system)
    if evaluated:
        lines.append("at each communication point, before the steps, the feedthrough outputs "
                     f"are evaluated in this order (`evaluate`): {', '.join(evaluated)}")
    opts = system.experiment.loop_solver
    for k, lp in enumerate(_loops(system), 1):
        tears = ", ".join(f"{n}.{p}" for n, p in lp.tears)
        lines.append(f"algebraic loop {k} through {', '.join(lp.components)}: torn at {tears}, "
                     f"solved at each point ({opts.method}, tol {opts.tol:g}, max_iter "
                     f"{opts.max_iter}, relaxation {opts.relaxation:g})")
    lines.append("connections:")
    driven = set()
    for c in system.connections:
        a = system.components[c.src].variables[c.src_port]
        b = system.components[c.dst].variables[c.dst_port]
        conv = "" if (c.gain, c.offset) == (1.0, 0.0) else \
            f"  (converted: x {c.gain:g}{f' + {c.offset:g}' if c.offset else ''})"
        lines.append(f"  {c}  [{a.unit_text} -> {b.unit_text}]{conv}")
        driven.add((c.dst, c.dst_port))
    unwired = [(n, p, v) for n, comp in system.components.items()
               for p, v in comp.inputs.items() if (n, p) not in driven]
    opened = [f"{n}.{p} = {system.components[n].get(p)!r}" for n, p, v in unwired
              if not v.optional]
    if opened:
        lines.append("open inputs (start values): " + ", ".join(opened))
    optional = [f"{n}.{p}" for n, p, v in unwired if v.optional]
    if optional:
        lines.append("optional inputs left unwired: " + ", ".join(optional))
    rec = ", ".join(f"{n}.{p}" for n, p in system.record.signals)
    lines.append(f"recorded every {system.record.decimation} step(s): {rec}")
    return "\n".join(lines)


def tree(spec: ScenarioSpec, indent: str = "  ") -> list[str]:
    """The components of `spec` as a tree: each block with its kind, each subsystem with its
    file, the ports it exposes and its own components below it."""
    lines: list[str] = []
    for name, comp in spec.components.items():
        if comp.system is None:
            lines.append(f"{indent}{name}: {comp.kind.value}")
            continue
        inner = comp.system
        lines.append(f"{indent}{name}: system {inner.source}")
        lines += [f"{indent}  input  {_exposed(e)} -> {e.port.value}"
                  for e in inner.inputs.values()]
        lines += [f"{indent}  output {_exposed(e)} <- {e.port.value}"
                  for e in inner.outputs.values()]
        lines += tree(inner, indent + "  ")
    return lines


def _exposed(e: Exposure) -> str:
    unit = e.unit.value if e.unit is not None else None
    text = ", ".join(unit) if isinstance(unit, list) else unit
    return f"{e.name} [{text}]" if text else e.name


def _kind_text(name: str, cls: type[Component]) -> list[str]:
    doc = (cls.__doc__ or "").strip().splitlines()
    out = [f"{name}: {cls.__module__}.{cls.__name__} — {doc[0] if doc else ''}"]
    out += _variable_lines(cls.declared().values(), "    ")
    for setting, added in cls.added_parameters().items():
        out.append(f"    with {setting}:")
        out += _variable_lines(added.values(), "      ")
    return out


def _variable_lines(variables: Iterable[Variable], indent: str) -> list[str]:
    out: list[str] = []
    for var in variables:
        size = "" if var.size is None else f"[{var.size or 'n'}]"
        rng = ""
        if var.min is not None or var.max is not None:
            rng = f" in [{var.min}, {var.max}]"
        deps = getattr(var, "depends_on", ())
        dep = f" depends_on {', '.join(deps)}" if deps else ""
        desc = f" — {var.description}" if var.description else ""
        out.append(f"{indent}{var.kind:9s} {var.name}{size} [{var.unit_text}] {var.type} "
                   f"= {var.start!r}{rng}{dep}{desc}")
    return out


def kinds_table(selected: list[str] | None = None, base_dir: Path | None = None) -> str:
    """Every known kind (or the selected ones, which may name classes: 'my_block.py:MyBlock',
    relative to `base_dir`, and 'package.module:MyBlock') with ports, parameters, states and
    units. A selected class that cannot be loaded raises its `KindError`."""
    lines: list[str] = []
    for name in sorted(selected or kinds()):
        try:
            lines += _kind_text(name, lookup(name, base_dir))
        except KindError:
            raise
        except KeyError as err:
            lines.append(f"{name}: {err.args[0]}")
        except Exception as err:  # noqa: BLE001 - a kind that cannot load is listed, not fatal
            lines.append(f"{name}: cannot be loaded ({type(err).__name__}: {err})")
    return "\n".join(lines)
