"""An override's value is read as YAML reads it: the decimal numbers a sweep writes take a
quicker path (`twmr.scenario.overrides._parse`) that must give YAML's value, type and bits."""
from __future__ import annotations

import math

import yaml
from hypothesis import given
from hypothesis import strategies as st

from twmr.core.errors import Location
from twmr.scenario.overrides import _parse
from twmr.scenario.yamlread import FAST

texts = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.integers(min_value=-10**30, max_value=10**30).map(str),
    st.from_regex(r"-?[0-9]{1,4}(\.[0-9]{0,5})?([eE][-+]?[0-9]{1,3})?", fullmatch=True),
    st.sampled_from(["0", "-0", "-0.0", "00", "010", "0.50", "1.", ".5", "1_000", "+1", " 2",
                     "0x1f", "1:30", "1e-05", "1.5e-07", "[1, 2.5]", "true", "'3'"]),
)


@given(texts)
def test_a_value_is_read_as_yaml_reads_it(text: str) -> None:
    ok, value = _parse(f"c.p={text}", "c.p", text, Location("--set", 0, text), [])
    expected = yaml.load(text, Loader=FAST)  # noqa: S506 - a safe loader
    assert ok and type(value) is type(expected)
    if isinstance(value, float):
        assert math.copysign(1.0, value) == math.copysign(1.0, expected)
        assert value == expected or (math.isnan(value) and math.isnan(expected))
    else:
        assert value == expected
