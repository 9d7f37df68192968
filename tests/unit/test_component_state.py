"""A native block's saved state (`Component.get_state`/`set_state`): exactly its inputs, outputs,
states and the private attributes it names in `state_attributes`, as plain values that pickle; a
restored state continues exactly as the first continuation did; a block that cannot save its state
(`can_get_and_set_state = False`) and a state that is not plain are refused in one paragraph."""
from __future__ import annotations

import math
import pickle
import threading

import numpy as np
import pytest

from twmr.core.component import Component
from twmr.core.errors import ComponentError
from twmr.core.port import Input, Output, Parameter, State
from twmr.registry import lookup


class Filter(Component):
    """A discrete second-order filter whose internal state is a private tuple, as a kernel's is;
    it also holds a lock (like a CAN link), which is not part of its state."""

    u = Input()
    y = Output()
    count = State(0.0)
    a = Parameter(0.9)
    state_attributes = ("_x",)

    def initialize(self) -> None:
        self._x = (0.0, 0.0)
        self._link = threading.Lock()

    def do_step(self, t: float, h: float) -> None:
        x1, x2 = self._x
        self._x = (self.a * x1 + h * self.u, x1 - 0.5 * x2 + math.sin(t))
        self.y = self._x[0] + self._x[1]
        self.count += 1.0


def run(comp: Component, t0: float, n: int, h: float = 0.01) -> list[tuple[float, ...]]:
    """n steps from t0 with input u = cos(t): the outputs and states after each."""
    rows = []
    for k in range(n):
        t = t0 + k * h
        comp.u = math.cos(3.0 * t)  # type: ignore[attr-defined]
        comp.do_step(t, h)
        rows.append(tuple(comp.get(name) for name in comp.outputs))
    return rows


@pytest.mark.parametrize("block", [Filter, lookup("integrator")])
def test_a_restored_state_continues_as_the_first_continuation(block) -> None:
    comp = block("f")
    comp.setup(0.0, None)
    comp.initialize()
    run(comp, 0.0, 25)
    saved = comp.get_state()
    first = run(comp, 0.25, 40)
    comp.set_state(saved)
    again = run(comp, 0.25, 40)
    assert again == first  # bit for bit
    assert first[0] != first[-1]  # it did move


def test_the_state_is_the_declared_values_as_plain_pairs_that_pickle() -> None:
    comp = Filter("f")
    comp.setup(0.0, None)
    comp.initialize()
    run(comp, 0.0, 3)
    state = comp.get_state()
    assert [name for name, _ in state] == ["u", "y", "count", "_x"]
    assert dict(state)["count"] == 3.0 and isinstance(dict(state)["_x"], tuple)
    assert pickle.loads(pickle.dumps(state)) == state  # the lock is not in it
    comp._x = (9.0, 9.0)
    comp.set_state(pickle.loads(pickle.dumps(state)))
    assert comp._x == dict(state)["_x"] and comp.get("count") == 3.0


def test_a_state_attribute_that_is_not_plain_is_refused_naming_it() -> None:
    class Buffered(Filter):
        state_attributes = ("_x", "_history")

        def initialize(self) -> None:
            super().initialize()
            self._history: list[float] = []

    comp = Buffered("buf")
    comp.initialize()
    with pytest.raises(ComponentError) as err:
        comp.get_state()
    message = str(err.value)
    assert message.startswith("component 'buf': cannot save its state: '_history' holds a list")
    assert "Fix:" in message and "\n" not in message


def test_a_block_that_cannot_save_its_state_refuses() -> None:
    class Drive(Filter):
        kind = "some_drive"
        can_get_and_set_state = False

    comp = Drive("motor")
    comp.initialize()
    for call in (comp.get_state, lambda: comp.set_state(())):
        with pytest.raises(ComponentError) as err:
            call()
        assert "component 'motor': a some_drive cannot" in str(err.value)
        assert "can_get_and_set_state is false" in str(err.value)


def test_a_state_saved_by_another_block_is_refused() -> None:
    integrator = lookup("integrator")("i")
    integrator.initialize()
    comp = Filter("f")
    comp.initialize()
    with pytest.raises(ComponentError, match="not saved by a Filter with these ports"):
        comp.set_state(integrator.get_state())


def slip_rows(comp: Component, t0: float, n: int, h: float = 0.01) -> list[tuple[float, ...]]:
    """n steps of a slip block from t0: its slip rate, slip acceleration and disturbance."""
    rows = []
    for k in range(n):
        comp.do_step(t0 + k * h, h)
        comp.evaluate(t0 + (k + 1) * h)
        rows.append((*comp.slip_rate, *comp.slip_accel, *comp.disturbance))  # type: ignore[attr-defined]
    return rows


def test_a_restored_random_slip_draws_the_same_noise_again() -> None:
    comp = lookup("slip_disturbance")("slip", profile="random", seed=7, bandwidth=5.0)
    comp.setup(0.0, None)
    comp.initialize()
    slip_rows(comp, 0.0, 20)
    saved = comp.get_state()
    assert pickle.loads(pickle.dumps(saved)) == saved
    first = slip_rows(comp, 0.2, 30)
    comp.set_state(pickle.loads(pickle.dumps(saved)))
    again = slip_rows(comp, 0.2, 30)
    assert again == first  # bit for bit: the filter's state and the generator's
    # the state holds the generator: numpy's own generator, advanced by the 20 steps' draws
    # (5 normals each), gives the same next draws as the restored block
    rng = np.random.default_rng(7)
    rng.standard_normal(100)
    comp.set_state(saved)
    np.testing.assert_array_equal(comp._rng.standard_normal(5), rng.standard_normal(5))


def test_a_random_slip_restored_into_a_fresh_block_continues_the_same() -> None:
    make = lookup("slip_disturbance")
    comp = make("slip", profile="random", seed=3)
    comp.setup(0.0, None)
    comp.initialize()
    slip_rows(comp, 0.0, 10)
    saved = comp.get_state()
    first = slip_rows(comp, 0.1, 10)
    other = make("slip", profile="random", seed=99)
    other.setup(0.0, None)
    other.initialize()
    other.set_state(saved)
    assert slip_rows(other, 0.1, 10) == first
    assert first[0] != first[-1]
