"""Descriptors: coercion, sizes, limits."""
import pytest

from twmr.core import Component, Input, Output, Parameter


class Block(Component):
    u = Input(size=2, unit="m")
    y = Output(depends_on="u")
    k = Parameter(2.0, min=0.0, max=10.0)


def test_vector_start_is_tuple_of_size() -> None:
    assert Block().u == (0.0, 0.0)


def test_parameter_limits_rejected() -> None:
    with pytest.raises(ValueError, match="above the maximum"):
        Block(k=11)


def test_wrong_length_rejected() -> None:
    with pytest.raises(ValueError, match="expected 2 values"):
        Block(u=[1, 2, 3])


def test_feedthrough_detected() -> None:
    assert Block().has_feedthrough
