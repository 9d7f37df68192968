"""A co-simulation FMU as a kind of block of the compiled driver (`twmr.master.driver`): no code
generated per scenario, one adapter module per kind of FMU call (compiled once, then loaded
from numba's cache), so the compile does not grow with the number of FMU instances.

A kind (`FmuShape`) is what the calls look like: FMI 2.0 or 3.0, each set or get call's FMI
function, number of value references and values, and where in the block's port area of the
driver's vector S each value is. The addresses (the instance, the C functions, the value
references and the value buffers of the FMU's compiled form, `compiled_calls.compiled_form`)
are the block's parameters in P, so every instance of a kind, of any FMU file with the same
calls, runs the same machine code. The calls, their order, the values and the statuses are
those of the generated loop (`compiled_calls.call_lines`): the adapters return 0, or the worst
status above Warning of a group of calls and the first call giving it, coded as there
(status << 8 | CALLS - 1 - the call's index in `call_names`; status 255: fmi3DoStep asked to
terminate).

The driver holds port values as float64: an FMU's Real ports (FMI 2.0 Real, FMI 3.0 Float64
and Float32) are in its vectors, its other ports are not (`real_ports`); an FMU that sets or
gets a port of another type (wired or recorded) keeps the generated loop."""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

from twmr.fmi.compiled_calls import CALLS, FmuCalls, call_names

#: the C buffer each Real call carries its values in
_BUFFERS = {"Real": "f64", "Float64": "f64", "Float32": "f32"}
#: the adapter's code of fmi3DoStep's request to terminate
TERMINATE_CODE = 255
#: the most an address may be to be held exactly in a float64
_EXACT = 2 ** 53


class NotInDriver(Exception):
    """An FMU the driver cannot call (its text says why)."""


@dataclass(frozen=True)
class FmuTransferShape:
    """One set or get call: the FMI function, how many value references and values, the C
    buffer ('f64' or 'f32') and the offset in the block's port area of each value."""

    call: str
    nvr: int
    count: int
    buffer: str
    offsets: tuple[int, ...]


@dataclass(frozen=True)
class FmuShape:
    """The calls of one kind of FMU (see the module docstring); `set_inputs`: the step sets
    the inputs first (an FMU without feedthrough is not evaluated at the points)."""

    fmi3: bool
    set_inputs: bool
    inputs: tuple[FmuTransferShape, ...]
    feedthrough: tuple[FmuTransferShape, ...]
    after_step: tuple[FmuTransferShape, ...]


def fmu_shape(comp: Any, calls: FmuCalls) -> FmuShape:
    """The `FmuShape` of FMU component `comp` with compiled calls `calls`; `NotInDriver` for a
    call of a type other than Real."""
    offsets: dict[str, int] = {}
    width = 0
    for port, var in real_ports(comp).items():
        offsets[port] = width
        width += var.width

    def shape(group: tuple[Any, ...]) -> tuple[FmuTransferShape, ...]:
        out = []
        for t in group:
            suffix = t.call[len("fmi2Set"):]
            if suffix not in _BUFFERS:
                raise NotInDriver(f"'{comp.name}' calls {t.call}: the driver carries Real "
                                  f"values only")
            out.append(FmuTransferShape(t.call, t.nvr, t.count, _BUFFERS[suffix], tuple(
                offsets[port] + e for port, n in t.ports for e in range(n))))
        return tuple(out)

    made = FmuShape(calls.fmi3, not comp.has_feedthrough, shape(calls.inputs),
                    shape(calls.feedthrough), shape(calls.after_step))
    if len(made.inputs) + len(made.feedthrough) + len(made.after_step) + 1 >= CALLS:
        raise NotInDriver(f"'{comp.name}' makes more calls than the driver numbers")
    return made


def real_ports(comp: Any) -> dict[str, Any]:
    """The ports of FMU component `comp` the driver holds (outputs, then inputs, declared
    order): its Real ones."""
    return {p: v for p, v in {**comp.outputs, **comp.inputs}.items() if v.type == "Real"}


def fmu_params(params: tuple[Any, ...]) -> tuple[float, ...]:
    """The block's parameters in P: the addresses of the FMU's compiled form `params`
    (`compiled_calls.compiled_form`: doStep, the instance, doStep's flags and last time, then
    per call its function, value references and buffer), as float64 (exact below 2**53)."""
    step, instance, flags, last, *calls = params
    values = [_address(step), int(instance), flags.ctypes.data, last.ctypes.data]
    for fn, vrs, buf in calls:
        values += [_address(fn), vrs.ctypes.data, buf.ctypes.data]
    if any(not 0 <= v < _EXACT for v in values):
        raise NotInDriver("an address of the FMU is beyond what a float64 holds exactly")
    return tuple(float(v) for v in values)


def _address(fn: Any) -> int:
    return ctypes.cast(fn, ctypes.c_void_p).value or 0


def adapters(shape: FmuShape) -> str:
    """Source of the kind's `ev` (at a point: set the inputs, get the feedthrough outputs) and
    `st` (a step: the inputs set first if `set_inputs`, doStep, the outputs got), of the
    driver's adapter signature."""
    transfers = (*shape.inputs, *shape.feedthrough, *shape.after_step)
    index = {id(t): k for k, t in enumerate(transfers)}
    io = "io5" if shape.fmi3 else "io4"
    lines: list[str] = []

    def add(indent: int, text: str) -> None:
        lines.append("    " * indent + text)

    def head(name: str) -> None:
        add(0, "@njit(cache=True, error_model='numpy')")
        add(0, f"def {name}(t, h, Sp, Xp, Pp, nS, nX, nP, so, xo, po):")
        add(1, "inst = int(Pp[po + 1])")

    def transfer(t: FmuTransferShape, into: bool) -> None:
        k = index[id(t)]
        at = 4 + 3 * k
        add(1, f"b{k} = {t.buffer}_at(int(Pp[po + {at + 2}]))")
        if into:
            for j, o in enumerate(t.offsets):
                add(1, f"b{k}[{j}] = Sp[so + {o}]")
        tail = f", {t.count}" if shape.fmi3 else ""
        add(1, f"s = {io}(int(Pp[po + {at}]), inst, int(Pp[po + {at + 1}]), {t.nvr}, "
               f"int(Pp[po + {at + 2}]){tail})")
        add(1, f"g = max(g, (s > 1) * ((s << 8) | {CALLS - 1 - k}))")
        if not into:
            for j, o in enumerate(t.offsets):
                add(1, f"Sp[so + {o}] = float64(b{k}[{j}])")

    head("ev")
    add(1, "g = 0")
    for t in shape.inputs:
        transfer(t, True)
    for t in shape.feedthrough:
        transfer(t, False)
    add(1, "return g")
    add(0, "")
    add(0, "")
    head("st")
    add(1, "g = 0")
    if shape.set_inputs:
        for t in shape.inputs:
            transfer(t, True)
        add(1, "if g:")
        add(2, "return g")
    step = CALLS - 1 - len(transfers)  # doStep: the last of `call_names`
    if shape.fmi3:
        add(1, "flags = int(Pp[po + 2])")
        add(1, "s = do_step3(int(Pp[po]), inst, t, h, flags, int(Pp[po + 3]))")
        add(1, "if s > 1:")
        add(2, f"return (s << 8) | {step}")
        add(1, "if u8_at(flags)[1]:")
        add(2, f"return ({TERMINATE_CODE} << 8) | {step}")
    else:
        add(1, "s = do_step2(int(Pp[po]), inst, t, h)")
        add(1, "if s > 1:")
        add(2, f"return (s << 8) | {step}")
    for t in shape.after_step:
        transfer(t, False)
    add(1, "return g")
    head_lines = ["# generated by twmr.fmi.driver_kind: the adapters of one kind of FMU call",
                  "from numba import njit",
                  "from numpy import float64",
                  "from twmr.fmi.c_calls import do_step2, do_step3, f32_at, f64_at, io4, io5, "
                  "u8_at", "", ""]
    return "\n".join(head_lines + lines) + "\n"


def failure(calls: FmuCalls, code: int) -> tuple[str, int]:
    """(the FMI function, its status) of an adapter's return `code` (status -1: fmi3DoStep
    asked to terminate, as `compiled_calls.TERMINATE`)."""
    from twmr.fmi.compiled_calls import TERMINATE

    status = code >> 8
    return (call_names(calls)[CALLS - 1 - (code & (CALLS - 1))],
            TERMINATE if status == TERMINATE_CODE else status)
