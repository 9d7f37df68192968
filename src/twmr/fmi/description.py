"""What an FMU offers, read from its modelDescription.xml (through fmpy): the ports, their FMI
types and value references, array sizes, units with the FMU's own UnitDefinitions, and direct
feedthrough.

Ports: causality input/output -> `Input`/`Output`, parameters and structural parameters (fixed or
tunable) -> `Parameter`, with type, unit (the variable's or its declaredType's), start, min/max and
description. An FMI 3.0 array (`<Dimension>`) is a vector port of the product of its dimensions
(row-major), sized by the dimension's start or by the structural parameter it names; Modelica
array names `x[1]..x[n]` are grouped into a vector port `x`. Direct feedthrough comes from
ModelStructure (an output without dependency information depends on every input, as the standard
says).

Aliases (FMI 3.0 `<Alias>`, FMI 2.0 variables of one type sharing a value reference) are one
variable: an alias of an output or state is a read-only output reading it (in the alias's own
display unit where the FMU defines one), an alias of an input or parameter is no port, and
`aliases_of` names what each alias stands for, so that setting one can be refused.
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from twmr.core.errors import FmuError
from twmr.core.port import (
    BINARY,
    BOOLEAN,
    CLOCK,
    INTEGER,
    REAL,
    STRING,
    Input,
    Output,
    Parameter,
    State,
    Variable,
)
from twmr.core.units import Unit

_ARRAY = re.compile(r"^(.*)\[(\d+)\]$")
#: FMI type -> port type
PORT_TYPE = {"Real": REAL, "Float64": REAL, "Float32": REAL, "Integer": INTEGER,
             "Enumeration": INTEGER, "Int8": INTEGER, "UInt8": INTEGER, "Int16": INTEGER,
             "UInt16": INTEGER, "Int32": INTEGER, "UInt32": INTEGER, "Int64": INTEGER,
             "UInt64": INTEGER, "Boolean": BOOLEAN, "String": STRING, "Binary": BINARY,
             "Clock": CLOCK}
#: value range of the FMI 3.0 integer types
_RANGE = {f"{u}Int{b}": ((0, 2**b - 1) if u else (-2**(b - 1), 2**(b - 1) - 1))
          for u in ("", "U") for b in (8, 16, 32, 64)}


@dataclass
class FmuPort:
    """One port and the FMU variables behind it: value references in element order, the FMI
    type of its get/set calls, and how many values they carry."""

    name: str
    kind: str
    fmi_type: str
    vrs: list[int]
    count: int
    scalar: bool
    discrete: bool
    #: an alias (read only): the port of the variable it names
    alias_of: str = ""
    #: (factor, offset) of an alias shown in its own display unit: value = factor * base + offset
    display: tuple[float, float] | None = None
    #: a clock port: its intervalVariability (triggered, countdown, constant, fixed, tunable,
    #: changing); "" for every other port
    clock: str = ""
    #: an input clock the importer activates on the FMU's own schedule (periodic or countdown):
    #: it is an output port of the component, ticking when the master activates it
    scheduled: bool = False
    #: value references of the clocks this variable is clocked by (empty: not clocked)
    clocked_by: tuple[int, ...] = ()


def _unreadable(path: Path, exc: Exception) -> str:
    """What is wrong with an FMU fmpy could not read, in words (fmpy's own failures, such as an
    UnboundLocalError for an unknown element, say nothing useful; its schema check does)."""
    import zipfile

    from fmpy import read_model_description
    from lxml import etree

    if path.is_dir():
        return "it is a folder, not an FMU file"
    if not zipfile.is_zipfile(path):
        return "it is not a zip archive" + (" (the file is empty)" if not path.stat().st_size
                                            else "")
    with zipfile.ZipFile(path) as z:
        if "modelDescription.xml" not in z.namelist():
            return "it has no modelDescription.xml at its top"
    if isinstance(exc, etree.XMLSyntaxError):
        return f"its modelDescription.xml is not well-formed XML ({exc.msg})"
    try:
        read_model_description(str(path), validate=True)
    except Exception as invalid:  # noqa: BLE001 - fmpy reports schema errors as Exception
        lines = [line.strip(" -.") for line in str(invalid).splitlines()[1:] if line.strip()]
        if lines:
            return f"its model description does not follow the FMI schema ({lines[0]})"
    if type(exc) is Exception:  # fmpy's own message, e.g. "Unsupported FMI version: 9"
        return f"fmpy cannot read its model description ({exc})"
    return "fmpy cannot read its model description (an element or attribute it needs is " \
           "missing or malformed)"


@functools.lru_cache(maxsize=128)
def _description(path: str, mtime_ns: int, size: int) -> Any:
    """fmpy's ModelDescription of the FMU file `path` as it is (its time and size are the key:
    a changed file is read anew); read once for all its instances. Not to be changed."""
    from fmpy import read_model_description

    return read_model_description(path, validate=False)


def read_description(path: Path, instance: str = "fmu") -> Any:
    """fmpy's ModelDescription of `path`, with every failure as an FmuError; FMUs this importer
    cannot run correctly (FMI 1.0, clocks, scheduled execution only) are refused here."""

    if not path.exists():
        raise FmuError(instance, None, f"FMU file '{path}' not found. Fix: check `path:` (relative "
                       f"paths are taken from the scenario's folder).")
    try:
        stat = (path / "modelDescription.xml" if path.is_dir() else path).stat()
        md = _description(str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    except Exception as exc:  # noqa: BLE001 - fmpy raises many kinds (zip, XML, schema)
        raise FmuError(instance, None, f"'{path}' is not a readable FMU: {_unreadable(path, exc)}."
                       f" Fix: give an FMU file (a zip with a valid modelDescription.xml at its "
                       f"top), or ask its vendor for a correct one.") from None
    if md.fmiVersion.startswith("1."):
        raise FmuError(instance, None, f"'{path}' is an FMI 1.0 FMU, which is not supported. Fix: "
                       f"export it as FMI 2.0 or 3.0 co-simulation or model exchange.")
    if md.coSimulation is None and md.modelExchange is None:
        what = "only scheduled execution" if md.scheduledExecution is not None else "no interface"
        raise FmuError(instance, None, f"'{path}' offers {what}; this importer runs co-simulation "
                       f"and model-exchange FMUs. Fix: export it as FMI 2.0/3.0 co-simulation or "
                       f"model exchange.")
    clocks = [v.name for v in md.modelVariables if v.type == "Clock"]
    if clocks and (md.coSimulation is None or not md.coSimulation.hasEventMode):
        why = "it has no co-simulation interface (clocks in model exchange are not supported)" \
            if md.coSimulation is None else "its co-simulation interface has no event mode " \
            "(hasEventMode is not true), in which clocks tick"
        raise FmuError(instance, None, f"'{path}' has clocks ({', '.join(clocks[:5])}), but "
                       f"{why}. Fix: export the FMU as FMI 3.0 co-simulation with "
                       f"hasEventMode=\"true\", or without clocks.")
    return md


def description_xml(path: Path) -> bytes:
    """The bytes of the modelDescription.xml of the FMU at `path` (a file or an unpacked
    folder), for what fmpy does not read."""
    import zipfile

    if path.is_dir():
        return (path / "modelDescription.xml").read_bytes()
    with zipfile.ZipFile(path) as z:
        return z.read("modelDescription.xml")


def clock_timing(path: Path) -> dict[int, tuple[float, float]]:
    """Value reference -> (intervalDecimal, shiftDecimal) [s] of every Clock that gives an
    interval, from the FMU's modelDescription.xml (fmpy does not read them); shift 0 if none."""
    from lxml import etree

    timing = {}
    for v in etree.fromstring(description_xml(path)).iter("Clock"):
        interval = v.get("intervalDecimal")
        if interval is not None:
            timing[int(v.get("valueReference", "0"))] = (float(interval),
                                                         float(v.get("shiftDecimal") or 0.0))
    return timing


def derivatives_provided(path: Path, interface: str) -> tuple[bool, bool]:
    """(directional, adjoint): whether the FMU's `interface` element ('ModelExchange' or
    'CoSimulation') provides directional derivatives (FMI 2.0 providesDirectionalDerivative,
    FMI 3.0 providesDirectionalDerivatives, which fmpy does not read) and adjoint ones (FMI
    3.0 providesAdjointDerivatives), from its modelDescription.xml."""
    from lxml import etree

    element = etree.fromstring(description_xml(path)).find(interface)
    if element is None:
        return False, False
    directional = any(element.get(a) == "true" for a in ("providesDirectionalDerivative",
                                                         "providesDirectionalDerivatives"))
    return directional, element.get("providesAdjointDerivatives") == "true"


def unit_definitions(md: Any) -> dict[str, Unit]:
    """The FMU's UnitDefinitions that carry a BaseUnit, as units (SI = factor * value + offset)."""
    defined: dict[str, Unit] = {}
    for u in getattr(md, "unitDefinitions", None) or []:
        b = u.baseUnit
        if u.name and b is not None:
            exps = (b.kg, b.m, b.s, b.A, b.K, b.mol, b.cd, b.rad)
            defined[u.name] = Unit(u.name, float(b.factor), tuple(int(e) for e in exps),
                                   float(b.offset))
    return defined


def _unit(v: Any) -> str:
    unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None)
    return unit or ""


def _values(v: Any, text: str | None, type_: str, count: int, resized: bool = False
            ) -> list[Any]:
    """`count` start values of `v` from its start text (FMI 3.0 arrays: space-separated). An
    array `resized` by a structural parameter keeps its first values (a repeated one fills it);
    the FMU is not told these, only the values the scenario gives."""
    if text is None:
        return [{STRING: "", BOOLEAN: False, BINARY: b"", REAL: 0.0, CLOCK: False}.get(
            type_, 0)] * count
    if type_ == STRING:
        return [str(text)] * count
    items = str(text).split() or [""]
    if (len(items) == 1 or (resized and len(set(items)) == 1)) and count > 1:
        items = items[:1] * count
    if resized and len(items) != count:
        items = (items + ["0"] * count)[:count]
    if len(items) != count:
        raise ValueError(f"variable '{v.name}' has {len(items)} start values for "
                         f"{count} elements")
    out: list[Any] = []
    for raw in items:
        try:
            if type_ == BOOLEAN:
                out.append({"true": True, "1": True, "false": False, "0": False}[raw.lower()])
            elif type_ == BINARY:
                out.append(bytes.fromhex(raw[2:] if raw.lower().startswith("0x") else raw))
            elif type_ == REAL:
                out.append(float(raw))
            else:
                out.append(int(raw) if re.fullmatch(r"[-+]?\d+", raw) else int(float(raw)))
        except (ValueError, KeyError):
            raise ValueError(f"variable '{v.name}' has start=\"{raw}\", which is not a valid "
                             f"{type_}") from None
    return out


def sizing_references(md: Any) -> set[int]:
    """Value references of the structural parameters that size an array (`<Dimension
    valueReference>`): only these must be whole numbers; the others (a Boolean `dae`) keep
    their type."""
    return {d.valueReference for v in md.modelVariables
            for d in getattr(v, "dimensions", None) or [] if d.valueReference is not None}


def structural_values(md: Any, given: dict[str, Any]) -> dict[int, int]:
    """Value of every structural parameter that sizes an array, by value reference: `given` by
    the scenario, else its start."""
    sizing = sizing_references(md)
    values: dict[int, int] = {}
    for v in md.modelVariables:
        if v.causality == "structuralParameter" and v.valueReference in sizing and \
                getattr(v, "alias", None) is None:
            raw = given.get(v.name, v.start)
            try:
                values[v.valueReference] = int(raw) if raw is not None else 0
            except (TypeError, ValueError):
                raise ValueError(f"structural parameter '{v.name}' = {raw!r} sizes an array "
                                 f"but is not an integer") from None
    return values


def _size(v: Any, structural: dict[int, int]) -> int | None:
    """Number of elements of an FMI 3.0 array variable (None: a scalar)."""
    dims = getattr(v, "dimensions", None) or []
    if not dims:
        return None
    n = 1
    for d in dims:
        if d.start is not None:
            n *= int(d.start)
        elif d.valueReference in structural:
            n *= structural[d.valueReference]
        else:
            raise ValueError(f"variable '{v.name}' has a dimension given by value reference "
                             f"{d.valueReference}, which is not a structural parameter")
    return n


#: FMI 2.0 value-reference spaces: variables of one space with one value reference are aliases
_FMI2_SPACE = {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer",
               "Boolean": "Boolean", "String": "String"}


def _alias_bases(md: Any) -> dict[int, Any]:
    """The variable each alias names, by id of the alias: FMI 3.0 `<Alias>` elements (fmpy
    adds them as variables with `alias` set), FMI 2.0 variables sharing a value reference of one
    type (the base is the one with a port and a start value, else the first with a port)."""
    if md.fmiVersion.startswith("3."):
        return {id(v): v.alias for v in md.modelVariables if getattr(v, "alias", None)}
    sets: dict[tuple[str, int], list[Any]] = {}
    for v in md.modelVariables:
        if v.type in _FMI2_SPACE:
            sets.setdefault((_FMI2_SPACE[v.type], v.valueReference), []).append(v)
    bases: dict[int, Any] = {}
    for members in sets.values():
        if len(members) < 2:
            continue
        ported = [v for v in members if _kind(v) is not None] or members
        base = next((v for v in ported if v.start is not None), ported[0])
        bases.update((id(v), base) for v in members if v is not base)
    return bases


def _triggered(v: Any) -> bool:
    return (getattr(v, "intervalVariability", None) or "triggered") == "triggered"


def _port_name(v: Any) -> str:
    m = _ARRAY.match(v.name) if not getattr(v, "dimensions", None) else None
    return m.group(1) if m else v.name


def aliases_of(md: Any) -> dict[str, str]:
    """Alias name -> the name of the port it stands for, for every alias of a port (array
    elements `y[i]` of `x[i]` as `y` -> `x`)."""
    bases = _alias_bases(md)
    return {_port_name(v): _port_name(base) for v in md.modelVariables
            if (base := bases.get(id(v))) is not None and _kind(base) is not None}


def _kind(v: Any) -> str | None:
    if v.type == "Clock":  # an input clock the importer schedules ticks as an output of ours
        return "input" if v.causality == "input" and _triggered(v) else \
            "output" if v.causality in ("input", "output") else None
    if v.causality == "input":
        return "input"
    if v.causality == "output":
        return "state" if getattr(v, "initial", None) == "exact" else "output"
    if v.causality in ("parameter", "structuralParameter") and \
            v.variability in ("fixed", "tunable"):
        return "parameter"
    return None


def ports_of(md: Any, given: dict[str, Any] | None = None
             ) -> tuple[list[FmuPort], dict[str, Variable]]:
    """Ports (grouped arrays) and their Variable descriptors from a ModelDescription; `given`
    holds the scenario's parameter values (structural parameters size the arrays)."""
    structural = structural_values(md, given or {})
    defined = unit_definitions(md)
    bases = _alias_bases(md)
    groups: dict[tuple[str, str], list[tuple[int, Any]]] = {}
    order: list[tuple[str, str]] = []
    for v in md.modelVariables:
        # an alias that is an output (or state) is a read-only output; otherwise it is no port
        kind = _kind(v) if id(v) not in bases else \
            ("alias" if _kind(v) in ("output", "state") else None)
        if kind is None or v.type not in PORT_TYPE:
            continue
        m = _ARRAY.match(v.name) if not getattr(v, "dimensions", None) else None
        key = (m.group(1), kind) if m else (v.name, kind)
        idx = int(m.group(2)) if m else 0
        if key not in groups:
            groups[key] = []
            order.append(key)
        groups[key].append((idx, v))
    ports: list[FmuPort] = []
    variables: dict[str, Variable] = {}
    port_of_var: dict[int, str] = {}
    for key in order:
        name, kind = key
        items = sorted(groups[key], key=lambda x: x[0])
        scalar = len(items) == 1 and items[0][0] == 0
        if not scalar and ([i for i, _ in items] != list(range(1, len(items) + 1))
                           or len({v.type for _, v in items}) > 1):
            # not a complete 1..n array of one type: every element is its own scalar port
            for i, v in items:
                _add(ports, variables, f"{name}_{i}", kind, [v], structural, defined, md)
                port_of_var[id(v)] = f"{name}_{i}"
            continue
        _add(ports, variables, name, kind, [v for _, v in items], structural, defined, md)
        for _, v in items:
            port_of_var[id(v)] = name
    first = {port_of_var[id(v)]: v for v in reversed(md.modelVariables) if id(v) in port_of_var}
    for p in ports:
        if p.kind == "alias":
            p.alias_of = port_of_var.get(id(bases[id(first[p.name])]), "")
            p.kind = "output"
    inputs = [p.name for p in ports if p.kind == "input"]
    deps: dict[str, set[str]] = {}
    for unknown in getattr(md, "outputs", []) or []:
        port = port_of_var.get(id(unknown.variable))
        if port is None or variables[port].kind == "state":
            continue  # a state never depends directly on inputs
        if unknown.dependencies is None:
            deps.setdefault(port, set()).update(inputs)
        else:
            deps.setdefault(port, set()).update(
                port_of_var[id(d)] for d in unknown.dependencies
                if port_of_var.get(id(d)) in inputs)
    for p in ports:
        if p.kind == "output" and not p.alias_of:
            var = variables[p.name]
            assert isinstance(var, Output)
            # clocks and clocked outputs are read in event mode after the step: no feedthrough
            var.depends_on = () if p.clock or p.clocked_by else \
                tuple(sorted(deps.get(p.name, set(inputs))))
    for p in ports:
        if p.alias_of:
            alias, base = variables[p.name], variables[p.alias_of]
            assert isinstance(alias, Output)
            factor, offset = p.display or (1.0, 0.0)
            starts = base.start if isinstance(base.start, tuple) else (base.start,)
            shown = starts if p.display is None else tuple(factor * x + offset for x in starts)
            alias.start = alias.coerce(shown if isinstance(base.start, tuple) else shown[0])
            alias.depends_on = (p.alias_of,) if base.kind == "input" else \
                getattr(base, "depends_on", ())
    return ports, variables


def _display(md: Any, v: Any, defined: dict[str, Unit]) -> tuple[float, float, Unit] | None:
    """(factor, offset, unit) of an FMI 3.0 alias with a display unit of its own, defined among
    the `<DisplayUnit>`s of its variable's unit (which has a BaseUnit): shown = factor * value +
    offset; None when it has none."""
    base = getattr(v, "alias", None)
    unit = _unit(v)
    if base is None or not v.displayUnit or v.displayUnit == base.displayUnit or \
            unit not in defined:
        return None
    for u in getattr(md, "unitDefinitions", None) or []:
        for d in u.displayUnits if u.name == unit else ():
            if d.name == v.displayUnit and d.factor:
                si = defined[unit]
                shown = Unit(d.name, si.factor / d.factor, si.exponents,
                             si.offset - si.factor * d.offset / d.factor)
                return float(d.factor), float(d.offset), shown
    return None


def _add(ports: list[FmuPort], variables: dict[str, Variable], name: str, kind: str,
         vs: list[Any], structural: dict[int, int], defined: dict[str, Unit], md: Any) -> None:
    fmi_type = vs[0].type
    type_ = PORT_TYPE[fmi_type]
    size = _size(vs[0], structural) if len(vs) == 1 else None
    count = size if size is not None else len(vs)
    if size is not None:
        resized = any(d.start is None for d in vs[0].dimensions)
        starts = _values(vs[0], vs[0].start, type_, size, resized)
    else:
        starts = [_values(v, v.start, type_, 1)[0] for v in vs]
    cls = {"input": Input, "output": Output, "state": State, "parameter": Parameter,
           "alias": Output}[kind]
    kwargs: dict[str, Any] = {"type": type_, "description": vs[0].description or ""}
    display = _display(md, vs[0], defined) if kind == "alias" and type_ == REAL else None
    if type_ in (REAL, INTEGER):
        units = tuple(_unit(v) for v in vs) if size is None else (_unit(vs[0]),)
        kwargs["unit"] = units[0] if len(set(units)) == 1 else units
        kwargs["unit_definitions"] = defined
        low, high = _RANGE.get(fmi_type, (None, None))
        kwargs["min"], kwargs["max"] = _bound(vs[0], "min", low), _bound(vs[0], "max", high)
        if display is not None:  # its unit is the display unit; min and max are in the base's
            shown = display[2]
            kwargs["unit"], kwargs["unit_definitions"] = shown.text, {**defined,
                                                                       shown.text: shown}
            kwargs["min"] = kwargs["max"] = None
    scalar = len(vs) == 1 and size is None
    if scalar:
        var = cls(start=starts[0], **kwargs)
    else:
        kwargs["size"] = count
        var = cls(start=tuple(starts), **kwargs)
    var.name = name
    variables[name] = var
    discrete = all(v.variability in ("discrete", "fixed", "tunable") or
                   (v.type not in ("Real", "Float64", "Float32")) for v in vs)
    clock = (getattr(vs[0], "intervalVariability", None) or "triggered") \
        if fmi_type == "Clock" else ""
    clocked_by = tuple(c.valueReference for c in getattr(vs[0], "clocks", None) or ())
    ports.append(FmuPort(name, kind, fmi_type, [v.valueReference for v in vs], count, scalar,
                         discrete, display=display[:2] if display else None, clock=clock,
                         scheduled=bool(clock) and vs[0].causality == "input" and
                         clock != "triggered", clocked_by=clocked_by))


def _bound(v: Any, which: str, default: int | None) -> Any:
    """min/max of the variable (as a number) or the type's range; None when unbounded."""
    raw = getattr(v, which, None)
    if raw is None:
        raw = getattr(getattr(v, "declaredType", None), which, None)
    if raw is None:
        return default
    try:
        value = float(raw)
    except (TypeError, ValueError):
        return default
    return value if math.isfinite(value) else default
