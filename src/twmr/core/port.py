"""Variable descriptors: `Input`, `Output`, `Parameter`, `State`.

Declared at class level, they take their name from the attribute. Values live in the instance's
``__dict__`` (the descriptors are non-data descriptors), so reading ``self.pose`` in a step costs
one dict lookup. A scalar (size None) holds a float/int/bool; a vector of size n holds a tuple of n
floats, which the master can share between components without copying.
"""
from __future__ import annotations

import builtins
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from twmr.core.errors import CosimError

REAL, INTEGER, BOOLEAN, STRING, BINARY = "Real", "Integer", "Boolean", "String", "Binary"
#: an FMI 3.0 clock: True at the communication point where it ticked, else False
CLOCK = "Clock"
TYPES = (REAL, INTEGER, BOOLEAN, STRING, BINARY, CLOCK)
#: types that are not numbers: never recorded, never checked for NaN
TEXT_TYPES = (STRING, BINARY)


def _binary(value: Any = b"") -> bytes:
    """Bytes from bytes or from hexadecimal text ('0a0b', as FMI 3.0 start values are written)."""
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if isinstance(value, str):
        try:
            return bytes.fromhex(value)
        except ValueError:
            raise ValueError(f"expected hexadecimal bytes such as '0a0b', got {value!r}") from None
    raise TypeError(f"expected bytes (hexadecimal text such as '0a0b'), got {value!r}")


class DeclarationError(CosimError, ValueError):
    """A port declared inconsistently in a block's class (units that do not match its size)."""


_CAST: dict[str, Callable[..., Any]] = {REAL: float, INTEGER: int, BOOLEAN: bool, STRING: str,
                                        BINARY: _binary, CLOCK: bool}


@dataclass
class Variable:
    """Base descriptor; `kind` is 'input', 'output', 'parameter' or 'state'.

    size None is a scalar, n > 0 a vector of n elements, 0 a vector of any length (nested lists,
    e.g. a matrix given row by row, are flattened row-major). unit '' means unspecified (generic
    blocks): it connects to any unit without conversion; '1' means dimensionless."""

    start: Any = None
    size: int | None = None
    unit: str | tuple[str, ...] = ""
    type: str = REAL
    min: float | None = None
    max: float | None = None
    description: str = ""
    #: units this port's unit strings may name beyond Modelica's (an FMU's UnitDefinitions)
    unit_definitions: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    name: str = field(default="", init=False)
    kind = "variable"

    def __post_init__(self) -> None:
        if self.type not in TYPES:
            raise ValueError(f"type must be one of {TYPES}, not {self.type!r}")
        self.start = self.coerce(self._default_start() if self.start is None else self.start)

    def _default_start(self) -> Any:
        return _CAST[self.type]()

    def __set_name__(self, owner: builtins.type, name: str) -> None:
        self.name = name
        if isinstance(self.unit, tuple) and len(self.unit) != self.width:
            raise DeclarationError(self._units_problem(f"{owner.__qualname__}.{name}"))

    def _units_problem(self, where: str) -> str:
        n, cls, units = len(self.unit), type(self).__name__, self.unit
        article = "an" if cls[0] in "AEIOU" else "a"
        if self.size is None:
            return (f"{where}: {n} units {units!r} are given for a scalar {cls} (no size). "
                    f"Fix: declare it as a vector, {cls}(size={n}, unit={units!r}), or give one "
                    f"unit string for all its elements, unit={units[0]!r}.")
        return (f"{where}: {n} units {units!r} are given for {article} {cls} of size {self.size}. "
                f"Fix: give one unit per element ({self.size}), or one unit string for all, "
                f"unit={units[0]!r}.")

    def __get__(self, obj: Any, objtype: builtins.type | None = None) -> Any:
        if obj is None:
            return self
        return obj.__dict__.setdefault(self.name, self.start)

    @property
    def width(self) -> int:
        """Number of scalar elements."""
        return self.size or 1

    def element_unit(self, index: int) -> str:
        """Unit string of element `index` (0-based)."""
        return self.unit[index] if isinstance(self.unit, tuple) else self.unit

    @property
    def unit_text(self) -> str:
        """The unit as one string, e.g. '(m, m, rad)' for per-element units."""
        return f"({', '.join(self.unit)})" if isinstance(self.unit, tuple) else self.unit

    def coerce(self, value: Any) -> Any:
        """Value in the port's representation: a scalar, or a tuple of `size` elements.

        Raises ValueError/TypeError with a plain message when the value does not fit."""
        cast = _CAST[self.type]
        if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
            value = value.tolist()  # numpy arrays and scalars
        if value is None:
            raise TypeError("no value given (null)")
        if self.type in (BOOLEAN, CLOCK) and not isinstance(value, (bool, int, list, tuple)):
            raise TypeError(f"expected true or false, got {value!r}")
        if self.type == BINARY:
            if self.size is None:
                return _binary(value)
            return tuple(_binary(v) for v in value)
        if self.type in (REAL, INTEGER) and isinstance(value, str):
            raise TypeError(f"expected a number, got the text {value!r}")
        if self.size is None:
            if isinstance(value, (list, tuple)):
                raise ValueError(f"expected a scalar, got a list of {len(value)}")
            return self._check(cast(value))
        if not isinstance(value, (list, tuple)):
            return tuple(self._check(cast(value)) for _ in range(self.size))
        if self.size == 0:
            value = _flatten(value)
        elif len(value) != self.size:
            raise ValueError(f"expected {self.size} values, got {len(value)}")
        return tuple(self._check(cast(v)) for v in value)

    def _check(self, v: Any) -> Any:
        if self.type == STRING:
            return v
        if v != v:  # NaN fails every comparison, so it would pass min and max
            raise ValueError("NaN is not a valid value")
        if self.min is not None and v < self.min:
            raise ValueError(f"{v} is below the minimum {self.min}")
        if self.max is not None and v > self.max:
            raise ValueError(f"{v} is above the maximum {self.max}")
        return v


def _flatten(value: Any) -> list[Any]:
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _flatten(v)]
    return [value]


@dataclass
class Input(Variable):
    """A value the component reads; set by the master from a connection (or its start value).
    An `optional` input may stay unwired without being listed under `open:` (its start value
    then means "not given", which the component handles)."""

    optional: bool = False
    kind = "input"


@dataclass
class Output(Variable):
    """A value the component writes. `depends_on` lists the inputs it depends on directly
    (direct feedthrough); empty means it depends only on state and time."""

    depends_on: tuple[str, ...] = ()
    kind = "output"

    def __post_init__(self) -> None:
        if isinstance(self.depends_on, str):
            self.depends_on = (self.depends_on,)
        self.depends_on = tuple(self.depends_on)
        super().__post_init__()


@dataclass
class Parameter(Variable):
    """A value fixed before `initialize()`: set from the scenario, checked against min/max."""

    kind = "parameter"

    def _default_start(self) -> Any:
        raise ValueError("a Parameter needs a default value")


@dataclass
class State(Output):
    """A continuous or discrete state, visible as an output (it can drive inputs and be recorded);
    its start is settable from the scenario's `initial:`. It never depends directly on inputs."""

    kind = "state"
