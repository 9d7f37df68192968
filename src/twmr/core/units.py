"""Modelica/FMI unit strings: parse into an SI factor, offset and base-unit exponents.

Grammar (Modelica spec 19.1): factors joined by '.', at most one '/', each factor a symbol with an
optional prefix and an optional signed integer exponent: ``N.m``, ``rad/s``, ``m/s2``, ``kg.m2``,
``1/s``, ``s-1``, ``mm``, ``deg``. A symbol that is a unit on its own (``m``) is never read as a
prefix. Radian is kept as a base dimension, as FMI's BaseUnit does, so ``rad/s`` and ``1/s`` differ.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache

from twmr.core.errors import UnitError

BASES = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def _dims(**exps: int) -> tuple[int, ...]:
    return tuple(exps.get(b, 0) for b in BASES)


# symbol -> (factor to SI, exponents)
_SYMBOLS: dict[str, tuple[float, tuple[int, ...]]] = {
    "1": (1.0, _dims()),
    "m": (1.0, _dims(m=1)),
    "g": (1e-3, _dims(kg=1)),
    "s": (1.0, _dims(s=1)),
    "A": (1.0, _dims(A=1)),
    "K": (1.0, _dims(K=1)),
    "mol": (1.0, _dims(mol=1)),
    "cd": (1.0, _dims(cd=1)),
    "rad": (1.0, _dims(rad=1)),
    "deg": (math.pi / 180.0, _dims(rad=1)),
    "rev": (2.0 * math.pi, _dims(rad=1)),
    "rpm": (2.0 * math.pi / 60.0, _dims(rad=1, s=-1)),
    "sr": (1.0, _dims()),
    "min": (60.0, _dims(s=1)),
    "h": (3600.0, _dims(s=1)),
    "d": (86400.0, _dims(s=1)),
    "Hz": (1.0, _dims(s=-1)),
    "N": (1.0, _dims(kg=1, m=1, s=-2)),
    "Pa": (1.0, _dims(kg=1, m=-1, s=-2)),
    "bar": (1e5, _dims(kg=1, m=-1, s=-2)),
    "J": (1.0, _dims(kg=1, m=2, s=-2)),
    "W": (1.0, _dims(kg=1, m=2, s=-3)),
    "C": (1.0, _dims(A=1, s=1)),
    "V": (1.0, _dims(kg=1, m=2, s=-3, A=-1)),
    "Ohm": (1.0, _dims(kg=1, m=2, s=-3, A=-2)),
    "F": (1.0, _dims(kg=-1, m=-2, s=4, A=2)),
    "H": (1.0, _dims(kg=1, m=2, s=-2, A=-2)),
    "Wb": (1.0, _dims(kg=1, m=2, s=-2, A=-1)),
    "T": (1.0, _dims(kg=1, s=-2, A=-1)),
    "l": (1e-3, _dims(m=3)),
    "degC": (1.0, _dims(K=1)),
    "percent": (0.01, _dims()),
}
_OFFSETS = {"degC": 273.15}
_PREFIXES = {
    "Y": 1e24, "Z": 1e21, "E": 1e18, "P": 1e15, "T": 1e12, "G": 1e9, "M": 1e6, "k": 1e3,
    "h": 1e2, "da": 1e1, "d": 1e-1, "c": 1e-2, "m": 1e-3, "u": 1e-6, "n": 1e-9, "p": 1e-12,
    "f": 1e-15, "a": 1e-18,
}
_FACTOR = re.compile(r"^([A-Za-z]+|1)(-?\d+)?$")


@dataclass(frozen=True)
class Unit:
    """A parsed unit: SI value = factor * value + offset; exponents over `BASES`."""

    text: str
    factor: float
    exponents: tuple[int, ...]
    offset: float = 0.0

    @property
    def dimension(self) -> str:
        """The exponents written out, e.g. 'kg.m2.s-2', for error messages."""
        parts = [f"{b}{e if e != 1 else ''}" for b, e in zip(BASES, self.exponents, strict=True)
                 if e]
        return ".".join(parts) or "1"


def _symbol(sym: str) -> tuple[float, tuple[int, ...]]:
    if sym in _SYMBOLS:
        return _SYMBOLS[sym]
    for plen in (2, 1):
        prefix, rest = sym[:plen], sym[plen:]
        if prefix in _PREFIXES and rest in _SYMBOLS and rest != "1":
            factor, exps = _SYMBOLS[rest]
            return _PREFIXES[prefix] * factor, exps
    raise UnitError(f"unknown unit symbol '{sym}'")


def _product(text: str) -> tuple[float, list[int]]:
    factor, exps = 1.0, [0] * len(BASES)
    for part in text.split("."):
        match = _FACTOR.match(part)
        if not match:
            raise UnitError(f"cannot read unit factor '{part}'")
        f, e = _symbol(match.group(1))
        power = int(match.group(2) or 1)
        factor *= f**power
        for i, x in enumerate(e):
            exps[i] += x * power
    return factor, exps


@cache
def parse_unit(text: str) -> Unit:
    """Parse a Modelica unit string; '' means dimensionless ('1')."""
    raw = (text or "1").strip()
    try:
        if raw.count("/") > 1:
            raise UnitError("more than one '/'")
        num, _, den = raw.partition("/")
        den = den.strip("()")
        factor, exps = _product(num)
        if den:
            dfactor, dexps = _product(den)
            factor /= dfactor
            exps = [a - b for a, b in zip(exps, dexps, strict=False)]
    except UnitError as exc:
        raise UnitError(
            f"unit '{raw}' is not a Modelica unit string ({exc}); write it like 'N.m', 'rad/s', "
            "'m/s2' or 'kg.m2'"
        ) from None
    return Unit(raw, factor, tuple(exps), _OFFSETS.get(raw, 0.0))


def known_unit(text: str, defined: dict[str, Unit] | None = None) -> Unit | None:
    """The unit `text` as `defined` (e.g. by an FMU's UnitDefinitions) or as a Modelica unit
    string; None when neither knows it."""
    if defined and text in defined:
        return defined[text]
    try:
        return parse_unit(text)
    except UnitError:
        return None


def conversion(src: str | Unit, dst: str | Unit) -> tuple[float, float]:
    """(gain, offset) such that value_in_dst = gain * value_in_src + offset; UnitError if the
    dimensions differ."""
    a = src if isinstance(src, Unit) else parse_unit(src)
    b = dst if isinstance(dst, Unit) else parse_unit(dst)
    src, dst = a.text, b.text
    if a.exponents != b.exponents:
        raise UnitError(
            f"unit '{src}' ({a.dimension}) cannot be converted to '{dst}' ({b.dimension})"
        )
    gain = a.factor / b.factor
    offset = (a.offset - b.offset) / b.factor
    if math.isclose(gain, 1.0, rel_tol=1e-15, abs_tol=0.0):
        gain = 1.0
    return gain, offset


def compatible(src: str, dst: str) -> bool:
    """True when a value in `src` can be converted to `dst`."""
    return parse_unit(src).exponents == parse_unit(dst).exponents
