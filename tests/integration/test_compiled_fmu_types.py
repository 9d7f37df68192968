"""FMUs of every scalar type in the compiled loop (`twmr.fmi.compiled_calls`): chains of the C test
FMUs (a Van der Pol oscillator into two feedthrough FMUs, FMI 2.0 and FMI 3.0, tests/fmus/) run
by the Python loop and compiled must record equal rows element for element; Integer and Boolean
values cross into Real inputs and into integer inputs of other widths with the Python path's
conversions (a float; C's wrap-around); a String port the run wires refuses the compiled loop
in one paragraph naming the port.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.fmu_build import build_c_fmu
from twmr.core.errors import CosimError
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import loads

FMI3_NUMERIC = ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32",
                "Int64", "UInt64", "Boolean", "Enumeration")
#: values at the edges of their types' ranges, given to the first feedthrough's inputs
FMI3_GIVEN = {"Int8": -128, "UInt8": 255, "Int16": 32767, "UInt16": 65535,
              "Int32": -2147483648, "UInt32": 4294967295, "Int64": -2**53 - 1,
              "UInt64": 2**64 - 1, "Boolean": "true", "Enumeration": 3}
#: (output of a, input of c): integers into Real inputs and into integers of other widths
FMI3_CROSS = (("UInt64_output", "Float64_input"), ("Int64_output", "Float32_input"),
              ("UInt64_output", "Int64_input"), ("Int8_output", "UInt8_input"),
              ("Int64_output", "Int8_input"), ("UInt32_output", "Int16_input"),
              ("Int16_output", "UInt64_input"), ("Enumeration_output", "Int32_input"),
              ("Boolean_output", "Boolean_input"))
FMI2_TYPES = ("Float64_continuous", "Float64_discrete", "Int32", "Boolean", "Enumeration")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("typed_fmus")
    return {"vdp2": build_c_fmu("vdp2", d), "ft2": build_c_fmu("ft2", d),
            "vdp3": build_c_fmu("vdp3", d, fmi3=True),
            "types3": build_c_fmu("types3", d, fmi3=True)}


def run(text: str, mode: str) -> tuple[np.ndarray, dict]:
    store = ResultStore()
    ex = Execution(loads(text, source="typed.yaml"), [store],
                   algorithm=make_algorithm("gauss_seidel", mode))
    outcome = ex.run()
    assert outcome.status == "completed", outcome
    return store.data(), outcome.extra


def fmi2_chain(fmus: dict[str, Path]) -> str:
    wires = "\n".join(f"  - a.{t}_output -> b.{t}_input" for t in FMI2_TYPES[1:])
    signals = [f"b.{t}_output" for t in FMI2_TYPES] + \
        ["a.Int32_output", "b.Int32_input", "c.Float64_continuous_output",
         "c.Float64_discrete_output"]
    return f"""
components:
  vdp: {{kind: fmu, parameters: {{path: {fmus['vdp2']}}}}}
  a:
    kind: fmu
    parameters: {{path: {fmus['ft2']}}}
    initial: {{Float64_discrete_input: -1.0e300, Int32_input: -2147483648,
              Boolean_input: true, Enumeration_input: 2}}
  b: {{kind: fmu, parameters: {{path: {fmus['ft2']}}}}}
  c: {{kind: fmu, parameters: {{path: {fmus['ft2']}}}}}
connections:
  - vdp.x0 -> a.Float64_continuous_input
  - a.Float64_continuous_output -> b.Float64_continuous_input
{wires}
  - a.Int32_output -> c.Float64_continuous_input
  - a.Boolean_output -> c.Float64_discrete_input
open: [a.Float64_discrete_input, a.Int32_input, a.Boolean_input, a.String_input,
       a.Enumeration_input, b.String_input, c.Int32_input, c.Boolean_input, c.String_input,
       c.Enumeration_input]
experiment: {{start: 0.0, stop: 0.5, step: 0.001}}
record: {{signals: [{', '.join(signals)}]}}
"""


def fmi3_chain(fmus: dict[str, Path]) -> str:
    initial = ", ".join(f"{t}_input: {v}" for t, v in FMI3_GIVEN.items())
    wires = "\n".join(f"  - a.{t}_output -> b.{t}_input" for t in FMI3_NUMERIC)
    cross = "\n".join(f"  - a.{o} -> c.{i}" for o, i in FMI3_CROSS)
    fed = {"Float32", "Float64"}
    opened = [f"a.{t}_input" for t in FMI3_NUMERIC if t not in fed] + \
        [f"{x}.{t}_input" for x in "abc" for t in ("String", "Binary")] + \
        [f"c.{t}_input" for t in FMI3_NUMERIC if f"{t}_input" not in {i for _, i in FMI3_CROSS}] + \
        ["a.vec_in", "c.vec_in"]
    signals = [f"b.{t}_output" for t in FMI3_NUMERIC] + [f"c.{i}" for _, i in FMI3_CROSS] + \
        [f"c.{i.replace('_input', '_output')}" for _, i in FMI3_CROSS] + ["b.vec_out"]
    return f"""
components:
  vdp: {{kind: fmu, parameters: {{path: {fmus['vdp3']}}}}}
  a:
    kind: fmu
    parameters: {{path: {fmus['types3']}}}
    initial: {{{initial}, vec_in: [4, 5, 6]}}
  b: {{kind: fmu, parameters: {{path: {fmus['types3']}}}}}
  c: {{kind: fmu, parameters: {{path: {fmus['types3']}}}}}
connections:
  - vdp.x0 -> a.Float64_input
  - vdp.x1 -> a.Float32_input
{wires}
{cross}
  - a.vec_out -> b.vec_in
open: [{', '.join(opened)}]
experiment: {{start: 0.0, stop: 0.5, step: 0.001}}
record: {{signals: [{', '.join(signals)}]}}
"""


@pytest.mark.parametrize("chain", [fmi2_chain, fmi3_chain], ids=["FMI 2.0", "FMI 3.0"])
def test_every_scalar_type_bit_identical_python_and_compiled(fmus, chain) -> None:
    text = chain(fmus)
    python, _ = run(text, "off")
    compiled, extra = run(text, "on")
    assert extra["algorithm.compiled"] is True
    assert python.shape == compiled.shape and python.shape[0] == 501
    assert np.array_equal(python, compiled)
    assert len(np.unique(python[:, 1])) > 400  # vdp's x0 went through both feedthroughs


def test_a_feedthrough_fmu_is_evaluated_once_per_point(fmus) -> None:
    """types3 has feedthrough outputs that feed nothing and depend on open inputs only
    (Float32_output, visited before the wired Float64_input): visiting them evaluates nothing,
    so along vdp -> a -> b each FMU is set and got once per point, after its input is written."""
    from fmpy import read_model_description

    inputs = [v.name for v in read_model_description(str(fmus["types3"])).modelVariables
              if v.causality == "input" and v.name != "Float64_input"]
    text = f"""
components:
  vdp: {{kind: fmu, parameters: {{path: {fmus['vdp3']}}}}}
  a: {{kind: fmu, parameters: {{path: {fmus['types3']}}}}}
  b: {{kind: fmu, parameters: {{path: {fmus['types3']}}}}}
connections: [vdp.x0 -> a.Float64_input, a.Float64_output -> b.Float64_input]
open: [{', '.join(f'{c}.{n}' for c in 'ab' for n in inputs)}]
experiment: {{stop: 0.01, step: 0.001}}
record: {{signals: [b.Float64_output]}}
"""
    python = Execution(loads(text, source="chain.yaml"), [ResultStore()],
                       algorithm=make_algorithm("gauss_seidel", "off"))
    python.run()
    loop = python.algorithm.source.split("def finish")[0]
    assert [loop.count(f"ev{i}(t)") for i in (1, 2)] == [1, 1], loop
    assert np.array_equal(run(text, "off")[0], run(text, "on")[0])


def test_fmi3_conversions_as_the_python_path(fmus) -> None:
    """Integers into Real inputs round to the nearest float (Float32: to float32), into
    narrower or unsigned ones wrap around as C does; the inputs hold the integers as given."""
    store = ResultStore()
    system = loads(fmi3_chain(fmus), source="typed.yaml")
    outcome = Execution(system, [store], algorithm=make_algorithm("gauss_seidel", "on")).run()
    assert outcome.extra["algorithm.compiled"] is True
    last = dict(zip(store.columns, store.data()[-1], strict=True))
    expect = {"c.Float64_output": float(2**64 - 1),
              "c.Float32_output": float(np.float32(-2**53 - 1)),
              "c.Int64_output": -1.0, "c.UInt8_output": 128.0, "c.Int8_output": -1.0,
              "c.Int16_output": -1.0, "c.UInt64_output": float(32767), "c.Int32_output": 3.0,
              "c.Boolean_output": 1.0, "c.Int8_input": float(-2**53 - 1),
              "b.UInt64_output": float(2**64 - 1), "b.Int32_output": -2147483648.0}
    assert {k: last[k] for k in expect} == expect
    b = system.components["b"]
    assert b.get("Boolean_output") is True and b.get("UInt64_output") == 2**64 - 1


def test_a_wired_string_refuses_the_compiled_loop(fmus) -> None:
    text = f"""
components:
  a: {{kind: fmu, parameters: {{path: {fmus['ft2']}}}}}
  b: {{kind: fmu, parameters: {{path: {fmus['ft2']}}}}}
connections: [a.String_output -> b.String_input]
open: [a.Float64_continuous_input, a.Float64_discrete_input, a.Int32_input, a.Boolean_input,
       a.String_input, a.Enumeration_input, b.Float64_continuous_input, b.Float64_discrete_input,
       b.Int32_input, b.Boolean_input, b.Enumeration_input]
experiment: {{stop: 0.01, step: 0.001}}
"""
    with pytest.raises(CosimError) as info:
        run(text, "on")
    message = str(info.value)
    assert "'a.String_output' is String" in message and "Fix:" in message
    assert "\n" not in message.strip()
    _, extra = run(text, "auto")
    assert extra["algorithm.compiled"] is False
