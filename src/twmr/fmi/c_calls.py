"""Calls of an FMU's C functions, and its value buffers, by their addresses at run time, from
numba code (the FMU kinds of the compiled driver, `twmr.fmi.driver_kind`): one compiled adapter
serves every instance of a kind, whatever the addresses of its functions and buffers.

Imported only when a run is compiled (it imports numba)."""
from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

_I64 = types.int64


@intrinsic
def io4(typingctx: Any, fn: Any, a: Any, b: Any, c: Any, d: Any) -> Any:
    """int fn(size_t, size_t, size_t, size_t) at address `fn`: an FMI 2.0 set or get call
    (instance, value references, their number, values)."""
    return _io(4)


@intrinsic
def io5(typingctx: Any, fn: Any, a: Any, b: Any, c: Any, d: Any, e: Any) -> Any:
    """int fn(size_t x 5) at address `fn`: an FMI 3.0 set or get call (instance, value
    references, their number, values, their number)."""
    return _io(5)


def _io(n: int) -> tuple[Any, Any]:
    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        word = ir.IntType(64)
        fnty = ir.FunctionType(ir.IntType(32), [word] * n)
        status = builder.call(builder.inttoptr(args[0], fnty.as_pointer()), list(args[1:]))
        return builder.sext(status, word)

    return _I64(*(_I64,) * (n + 1)), codegen


@intrinsic
def do_step2(typingctx: Any, fn: Any, instance: Any, t: Any, h: Any) -> Any:
    """fmi2DoStep(instance, t, h, noSetFMUStatePriorToCurrentPoint = true) at address `fn`."""
    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        word, dbl, i32 = ir.IntType(64), ir.DoubleType(), ir.IntType(32)
        fnty = ir.FunctionType(i32, [word, dbl, dbl, i32])
        status = builder.call(builder.inttoptr(args[0], fnty.as_pointer()),
                              [args[1], args[2], args[3], ir.Constant(i32, 1)])
        return builder.sext(status, word)

    return _I64(_I64, _I64, types.float64, types.float64), codegen


@intrinsic
def do_step3(typingctx: Any, fn: Any, instance: Any, t: Any, h: Any, flags: Any,
             last: Any) -> Any:
    """fmi3DoStep(instance, t, h, noSetFMUStatePriorToCurrentPoint = true, the three bools at
    address `flags` (event handling needed, terminate, early return), the last successful
    time at address `last`) at address `fn`."""
    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        word, dbl, i32, i8 = ir.IntType(64), ir.DoubleType(), ir.IntType(32), ir.IntType(8)
        fnty = ir.FunctionType(i32, [word, dbl, dbl, i8, word, word, word, word])
        flags = args[4]
        status = builder.call(builder.inttoptr(args[0], fnty.as_pointer()),
                              [args[1], args[2], args[3], ir.Constant(i8, 1), flags,
                               builder.add(flags, ir.Constant(word, 1)),
                               builder.add(flags, ir.Constant(word, 2)), args[5]])
        return builder.sext(status, word)

    return _I64(_I64, _I64, types.float64, types.float64, _I64, _I64), codegen


def _pointer_to(item: Any) -> tuple[Any, Any]:
    ptr = types.CPointer(item)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(ptr))

    return ptr(_I64), codegen


@intrinsic
def f64_at(typingctx: Any, addr: Any) -> Any:
    """The float64 buffer at address `addr`."""
    return _pointer_to(types.float64)


@intrinsic
def f32_at(typingctx: Any, addr: Any) -> Any:
    """The float32 buffer at address `addr`."""
    return _pointer_to(types.float32)


@intrinsic
def u8_at(typingctx: Any, addr: Any) -> Any:
    """The uint8 (C bool) buffer at address `addr`."""
    return _pointer_to(types.uint8)
