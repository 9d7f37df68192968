"""`SspMap`: the component an SSP connection transformation puts on its wire.

One input `u`, one output `y` = f(u), direct feedthrough: `factor * u + offset` for a linear
transformation (with the unit conversion between the connectors' units folded in), or a table for
a boolean, integer or enumeration mapping (values the table does not list pass unchanged)."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from twmr.core.component import Component
from twmr.core.port import Input, Output

_ZERO = {"Real": 0.0, "Integer": 0, "Boolean": False}


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
        self.factor, self.offset = float(factor), float(offset)
        self.table = {k: v for k, v in table}
        self._cast = {"Real": float, "Integer": int, "Boolean": bool}[out_type]

    def initialize(self) -> None:
        self.evaluate(0.0)

    def evaluate(self, t: float) -> None:
        u = self.__dict__["u"]
        if self.table:
            self.__dict__["y"] = self._cast(self.table.get(u, u))
        else:
            self.__dict__["y"] = self._cast(self.factor * u + self.offset)
