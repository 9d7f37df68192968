"""Every number of an experiment is finite and in range, or refused at check naming the key:
tolerances and step bounds of the adaptive master, the loop solver's options, and a step longer
than the run (an SSP's stepSize="1e300" would take no step)."""
from __future__ import annotations

import pytest

import twmr
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(60)


def _scenario(experiment: dict[str, object]) -> dict[str, object]:
    return {"components": {"c": {"kind": "constant", "parameters": {"value": 1.0}}},
            "experiment": {"stop": 1.0, "step": 0.01, **experiment}}


@pytest.mark.parametrize(("experiment", "says"), [
    ({"algorithm": "adaptive", "rtol": float("nan")}, "'rtol' is nan"),
    ({"algorithm": "adaptive", "rtol": float("inf")}, "'rtol' is inf"),
    ({"algorithm": "adaptive", "max_step": float("inf")}, "'max_step' is inf"),
    ({"loops": "solve", "loop_solver": {"tol": float("inf")}}, "loop_solver 'tol' is inf"),
    ({"step": 1e300}, "longer than the run"),
])
def test_non_finite_or_out_of_range_numbers_are_refused(experiment: dict[str, object],
                                                         says: str) -> None:
    with pytest.raises(ScenarioError, match=says):
        twmr.load(_scenario(experiment))


def test_finite_values_still_load() -> None:
    twmr.load(_scenario({"algorithm": "adaptive", "rtol": 1e-3, "max_step": 0.1}))
