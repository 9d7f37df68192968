"""A co-simulation FMU inside the generated loop (`twmr.master.compiled`): what the loop needs to
call it (`FmuCalls`, `FmuTransfer`), its compiled form (`compiled_form`, a `Kernel` whose `fmu`
is an `FmuCalls`) and the lines of the loop that call its C functions (`call_lines`).

The loop calls the FMU's set, get and doStep functions itself, through their addresses, one
call per FMI type with the value references and a value buffer of that type laid out once: the
calls, their order and their values are those of `FmuComponent.evaluate` / `do_step`. Port
values are carried in the loop as the Python path holds them: a Real as a float64 (a Float32
variable too: it is rounded to float32 only on its way into the FMU, as ctypes does), an
Integer or a Boolean as an int64 (a UInt64 variable as a uint64; back in Python an FMI 3.0
Boolean is a bool again), converted into the call's C
type on the way in with C's wrap-around, as fmpy's ctypes arrays convert a Python int.

Supported: FMI 2.0 and 3.0 co-simulation FMUs without event mode, whose set and got ports are
scalars or Real vectors of Real, Integer and Boolean types (Float32, Float64, Int8..UInt64,
Enumeration, Boolean). A String, Binary or Clock port, an Integer or Boolean array, or an alias
in its own display unit that the run sets or reads refuses the loop (`NotCompilable`), naming
the port; one the run neither wires nor records stays out of the loop.
"""
from __future__ import annotations

import ctypes
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from twmr.core.kernel import Carriage, Kernel


@dataclass(frozen=True)
class FmuTransfer:
    """One set or get call of an FMU in the generated loop: the FMI function (e.g.
    'fmi3SetInt8'), the ports it carries [(port, width)] in the order of their value
    references, how many value references and values, and whether the loop carries the values
    as floats (else as integers)."""

    call: str
    ports: tuple[tuple[str, int], ...]
    nvr: int
    count: int
    real: bool


@dataclass(frozen=True)
class FmuCalls:
    """What the generated loop needs to call an FMI 2.0 or 3.0 co-simulation FMU: its calls,
    one per FMI type, setting the inputs, getting the feedthrough outputs and getting the
    outputs read after a step. The parameters of its
    `Kernel` are (doStep as a ctypes function taking pointers as size_t, the instance, doStep's
    flags (3 booleans) and last successful time (FMI 3.0), then per call in that order (the
    function, the value references as uint32, a value buffer of the call's C type)); a status
    above Warning stops the run, reported by `error(call, status, t)` (status -1: fmi3DoStep
    asked to terminate)."""

    fmi3: bool
    inputs: tuple[FmuTransfer, ...]
    feedthrough: tuple[FmuTransfer, ...]
    after_step: tuple[FmuTransfer, ...]
    error: Callable[[str, int, float], BaseException]


#: a failed call is reported as component index * CALLS + the call's index in the FMU's list
CALLS = 256
#: the status the loop reports when fmi3DoStep asks to terminate the simulation
TERMINATE = -1

_SIZE = ctypes.c_size_t
#: FMI call suffix -> (value buffer dtype, whether the loop carries it as a float)
_FMI2 = {"Real": (np.float64, True), "Integer": (np.int32, False),
         "Boolean": (np.int32, False)}
_FMI3 = {"Float64": (np.float64, True), "Float32": (np.float32, True),
         "Int8": (np.int8, False), "UInt8": (np.uint8, False), "Int16": (np.int16, False),
         "UInt16": (np.uint16, False), "Int32": (np.int32, False), "UInt32": (np.uint32, False),
         "Int64": (np.int64, False), "UInt64": (np.uint64, False), "Boolean": (np.bool_, False)}


class NotCompilable(Exception):
    """An FMU the generated loop cannot call (the message says which port and why)."""


def carried(fmi_type: str, fmi3: bool) -> Carriage:
    """How the loop carries a value of FMI type `fmi_type` (a Boolean is BOOL for FMI 3.0 only:
    fmpy gives an FMI 2.0 one as the int the FMU returned)."""
    if fmi_type in ("Real", "Float64", "Float32"):
        return Carriage.FLOAT
    if fmi_type == "Boolean" and fmi3:
        return Carriage.BOOL
    return Carriage.UINT if fmi_type == "UInt64" else Carriage.INT


def compiled_form(component: Any, fmu: Any, fmi3: bool, plans: list[list[Any]],
                  error: Callable[[str, int, float], BaseException]) -> Kernel:
    """The `Kernel` of an instantiated fmpy slave `fmu` of `component` (an `FmuComponent`),
    from its call plans [inputs, feedthrough outputs, outputs after the step]
    (`FmuComponent._plan`: per FMI type the bound fmpy function, the value references, the
    value count and the ports); raises `NotCompilable` naming a port the loop cannot carry."""
    version = "fmi3" if fmi3 else "fmi2"
    types = _FMI3 if fmi3 else _FMI2
    ports = {p.name: p for p in component.ports}
    size = _SIZE
    io = ctypes.CFUNCTYPE(ctypes.c_int, *([size] * (5 if fmi3 else 4)))

    def address(symbol: str) -> int:
        return ctypes.cast(getattr(fmu.dll, symbol), ctypes.c_void_p).value or 0

    groups: list[tuple[FmuTransfer, ...]] = []
    params: list[Any] = []
    for plan in plans:
        group = []
        for fn, vrs, count, names, _ in plan:
            what = fn.__name__
            suffix = what[3:]
            for name, scalar, _ in names:
                port = ports[name]
                if port.display is not None:
                    raise NotCompilable(
                        f"port '{component.name}.{name}' is an alias in a display unit of its "
                        f"own, which the compiled loop does not convert")
                if port.fmi_type in ("String", "Binary", "Clock") or suffix not in types:
                    raise NotCompilable(
                        f"port '{component.name}.{name}' is {port.fmi_type}, which the "
                        f"compiled loop does not carry (it carries Real, Integer and Boolean "
                        f"values)")
                if not scalar and not types[suffix][1]:
                    raise NotCompilable(
                        f"port '{component.name}.{name}' is an array of {port.fmi_type}, and "
                        f"the compiled loop carries arrays of Real values only")
            call = f"{version}{what[:3].capitalize()}{suffix}"
            group.append(FmuTransfer(call, tuple((n, c) for n, _, c in names), len(vrs),
                                     count, types[suffix][1]))
            params.append((io(address(call)), np.asarray(vrs, dtype=np.uint32),
                           np.zeros(count, dtype=types[suffix][0])))
        groups.append(tuple(group))
    if fmi3:
        step = ctypes.CFUNCTYPE(ctypes.c_int, size, ctypes.c_double, ctypes.c_double,
                                ctypes.c_bool, size, size, size, size)
    else:
        step = ctypes.CFUNCTYPE(ctypes.c_int, size, ctypes.c_double, ctypes.c_double,
                                ctypes.c_int)
    instance = getattr(fmu.component, "value", fmu.component)
    head = (step(address(f"{version}DoStep")), int(instance), np.zeros(3, dtype=np.bool_),
            np.zeros(1))
    return Kernel(params=(*head, *params),
                  fmu=FmuCalls(fmi3, groups[0], groups[1], groups[2], error))


def call_names(calls: FmuCalls) -> list[str]:
    """The FMI functions of an FMU in the loop, by the index a failure reports."""
    prefix = "fmi3" if calls.fmi3 else "fmi2"
    return [t.call for t in (*calls.inputs, *calls.feedthrough, *calls.after_step)] + \
        [f"{prefix}DoStep"]


def call_lines(calls: FmuCalls, i: int, step: str | None, set_inputs: bool,
               local: Callable[[str], str], scalar: Callable[[str], bool]) -> list[str]:
    """The loop's lines for FMU component `i` (its parameters `p{i}`): at a communication
    point (`step` None) the inputs set and the feedthrough outputs got; for a step (`step` the
    time and step size) the inputs set first when `set_inputs`, doStep, the other outputs
    got. `local(port)` names a port's variable in the loop, `scalar(port)` whether it is a
    scalar. A failed call (status above Warning) leaves the loop with `fail`, `fstat` and
    `bad` set, after the other calls of its group (the set and get calls of one communication
    point, or the gets after a step; never a doStep after a failed set)."""
    lines: list[str] = []
    names = call_names(calls)
    transfers = (*calls.inputs, *calls.feedthrough, *calls.after_step)
    index = {id(t): k for k, t in enumerate(transfers)}

    def failed() -> None:
        lines.append(f"if g: fail = {CALLS * i + CALLS - 1} - (g & {CALLS - 1}); "
                     f"fstat = g >> 8; bad = n; break")

    def transfer(t: FmuTransfer, into: bool) -> None:
        k = index[id(t)]
        par, buf = f"p{i}[{4 + k}]", f"p{i}[{4 + k}][2]"
        j = 0
        if into:
            for port, width in t.ports:
                v = local(port)
                for e in range(width):
                    lines.append(f"{buf}[{j + e}] = {v if scalar(port) else f'{v}[{e}]'}")
                j += width
        tail = f", {t.count})" if calls.fmi3 else ")"
        lines.append(f"s = {par}[0](p{i}[1], {par}[1].ctypes.data, {t.nvr}, "
                     f"{buf}.ctypes.data{tail}")
        # the worst status of the group's calls, and the first call that gave it: one branch
        # per group (a branch per call makes numba's compilation slow)
        lines.append(f"g = max(g, (s > 1) * ((s << 8) | {CALLS - 1 - k}))")
        if not into:
            wrap = "float64" if t.real else "int64"
            if not t.real and t.call.endswith("UInt64"):
                wrap = "uint64"
            for port, width in t.ports:
                items = [f"{wrap}({buf}[{j + e}])" for e in range(width)]
                lines.append(f"{local(port)} = "
                             f"{items[0] if scalar(port) else '(' + ', '.join(items) + ',)'}")
                j += width

    def group(ts: tuple[FmuTransfer, ...], into: bool) -> None:
        if ts:
            lines.append("g = 0")
            for t in ts:
                transfer(t, into)
            failed()

    assert len(names) < CALLS
    if step is None:
        if calls.inputs or calls.feedthrough:
            lines.append("g = 0")
            for t in calls.inputs:
                transfer(t, True)
            for t in calls.feedthrough:
                transfer(t, False)
            failed()
        return lines
    if set_inputs:
        group(calls.inputs, True)
    code = CALLS * i + len(names) - 1
    if calls.fmi3:
        lines.append(f"s = p{i}[0](p{i}[1], {step}, True, p{i}[2].ctypes.data, "
                     f"p{i}[2].ctypes.data + 1, p{i}[2].ctypes.data + 2, p{i}[3].ctypes.data)")
        lines.append(f"if s > 1 or p{i}[2][1]: fail = {code}; "
                     f"fstat = s if s > 1 else {TERMINATE}; bad = n; break")
    else:
        lines.append(f"s = p{i}[0](p{i}[1], {step}, 1)")
        lines.append(f"if s > 1: fail = {code}; fstat = s; bad = n; break")
    group(calls.after_step, False)
    return lines
