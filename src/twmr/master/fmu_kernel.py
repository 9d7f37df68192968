"""FMUs inside the compiled loop: an FMI 2.0 co-simulation FMU (`FmuComponent`, Real ports, run in
this process) called by the generated loop through its C function pointers — fmi2SetReal,
fmi2GetReal, fmi2DoStep with preallocated value-reference and value arrays — instead of fmpy's
Python wrappers. The calls and their order are those of `FmuComponent.evaluate` / `do_step`: the
wired inputs in one fmi2SetReal (at `evaluate` when the FMU has feedthrough, else before the
step), the feedthrough outputs read in one fmi2GetReal, after fmi2DoStep the other outputs the
run reads. FMI 3.0, model exchange, isolated FMUs and non-Real ports keep the Python loop.
"""
from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from twmr.master.compiled import FmuCalls, Kernel

_STATUS = {2: "fmi2Discard", 3: "fmi2Error", 4: "fmi2Fatal", 5: "fmi2Pending"}


def _ports(plan: list[Any]) -> tuple[tuple[tuple[str, int], ...], np.ndarray] | None:
    """(ports [(name, width)], value references) of an `FmuComponent` call plan holding Real
    values only (one entry), or None."""
    if not plan:
        return (), np.zeros(0, dtype=np.uint32)
    if len(plan) > 1 or plan[0][0].__name__ not in ("setReal", "getReal"):
        return None
    _, vrs, _, names, _ = plan[0]
    return tuple((name, count) for name, _, count in names), np.asarray(vrs, dtype=np.uint32)


def fmu_kernel(comp: Any, h: float) -> Kernel | None:
    """The compiled form of FMU block `comp` (initialized), or None when it cannot have one."""
    fmu = getattr(comp, "_fmu", None)
    if fmu is None or comp.me or comp.fmi3 or comp._pythonfmu or not hasattr(fmu, "dll"):
        return None
    plans = [_ports(p) for p in (comp._set_all, comp._get_ft, comp._get_step)]
    if any(p is None for p in plans):
        return None
    (ins, in_vrs), (ft, ft_vrs), (st, st_vrs) = plans  # type: ignore[misc]
    size = ctypes.c_size_t
    io = ctypes.CFUNCTYPE(ctypes.c_int, size, size, size, size)
    step = ctypes.CFUNCTYPE(ctypes.c_int, size, ctypes.c_double, ctypes.c_double, ctypes.c_int)

    def address(symbol: str) -> int:
        return ctypes.cast(getattr(fmu.dll, symbol), ctypes.c_void_p).value or 0

    instance = getattr(fmu.component, "value", fmu.component)
    values = np.zeros(max(1, len(in_vrs), len(ft_vrs), len(st_vrs)))
    params = (io(address("fmi2SetReal")), io(address("fmi2GetReal")),
              step(address("fmi2DoStep")), int(instance), in_vrs, ft_vrs, st_vrs, values)

    def error(call: str, status: int, t: float) -> BaseException:
        from twmr.core.errors import FmuError

        comp._t = t
        if call == "fmi2DoStep" and status == 2 and comp._fmi2_terminated():
            return FmuError(comp.name, t, f"FMU '{comp.path.name}' asked to terminate the "
                            f"simulation (fmi2DoStep returned fmi2Discard and fmi2Terminated is "
                            f"true).", comp.log.tail())
        return FmuError(comp.name, t, f"FMU '{comp.path.name}': {call} returned "
                        f"{_STATUS.get(status, status)}. Fix: see the FMU's log; check its "
                        f"inputs and parameters at this time.", comp.log.tail())

    return Kernel(params=params, fmu=FmuCalls(ins, ft, st, error))
