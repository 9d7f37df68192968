"""Modelica unit strings: SI factors and exponents, conversions, incompatible units."""
from __future__ import annotations

import math

import pytest

from twmr.core import UnitError
from twmr.core.units import BASES, compatible, conversion, parse_unit


def dims(**e: int) -> tuple[int, ...]:
    return tuple(e.get(b, 0) for b in BASES)


@pytest.mark.parametrize("text,factor,exps", [
    ("N.m", 1.0, dims(kg=1, m=2, s=-2)), ("rad/s", 1.0, dims(rad=1, s=-1)),
    ("m/s2", 1.0, dims(m=1, s=-2)), ("kg.m2", 1.0, dims(kg=1, m=2)), ("1/s", 1.0, dims(s=-1)),
    ("deg", math.pi / 180, dims(rad=1)), ("mm", 1e-3, dims(m=1)),
    ("km/h", 1 / 3.6, dims(m=1, s=-1)),
    ("s-1", 1.0, dims(s=-1)), ("", 1.0, dims()),
])
def test_parse(text: str, factor: float, exps: tuple[int, ...]) -> None:
    u = parse_unit(text)
    assert u.factor == pytest.approx(factor) and u.exponents == exps


def test_conversions_and_incompatibility() -> None:
    assert conversion("mm", "m")[0] == pytest.approx(1e-3)
    assert conversion("deg", "rad")[0] == pytest.approx(math.pi / 180)
    assert conversion("rpm", "rad/s")[0] == pytest.approx(2 * math.pi / 60)
    assert not compatible("rad/s", "1/s")  # radian kept as a base, as FMI does
    with pytest.raises(UnitError, match="cannot be converted"):
        conversion("N.m", "rad/s")
    with pytest.raises(UnitError, match="not a Modelica unit"):
        parse_unit("furlong")
