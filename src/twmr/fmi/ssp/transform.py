"""`SspMap`: the component an SSP connection transformation puts on its wire.

One input `u`, one output `y` = f(u), direct feedthrough: `factor * u + offset` for a linear
transformation (with the unit conversion between the connectors' units folded in; its kernel,
`linear_evaluate`, also runs in the compiled loop between Real ports), or a table for a boolean,
integer or enumeration mapping (values the table does not list pass unchanged)."""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

from twmr.core.component import Component
from twmr.core.kernel import Kernel, kernel_function
from twmr.core.port import Input, Output

_ZERO = {"Real": 0.0, "Integer": 0, "Boolean": False}


class LinearParams(NamedTuple):
    """y = factor * u + offset."""

    factor: float
    offset: float


@kernel_function
def linear_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: LinearParams
                    ) -> tuple[tuple, tuple]:
    """y = factor u + offset (SSP LinearTransformation after the unit conversion)."""
    return x, (p.factor * u[0] + p.offset,)


class SspMap(Component):
    """y = factor * u + offset, or y = table[u]; `u` and `y` of the types and units of the
    connectors the SSP connection joins."""

    kind = "ssp_map"
    construction_parameters = ("in_type", "out_type", "in_unit", "out_unit", "factor", "offset",
                               "table")

    def __init__(self, name: str = "", in_type: str = "Real", out_type: str = "Real",
                 in_unit: str = "", out_unit: str = "", factor: float = 1.0,
                 offset: float = 0.0, table: Sequence[Sequence[Any]] = ()):
        super().__init__(name)
        u = Input(_ZERO[in_type], type=in_type, unit=in_unit)
        y = Output(_ZERO[out_type], type=out_type, unit=out_unit, depends_on=("u",))
        u.name, y.name = "u", "y"
        self.variables = {"u": u, "y": y}
        self.__dict__.update(u=u.start, y=y.start)
        self.params = LinearParams(float(factor), float(offset))
        self.table = {k: v for k, v in table}
        casts: dict[str, Callable[[Any], Any]] = {"Real": float, "Integer": round,
                                                  "Boolean": bool}
        self._cast = casts[out_type]
        self._linear = not self.table and in_type == out_type == "Real"

    def kernel(self, h: float) -> Kernel | None:
        """The linear map between Real ports; None for a table or other types."""
        if not self._linear:
            return None
        return Kernel(params=self.params, evaluate=linear_evaluate)

    def initialize(self) -> None:
        self.evaluate(0.0)

    def do_step(self, t: float, h: float) -> None:
        """No state: `y` follows `u` in `evaluate`."""

    def evaluate(self, t: float) -> None:
        u = self.__dict__["u"]
        if self.table:
            self.__dict__["y"] = self._cast(self.table.get(u, u))
        elif self._linear:
            self.kernel_evaluate(t)
        else:
            self.__dict__["y"] = self._cast(linear_evaluate(t, (), (), (u,), self.params)[1][0])
