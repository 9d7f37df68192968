"""The compiled form of a block: `Kernel`, and `kernel_function` to write its functions once.

A kernel is two pure functions of the block's private state x (a tuple, or a `NamedTuple`), its
outputs y (the tuple of its output and state ports, declared order), its inputs u (the tuple of
its input ports, declared order) and its parameters p (one `NamedTuple` per block, read by field
name):

    evaluate(t, x, y, u, p) -> (x, y)        # the feedthrough outputs at t (FMI: get after set)
    step(t, h, x, y, u, p) -> (x, y)         # advance from t to t + h [s] with u held

They are the block's definition: its Python `evaluate`/`do_step` run them
(`Component.kernel_evaluate`, `kernel_do_step`) and the compiled loop (`twmr.master.compiled`)
calls them, so both give the same numbers by construction. A function decorated with
`kernel_function` runs as plain Python (numba is not even imported) and is compiled by numba only
when compiled code calls it; a numba `@njit` function may be given as well (it then runs
compiled in Python too).
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


class KernelFunction:
    """A kernel function (see `kernel_function`): called from Python it runs `py_func` as plain
    Python; numba code that calls it (the generated loop, another kernel function) compiles it
    with `njit(cache=True, error_model='numpy')` on first use.

    Each one is an instance of a subclass of its own whose ``__call__`` is `py_func` itself, so
    a call from Python costs what a call of `py_func` does (one kernel function calling another
    runs at every step)."""

    py_func: Callable[..., Any]

    def __new__(cls, fn: Callable[..., Any]) -> KernelFunction:
        own = type(cls.__name__, (cls,), {"__call__": staticmethod(fn), "__slots__": (),
                                          "__module__": cls.__module__})
        return super().__new__(own)

    def __init__(self, fn: Callable[..., Any]):
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self._jit: Any = None

    def __call__(self, *args: Any) -> Any:  # replaced by `py_func` in each instance's class
        return self.py_func(*args)

    def __reduce__(self) -> str:
        # pickled by reference, as the module-level name it is (`functools.update_wrapper`)
        return str(self.__qualname__)  # type: ignore[attr-defined]

    @property
    def jit(self) -> Any:
        """The numba dispatcher of `py_func` (numba imported, and the function compiled, on first
        call)."""
        if self._jit is None:
            from numba import njit

            self._jit = njit(cache=True, error_model="numpy")(self.py_func)
        return self._jit

    @property
    def _numba_type_(self) -> Any:
        """How numba types this object when compiled code refers to it: as its dispatcher."""
        from numba.core import types

        return types.Dispatcher(self.jit)

    def __deepcopy__(self, memo: dict[int, Any]) -> KernelFunction:
        return self

    def __repr__(self) -> str:
        return f"<kernel function {self.__module__}.{getattr(self, '__qualname__', '?')}>"


def kernel_function(fn: Callable[..., Any]) -> KernelFunction:
    """Decorator of a kernel function (or a helper it calls), defined at module level: plain
    Python when called from Python, numba-compiled when called from compiled code. Write it in
    the subset of Python that numba compiles (floats, tuples, NamedTuples, math, numpy)."""
    return KernelFunction(fn)


@dataclass(frozen=True)
class Kernel:
    """A component's compiled form: the functions `evaluate(t, x, y, u, p) -> (x, y)` and
    `step(t, h, x, y, u, p) -> (x, y)` (either None; `kernel_function`s or numba functions), its
    parameter table `params` (a NamedTuple of floats, tuples of floats or numpy arrays) and its
    initial private state `state`, and `sync(x)`, called with the state after every chunk of
    compiled steps (and after every Python call) so the component can report (e.g. log a
    warning)."""

    params: tuple = ()
    state: tuple = ()
    evaluate: Any = None
    step: Any = None
    sync: Callable[[Any], None] | None = None
    #: an FMU the loop calls itself through its C function pointers (`twmr.master.fmu_kernel`)
    fmu: FmuCalls | None = None

    def __deepcopy__(self, memo: dict[int, Any]) -> Kernel:
        return self  # immutable: a saved component state shares it


@dataclass(frozen=True)
class FmuCalls:
    """What the generated loop needs to call an FMI 2.0 co-simulation FMU: the ports each call
    carries, [(port, width)] in the order of their value references. The parameters of its
    `Kernel` are (fmi2SetReal, fmi2GetReal, fmi2DoStep as ctypes functions taking pointers as
    size_t, the instance, the value references of the inputs, of the feedthrough outputs and of
    the outputs read after a step (uint32 arrays), a float64 value buffer); a status above
    fmi2Warning stops the run, reported by `error(call, status, t)`."""

    inputs: tuple[tuple[str, int], ...]
    feedthrough: tuple[tuple[str, int], ...]
    after_step: tuple[tuple[str, int], ...]
    error: Callable[[str, int, float], BaseException]


__all__ = ["FmuCalls", "Kernel", "KernelFunction", "kernel_function"]
