"""Every registered kind that offers a kernel, through the compiled driver (`twmr.master.driver`):
hypothesis draws the variant, parameters, initial states, inputs and step as
tests/property/test_block_forms.py does, the block runs alone (its inputs held at the drawn
values) in the Python schedule and compiled, and the rows of all its outputs and states must be
equal bit for bit — or both runs stop with the same error. Each variant's value shapes (tuples,
NamedTuples, ints, arrays of any rank) go through the adapters' generated code."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings

from tests.helpers import system
from tests.property.test_block_forms import KINDS, SETTINGS, case
from twmr.core.errors import CosimError
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.master.compiled import CompileError
from twmr.observers.store import ResultStore
from twmr.testing import Harness


def alone(kind: str, c: dict[str, Any]) -> Any:
    """A system of one block of `kind` with the drawn parameters, states and first inputs."""
    dut = Harness(kind, parameters=c["params"], initial={**c["states"], **c["inputs"][0]},
                  step=c["h"])
    comp = dut.component
    steps = max(1, len(c["inputs"]) - 1)
    return system([comp], [], steps * c["h"] * (1.0 + 1e-9), c["h"],
                  record=[f"dut.{p}" for p in comp.outputs])


def rows(kind: str, c: dict[str, Any], mode: str) -> tuple[np.ndarray | None, str]:
    """(the recorded rows or None, the error text or '') of one run."""
    store = ResultStore()
    try:
        out = Execution(alone(kind, c), [store], algorithm=make_algorithm("gauss_seidel",
                                                                          mode)).run()
    except CompileError:
        raise
    except CosimError as exc:
        return None, str(exc)
    if mode == "on":
        assert out.extra["algorithm.driver"] is True, out.extra
    return store.data(), ""


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_runs_bit_identical_through_the_driver(kind: str) -> None:
    @settings(SETTINGS, max_examples=3)
    @given(case(kind))
    def check(c: dict[str, Any]) -> None:
        try:
            compiled, error = rows(kind, c, "on")
        except CompileError as exc:  # this variant has no kernel (its Python form is the rule)
            assert "offers no compiled kernel" in str(exc), str(exc)
            return
        python, python_error = rows(kind, c, "off")
        assert error == python_error
        if python is not None:
            assert compiled is not None and python.shape == compiled.shape
            assert np.array_equal(python, compiled, equal_nan=True), kind

    check()
