"""The per-step calls of a co-simulation FMU made straight through its C functions, with the
value-reference and value arrays built once (`accessor`, `stepper`), in place of fmpy's methods,
which build both arrays and go through a Python wrapper at every call.

An accessor takes and returns what fmpy's does (`set(vrs, values)`; `get(vrs)` for FMI 2.0,
`get(vrs, count)` for FMI 3.0, a list) and has its name (`setReal`, `getInt8`, ...), so a call
plan holds either; the values go through the same ctypes conversions (a value array of the
call's C type, filled from the Python values), so they are the same bit for bit. A status above
Warning raises fmpy's `FMICallException`, as fmpy does.
"""
from __future__ import annotations

import ctypes
from collections.abc import Callable
from typing import Any

#: FMI call suffix -> the C value type of its array
_FMI2: dict[str, Any] = {"Real": ctypes.c_double, "Integer": ctypes.c_int,
                         "Boolean": ctypes.c_int}
_FMI3: dict[str, Any] = {
    "Float64": ctypes.c_double, "Float32": ctypes.c_float, "Int8": ctypes.c_int8,
    "UInt8": ctypes.c_uint8, "Int16": ctypes.c_int16, "UInt16": ctypes.c_uint16,
    "Int32": ctypes.c_int32, "UInt32": ctypes.c_uint32, "Int64": ctypes.c_int64,
    "UInt64": ctypes.c_uint64, "Boolean": ctypes.c_bool}


def c_function(fmu: Any, name: str) -> Any:
    """fmpy's instantiated `fmu`'s C function `name` with the argument and result types fmpy
    gave it (its shared library `fmu.dll` hands out the function it configured), or None when
    fmpy did not configure it (fmpy's own methods are then used)."""
    dll = getattr(fmu, "dll", None)
    fn = getattr(dll, name, None) if dll is not None else None
    return fn if getattr(fn, "argtypes", None) is not None else None


def direct_calls(fmu: Any) -> bool:
    """Whether `fmu`'s C functions can be called straight (fmpy configured them)."""
    return c_function(fmu, "fmi3DoStep" if hasattr(fmu, "fmi3DoStep") else "fmi2DoStep") \
        is not None


def supports(suffix: str, fmi3: bool) -> bool:
    """Whether values of FMI call suffix `suffix` ('Real', 'Int8', ...) have a direct
    accessor (not String nor Binary)."""
    return suffix in (_FMI3 if fmi3 else _FMI2)


def accessor(fmu: Any, fmi3: bool, suffix: str, which: int, vrs: list[int],
             count: int) -> Callable[..., Any]:
    """The getter (which=0) or setter (1) of value type `suffix` of fmpy's instantiated `fmu`
    for value references `vrs` carrying `count` values."""
    from fmpy.fmi1 import FMICallException

    version = "fmi3" if fmi3 else "fmi2"
    name = f"{version}{'Set' if which else 'Get'}{suffix}"
    fn = c_function(fmu, name)
    inst = fmu.component
    vr = (ctypes.c_uint * len(vrs))(*vrs)
    nvr = len(vrs)
    buf = (_FMI3 if fmi3 else _FMI2)[suffix] * count
    values = buf()
    tail = (count,) if fmi3 else ()

    if which:
        def set_(_: Any, given: list[Any]) -> None:
            values[:] = given
            status = fn(inst, vr, nvr, values, *tail)
            if status > 1:
                raise FMICallException(function=name, status=status)

        set_.__name__ = f"set{suffix}"
        return set_

    def get(*_: Any) -> list[Any]:
        status = fn(inst, vr, nvr, values, *tail)
        if status > 1:
            raise FMICallException(function=name, status=status)
        return values[:]

    get.__name__ = f"get{suffix}"
    return get


def stepper(fmu: Any, fmi3: bool) -> Callable[[float, float], bool]:
    """doStep(t, h) of fmpy's instantiated co-simulation `fmu`: True when the FMU asks to
    terminate the simulation (FMI 3.0's terminateSimulation; FMI 2.0 says so by a status)."""
    from fmpy.fmi1 import FMICallException

    if not fmi3:
        fn2 = c_function(fmu, "fmi2DoStep")
        inst2 = fmu.component

        def step2(t: float, h: float) -> bool:
            status = fn2(inst2, t, h, 1)
            if status > 1:
                raise FMICallException(function="fmi2DoStep", status=status)
            return False

        return step2
    fn = c_function(fmu, "fmi3DoStep")
    inst = fmu.component
    flags = [ctypes.c_bool() for _ in range(3)]
    last = ctypes.c_double()
    refs = (*(ctypes.byref(f) for f in flags), ctypes.byref(last))
    terminate = flags[1]

    def step3(t: float, h: float) -> bool:
        status = fn(inst, t, h, True, *refs)
        if status > 1:
            raise FMICallException(function="fmi3DoStep", status=status)
        return terminate.value

    return step3


def event_stepper(fmu: Any) -> Callable[[float, float], tuple[bool, bool, bool, float]] | None:
    """fmi3DoStep(t, h) of fmpy's instantiated FMI 3.0 co-simulation `fmu` in event mode, as
    fmpy's `doStep` returns it: (eventHandlingNeeded, terminateSimulation, earlyReturn,
    lastSuccessfulTime), with its flags made once; None when fmpy did not configure the call."""
    from fmpy.fmi1 import FMICallException

    fn = c_function(fmu, "fmi3DoStep")
    if fn is None:
        return None
    inst = fmu.component
    needed, terminate, early = ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool()
    last = ctypes.c_double()
    refs = (ctypes.byref(needed), ctypes.byref(terminate), ctypes.byref(early),
            ctypes.byref(last))

    def step(t: float, h: float) -> tuple[bool, bool, bool, float]:
        status = fn(inst, t, h, True, *refs)
        if status > 1:
            raise FMICallException(function="fmi3DoStep", status=status)
        return needed.value, terminate.value, early.value, last.value

    step.__name__ = "doStep"
    return step

