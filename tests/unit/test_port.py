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


class ElementWise(Component):
    """y = 2 u element by element, its ports as wide as the parameter n."""

    sized_by = {"u": "n", "y": "n"}  # noqa: RUF012 - a class table
    n = Parameter(1)
    u = Input(1.5, unit="m")
    y = Output(0.0, unit="m", depends_on="u")

    def evaluate(self, t: float) -> None:
        self.y = tuple(2 * v for v in self.u) if isinstance(self.u, tuple) else 2 * self.u


def test_a_size_parameter_sizes_the_ports_of_one_instance_only() -> None:
    wide, narrow = ElementWise(n=3), ElementWise()
    assert wide.variables["u"].size == 3 and wide.u == (1.5, 1.5, 1.5)
    assert narrow.variables["u"].size is None and narrow.u == 1.5
    assert ElementWise.declared()["u"].size is None
    with pytest.raises(ValueError, match="expected 3 values"):
        wide.set_parameter("u", [1.0, 2.0])
    with pytest.raises(ValueError, match="at least 1"):
        ElementWise(n=0)


def test_sized_ports_are_wired_and_checked_by_their_instance_size(tmp_path) -> None:
    from twmr.core import ScenarioError
    from twmr.scenario import loads

    (tmp_path / "ew.py").write_text("from tests.unit.test_port import ElementWise\n")
    text = ("components:\n"
            "  a: {kind: 'ew.py:ElementWise', parameters: {n: 3}}\n"
            "  b: {kind: 'ew.py:ElementWise', parameters: {n: N}}\n"
            "connections: [a.y -> b.u]\nopen: [a.u]\n"
            "experiment: {stop: 0.1, step: 0.1}\n")
    system = loads(text.replace("N", "3"), base_dir=tmp_path)
    assert system.components["b"].variables["u"].size == 3
    with pytest.raises(ScenarioError, match=r"a\.y.*b\.u|size"):
        loads(text.replace("N", "2"), base_dir=tmp_path)
