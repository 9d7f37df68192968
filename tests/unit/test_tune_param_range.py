"""Whether a `--start` value lies in a `--param` range, decided by the range itself (no private
attribute of Optuna): numbers within the bounds, whole numbers for int:, one of the values for
values: — and never True for 1 or the text '2' for a number."""
from __future__ import annotations

from typing import Any

import pytest

from twmr.tuning.objective import parse_param

CASES = [
    ("c.k=1:5", 1, True), ("c.k=1:5", 5.0, True), ("c.k=1:5", 0.99, False),
    ("c.k=1:5", True, False), ("c.k=1:5", "2", False), ("c.k=1:5", float("nan"), False),
    ("c.k=int:1:5", 2, True), ("c.k=int:1:5", 2.0, True), ("c.k=int:1:5", 2.5, False),
    ("c.k=int:1:5", 6, False), ("c.k=log:0.1:10", 0.1, True), ("c.k=log:0.1:10", 10.5, False),
    ("c.k=values:1,a,2.5", 1, True), ("c.k=values:1,a,2.5", 1.0, True),
    ("c.k=values:1,a,2.5", True, False), ("c.k=values:1,a,2.5", "a", True),
    ("c.k=values:1,a,2.5", 3, False),
]


@pytest.mark.parametrize("text, value, inside", CASES)
def test_a_value_is_in_its_range(text: str, value: Any, inside: bool) -> None:
    assert parse_param(text).contains(value) is inside
