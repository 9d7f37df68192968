"""Signal-routing blocks: mux, demux, selector, product, math (and `gain`, `sum` in
`twmr.blocks.linear`). Each is defined by its kernel (`twmr.blocks.routing_kernels`). Their
ports carry no unit (''), so a signal keeps the unit of its source."""
from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

from twmr.blocks import routing_kernels as rk
from twmr.blocks.ports import numbered, resized
from twmr.core.component import Component
from twmr.core.ctwin import Choice, CTwin, initialiser, nary_sizes, width_of
from twmr.core.errors import CosimError
from twmr.core.kernel import Kernel
from twmr.core.port import INTEGER, STRING, Input, Output, Parameter


def _size(n: int) -> int | None:
    return None if n == 1 else int(n)


class Nary(Component):
    """A block of inputs u1 .. uk (u1 and u2 declared), one per character of the text parameter
    `OPS` (its `ALPHABET`), each `n` elements wide like y (element-wise)."""

    OPS: ClassVar[str] = ""
    ALPHABET: ClassVar[str] = ""
    n = Parameter(1, type=INTEGER, min=1, description="number of elements of each port")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.sizing_parameters = frozenset({"n", cls.OPS})

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name in ("n", self.OPS):
            ops = self.get(self.OPS)
            if len(ops) < 2 or set(ops) - set(self.ALPHABET):
                raise ValueError(f"expected at least two of {' '.join(self.ALPHABET)}, one per "
                                 f"input, got {ops!r}")
            numbered(self, "u", len(ops), self.variables["u1"], _size(self.n))
            self.variables["y"] = resized(self.variables["y"], _size(self.n))
            self.__dict__["y"] = self.variables["y"].start
            self.outputs["y"].depends_on = tuple(self.inputs)

    def initialize(self) -> None:
        self.evaluate(self.start_time)


class Product(Nary):
    """Product and quotient of n inputs, element-wise.

    y = ((1 op1 u1) op2 u2) ..., each op '*' or '/' (`ops`, one per input)."""

    kind = "product"
    OPS, ALPHABET = "ops", "*/"
    ops = Parameter("**", type=STRING, description="'*' or '/' per input, e.g. '**/'")
    u1 = Input(0.0)
    u2 = Input(0.0)
    y = Output(0.0, depends_on=("u1", "u2"))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"ops": "**"}, {"ops": "*/*"}, {"ops": "/*", "n": 2})

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=rk.NaryParams(tuple(1.0 if c == "*" else -1.0 for c in self.ops)),
                      evaluate=rk.product_evaluate)


class Mux(Component):
    """y = (u1, u2, ..., u<n_in>): n_in ports of `width` elements each, concatenated."""

    kind = "mux"
    sizing_parameters = frozenset({"n_in", "width"})
    n_in = Parameter(2, type=INTEGER, min=1, description="number of inputs")
    width = Parameter(1, type=INTEGER, min=1, description="elements of each input")
    u1 = Input(0.0)
    u2 = Input(0.0)
    y = Output((0.0, 0.0), size=2, depends_on=("u1", "u2"))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"n_in": 3}, {"n_in": 2, "width": 3})

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name in self.sizing_parameters:
            if self.n_in * self.width < 2:
                raise ValueError("a mux of one element makes no vector: give n_in * width >= 2")
            numbered(self, "u", self.n_in, self.variables["u1"], _size(self.width))
            self.variables["y"] = resized(self.variables["y"], self.n_in * self.width)
            self.__dict__["y"] = self.variables["y"].start
            self.outputs["y"].depends_on = tuple(self.inputs)

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(evaluate=rk.mux_evaluate)


class Demux(Component):
    """(y1, ..., y<n_out>) = u cut into n_out parts of `width` elements each."""

    kind = "demux"
    sizing_parameters = frozenset({"n_out", "width"})
    n_out = Parameter(2, type=INTEGER, min=1, description="number of outputs")
    width = Parameter(1, type=INTEGER, min=1, description="elements of each output")
    u = Input((0.0, 0.0), size=2)
    y1 = Output(0.0, depends_on=("u",))
    y2 = Output(0.0, depends_on=("u",))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"n_out": 3}, {"n_out": 2, "width": 2})

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name in self.sizing_parameters:
            if self.n_out * self.width < 2:
                raise ValueError("a demux of one element cuts no vector: give n_out * width "
                                 ">= 2")
            self.variables["u"] = resized(self.variables["u"], self.n_out * self.width)
            self.__dict__["u"] = self.variables["u"].start
            numbered(self, "y", self.n_out, self.variables["y1"], _size(self.width))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(evaluate=rk.demux_evaluate)


class Selector(Component):
    """y_i = u[indices_i] (1-based): picks and reorders elements of an input of `width`."""

    kind = "selector"
    sizing_parameters = frozenset({"width", "indices"})
    width = Parameter(2, type=INTEGER, min=1, description="elements of the input")
    indices = Parameter((1,), size=0, type=INTEGER, description="1-based elements picked")
    u = Input((0.0, 0.0), size=2)
    y = Output(0.0, depends_on=("u",))

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({}, {"width": 3, "indices": [3, 1]}, {"width": 4, "indices": [2, 2, 4]},
                {"width": 1, "indices": [1]})

    def set_parameter(self, name: str, value: Any) -> None:
        super().set_parameter(name, value)
        if name in self.sizing_parameters:
            self.variables["u"] = resized(self.variables["u"], _size(self.width))
            self.__dict__["u"] = self.variables["u"].start
            self.variables["y"] = resized(self.variables["y"], _size(max(1, len(self.indices))))
            self.__dict__["y"] = self.variables["y"].start

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        bad = [i for i in self.indices if not 1 <= i <= self.width]
        if not self.indices or bad:
            return [("indices", f"indices {list(self.indices)} name elements outside 1 .. "
                     f"{self.width} of the input.", f"give indices from 1 to {self.width} "
                     f"(the input's width), at least one.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        picks = tuple(min(max(i, 1), self.width) - 1 for i in self.indices)
        return Kernel(params=rk.SelectParams(picks), evaluate=rk.selector_evaluate)


class Math(Component):
    """y = f(u), f named by `function` (abs, sqrt, exp, sin, ...), element-wise.

    f is one of abs, sqrt, exp, log, log10, sin, cos, tan, asin, acos, atan, tanh, square (u^2),
    reciprocal (1/u), sign. Outside its domain
    f gives NaN (sqrt, log of a negative; asin, acos beyond 1), which the run reports."""

    kind = "math"
    sized_by: ClassVar[dict[str, str]] = {"u": "n", "y": "n"}
    n = Parameter(1, type=INTEGER, min=1, description="number of elements")
    function = Parameter("abs", type=STRING, description=" | ".join(rk.FUNCTIONS))
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.function not in rk.FUNCTIONS:
            return [("function", f"function '{self.function}' is not known.",
                     f"use one of {' | '.join(rk.FUNCTIONS)}.")]
        return []

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=rk.MathParams(float(rk.FUNCTIONS.get(self.function, 0))),
                      evaluate=rk.math_evaluate)


# -- C twins (`twmr export KIND`: a standalone C FMU from c/<kind>.c) ------------------------------
C = Path(__file__).parent / "c"


def _selector(comp: Component) -> dict[str, int | str]:
    width, index = comp.get("width"), comp.get("indices")
    if not index or not all(1 <= i <= width for i in index):
        raise CosimError(f"export selector: indices {list(index)} name elements outside 1 .. "
                         f"{width}. Fix: give indices from 1 to the input's width.")
    return {"SEL_M": len(index), "SEL_INDEX": initialiser([i - 1 for i in index])}


Mux.c_twin = CTwin(C / "mux.c", sizes=lambda comp: {"MUX_LEN": width_of(comp, "y")})
Demux.c_twin = CTwin(C / "demux.c", sizes=lambda comp: {"MUX_LEN": width_of(comp, "u")})
Selector.c_twin = CTwin(C / "selector.c", sizes=_selector)
Product.c_twin = CTwin(C / "product.c", sizes=nary_sizes("PROD", "ops", "*/"))
Math.c_twin = CTwin(C / "math.c", choices={"function": Choice("MATH_FN", rk.FUNCTIONS)},
                    sizes=lambda comp: {"N_EL": comp.get("n"), "EXP_MAX": repr(rk.EXP_MAX)})
