"""`elementwise`: a kernel function of scalars applied to every element of a vector port.

An element-wise block (`Component.sized_by`) holds a port of size n as a float (n = 1) or a
tuple of n floats. Its kernel writes the operation once, for one element:

    @elementwise
    def clip(v: float, p: SaturationParams) -> float:
        return p.lower if v < p.lower else (p.upper if v > p.upper else v)

and calls `clip(u[0], p)`: on floats it is the function itself; when some arguments are plain
tuples (not NamedTuples) it returns the tuple of the function applied to their elements i, the
other arguments passed whole (broadcast). In Python this runs as plain Python; in compiled code
numba types each call by the tuples' length and unrolls it, so the loop holds the result as a
tuple of the same type. numba is imported only when compiled code first refers to it.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from twmr.core.kernel import KernelFunction


def _mapped(arg: Any) -> bool:
    return type(arg) is tuple


class ElementWise:
    """A kernel function of scalars, mapped over the tuples among its arguments (see the
    module's docstring); `fn` is a plain function or a `KernelFunction`."""

    def __init__(self, fn: Callable[..., Any]):
        functools.update_wrapper(self, fn)
        self.fn = fn if isinstance(fn, KernelFunction) else KernelFunction(fn)
        self.name: str = getattr(fn, "__name__", "elementwise")
        self._type: Any = None

    def __call__(self, *args: Any) -> Any:
        f = self.fn.py_func
        sizes = {len(a) for a in args if _mapped(a)}
        if not sizes:
            return f(*args)
        if len(sizes) > 1:
            raise ValueError(f"{self.name}: tuples of different lengths {sorted(sizes)}")
        n = sizes.pop()
        return tuple(f(*(a[i] if _mapped(a) else a for a in args)) for i in range(n))

    @property
    def _numba_type_(self) -> Any:
        """The numba type of this object: an overload whose implementation is generated for
        the argument types of each call (the element calls unrolled)."""
        if self._type is None:
            from numba.core import types
            from numba.core.typing.templates import infer, make_overload_template

            fn = self.fn

            def typer(*args: Any) -> Callable[..., Any]:
                names = [f"a{i}" for i in range(len(args))]
                tuples = [type(a) is types.UniTuple for a in args]
                sizes = {a.count for a, t in zip(args, tuples, strict=True) if t}
                if len(sizes) > 1:
                    raise TypeError(f"{self.name}: tuples of different lengths "
                                    f"{sorted(sizes)}")
                n = sizes.pop() if sizes else None

                def call(i: int | None) -> str:
                    return "f(" + ", ".join(
                        f"{v}[{i}]" if t and i is not None else v
                        for v, t in zip(names, tuples, strict=True)) + ")"
                body = call(None) if n is None else "(" + "".join(
                    call(i) + ", " for i in range(n)) + ")"
                env: dict[str, Any] = {"f": fn}
                exec(f"def impl({', '.join(names)}):\n    return {body}\n", env)  # noqa: S102
                return env["impl"]

            template = make_overload_template(self, typer, {"no_cpython_wrapper": True},
                                              False, "never", False)
            infer(template)
            self._type = types.Function(template)
        return self._type

    def __deepcopy__(self, memo: dict[int, Any]) -> ElementWise:
        return self

    def __repr__(self) -> str:
        return f"<element-wise kernel function {self.fn!r}>"


def elementwise(fn: Callable[..., Any]) -> ElementWise:
    """Decorator of a module-level kernel function of scalars: applied element by element to
    the tuples among its arguments (see the module's docstring)."""
    return ElementWise(fn)


__all__ = ["ElementWise", "elementwise"]
