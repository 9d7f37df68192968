"""An override `comp.name=value` goes under 'initial' for an input or state of the kind and under
'parameters' otherwise (`twmr.scenario.overrides._set_value`), by the variables the kind
declares (`Component.declared`), a class that declares them its own way included."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from twmr.blocks.linear import Gain
from twmr.core.component import Component
from twmr.core.port import Input, Output, Parameter, Variable
from twmr.registry import kinds, lookup
from twmr.scenario.overrides import _declared


@pytest.mark.parametrize("kind", sorted(kinds()))
def test_each_registered_kind_finds_the_variables_it_declares(kind: str) -> None:
    try:
        cls = lookup(kind, Path.cwd())
    except ImportError:
        pytest.skip(f"{kind}: an extra is not installed")
    declared = cls.declared()
    assert all(_declared(cls, name) is var for name, var in declared.items())
    assert _declared(cls, "no_such_variable") is None


class Shadowed(Gain):
    """`k` given a plain class value (not a variable): the base's parameter stays declared."""

    k = 2.0  # type: ignore[assignment]
    u = Input(0.0, description="a new input of the same name")


def test_the_most_derived_variable_wins_and_a_plain_value_hides_none() -> None:
    assert _declared(Shadowed, "k") is Gain.declared()["k"]
    assert _declared(Shadowed, "u") is Shadowed.declared()["u"] is not Gain.declared()["u"]


class OwnDeclared(Component):
    """A kind whose variables come from its own `declared` (as a wrapper of a model file may)."""

    x = Output(0.0)

    @classmethod
    def declared(cls) -> dict[str, Variable]:
        return {**super().declared(), "made": Parameter(1.0), "fed": Input(0.0)}


def test_a_class_with_its_own_declared_is_asked() -> None:
    found: dict[str, Any] = {n: _declared(OwnDeclared, n) for n in ("x", "made", "fed", "y")}
    assert found["x"] is OwnDeclared.declared()["x"]
    assert found["made"].kind == "parameter" and found["fed"].kind == "input"
    assert found["y"] is None


def test_an_fmus_state_is_set_by_an_override_and_its_output_is_refused() -> None:
    """An FMU's variables are known only once it is read, so an override of its state goes
    under 'parameters' and is taken as the state's start value; an output is refused in one
    paragraph naming it (the Reference FMUs VanDerPol and Feedthrough)."""
    import twmr
    from tests.conformance.corpus import corpus
    from twmr.core import ScenarioError

    vdp = {"components": {"vdp": {"kind": "fmu", "parameters": {
        "path": str(corpus("reference-fmus", "VanDerPol_fmi2.fmu"))}}},
        "experiment": {"stop": 0.01, "step": 0.01}}
    run = twmr.simulate(twmr.load(vdp, ["vdp.x0=0.25", "vdp.x1=-0.5"]))
    assert run["vdp.x0"][0] == 0.25 and run["vdp.x1"][0] == -0.5
    feed = {"components": {"ft": {"kind": "fmu", "parameters": {
        "path": str(corpus("reference-fmus", "Feedthrough_fmi2.fmu"))}}},
        "experiment": {"stop": 0.01, "step": 0.01}}
    with pytest.raises(ScenarioError, match=r"'ft\.Float64_continuous_output' is an output: "
                                            r"the component computes it; nothing sets it\..*Fix"):
        twmr.load(feed, ["ft.Float64_continuous_output=3"])
