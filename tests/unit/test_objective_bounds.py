"""An objective or constraint expression is computed in floats and a part of numbers alone must
be finite: `9 ** 9 ** 9` is refused at once with a clear error instead of computing a huge
integer for ever."""
from __future__ import annotations

import math

import pytest

from twmr.tuning.objective import Expression, TuneError

pytestmark = pytest.mark.timeout(30)


@pytest.mark.parametrize("text", ["9 ** 9 ** 9", "mse_x + exp(1000)", "mse_x ** 9 ** 9 ** 9",
                                  "1 / 0 + mse_x"])
def test_a_non_finite_part_of_numbers_is_refused(text: str) -> None:
    with pytest.raises(TuneError, match="is not a finite number"):
        Expression(text)


def test_figures_that_overflow_give_nan_not_a_hang() -> None:
    e = Expression("mse_x ** mse_y ** mse_y")
    assert math.isnan(e.value({"mse_x": 9.0, "mse_y": 9.0}))
    assert Expression("mse_x * 10 ** 3 + log(mse_y)").value({"mse_x": 2.0, "mse_y": 1.0}) == 2000.0


def test_a_deeply_nested_expression_is_refused_plainly() -> None:
    with pytest.raises(TuneError, match="cannot read it"):
        Expression("(" * 100_000 + "1" + ")" * 100_000)
