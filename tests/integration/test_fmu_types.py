"""FMI 3.0 types, arrays and structural parameters through the importer (co-simulation and model
exchange): every type over its own FMI call, array ports with their start values, an array
parameter sized by a structural parameter from YAML (clocks: test_fmu_clocks.py)."""
from __future__ import annotations

import numpy as np
import pytest

from tests.fmu_build import build_c_fmu
from twmr.core import CosimError
from twmr.fmi.fmu import FmuComponent
from twmr.master import RunContext, simulate
from twmr.scenario import loads

NUMERIC = ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64",
           "UInt64", "Boolean", "Enumeration")
#: values unlike the FMU's start values, at the edges of their types' ranges
GIVEN = {"Float32": 0.375, "Float64": -1.0e300, "Int8": -128, "UInt8": 255, "Int16": 32767,
         "UInt16": 65535, "Int32": -2147483648, "UInt32": 4294967295, "Int64": -2**53,
         "UInt64": 2**53, "Boolean": False, "Enumeration": 3}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("types3")
    return {n: str(build_c_fmu(n, d, fmi3=True)) for n in ("types3",)}


def chain(path: str, interface: str, isolate: bool = False) -> str:
    """a (inputs from `initial:`) -> b, every output of a wired to b's input of the same type."""
    initial = ", ".join(f"{t}_input: {v!r}".replace("False", "false") for t, v in GIVEN.items())
    wires = "\n".join(f"  - a.{t}_output -> b.{t}_input" for t in (*NUMERIC, "String", "Binary"))
    return f"""
components:
  a:
    kind: fmu
    parameters: {{path: {path}, interface: {interface}, gains: [2.0, -3.0], n: 2,
                 isolate: {str(isolate).lower()}}}
    initial: {{{initial}, String_input: "hé llo", Binary_input: "00ff10", vec_in: [4, 5, 6]}}
  b: {{kind: fmu, parameters: {{path: {path}, interface: {interface}}}}}
connections:
{wires}
  - a.vec_out -> b.vec_in
open: [a.Float32_input, a.Float64_input, a.Int8_input, a.UInt8_input, a.Int16_input,
       a.UInt16_input, a.Int32_input, a.UInt32_input, a.Int64_input, a.UInt64_input,
       a.Boolean_input, a.String_input, a.Binary_input, a.Enumeration_input, a.vec_in]
experiment: {{start: 0.0, stop: 0.3, step: 0.1}}
"""


@pytest.mark.parametrize("interface, isolate", [("co_simulation", False),
                                               ("model_exchange", False),
                                               ("co_simulation", True)])
def test_every_type_passes_through_two_fmus(fmus, interface, isolate) -> None:
    """Also with the structural parameter n given after the array it sizes, and with `a` in a
    worker process."""
    system = loads(chain(fmus["types3"], interface, isolate), source="types.yaml")
    a = system.components["a"]
    assert a.variables["scaled"].size == 2 and a.variables["gains"].size == 2
    r = simulate(system)
    for t, value in GIVEN.items():
        assert r[f"b.{t}_output"][-1] == float(value), t
    np.testing.assert_array_equal([r[f"a.scaled[{i}]"][-1] for i in (1, 2)], [8.0, -15.0])
    np.testing.assert_array_equal([r[f"b.vec_out[{i}]"][-1] for i in (1, 2, 3)], [16, 20, 24])
    assert system.components["b"].get("String_input") == "hé llo"


def test_text_and_bytes_come_back_from_the_fmu(fmus) -> None:
    c = FmuComponent("t", fmus["types3"], n=4, gains=[1, 2, 3, 4])
    c.set_parameter("String_input", "xyz")
    c.set_parameter("Binary_input", bytes([0, 1, 254]))
    c.prepare(RunContext(None, 0.1, False))
    c.setup(0.0, 1.0)
    try:
        c.initialize()
        assert c.get("String_output") == "xyz" and c.get("Binary_output") == b"\x00\x01\xfe"
        assert c.get("scaled") == (1.0, 4.0, 9.0, 0.0)
        assert c.get("UInt64_output") == 9000000000 and c.get("Float32_output") == 1.5
        c.__dict__["Int8_input"] = -5
        c.evaluate(0.0)
        assert c.get("Int8_output") == -5
    finally:
        c.terminate()


def test_out_of_range_integer_from_yaml_is_refused_at_check(fmus) -> None:
    text = chain(fmus["types3"], "co_simulation").replace("UInt8_input: 255", "UInt8_input: 256")
    with pytest.raises(CosimError, match=r"UInt8_input.*256 is above the maximum 255"):
        loads(text, source="types.yaml")


def test_mixed_type_feedthrough_chain_against_fmpy(tmp_path) -> None:
    """Two FMI 2.0 mixed-type FMUs, every output of a wired to the input of b of its type:
    b's outputs are the analytic composition, and a alone equals fmpy's simulate_fmu."""
    from fmpy import simulate_fmu

    mixed = build_c_fmu("mixed2", tmp_path)
    pairs = [("r1o", "r1"), ("r2o", "r2"), ("i1o", "i1"), ("i2o", "i2"), ("b1o", "b1"),
             ("s1o", "s1")]
    wires = "\n".join(f"  - a.{o} -> b.{i}" for o, i in pairs)
    text = f"""
components:
  a:
    kind: fmu
    parameters: {{path: {mixed}}}
    initial: {{r1: 0.25, r2: -2.0, i1: 7, i2: 5, b1: true, s1: "wired text"}}
  b: {{kind: fmu, parameters: {{path: {mixed}}}}}
connections:
{wires}
open: [a.r1, a.r2, a.i1, a.i2, a.b1, a.s1]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""
    system = loads(text, source="mixed.yaml")
    r = simulate(system)
    assert (r["b.r1o"][-1], r["b.r2o"][-1], r["b.i1o"][-1], r["b.i2o"][-1], r["b.b1o"][-1]) == \
        (1.0, 0.0, 9, 45, 1.0)
    assert system.components["b"].get("s1") == "wired text"
    np.testing.assert_allclose(r["b.acc"], r["time"] * 0.5, atol=1e-12)
    ref = simulate_fmu(str(mixed), stop_time=1.0, output_interval=0.1,
                       start_values={"r1": 0.25, "r2": -2.0, "i1": 7, "i2": 5, "b1": True},
                       output=["r1o", "r2o", "i1o", "i2o", "b1o", "acc"])
    for name in ("r1o", "r2o", "i1o", "i2o", "b1o"):
        np.testing.assert_array_equal(r[f"a.{name}"], ref[name].astype(float), err_msg=name)
    # fmpy steps by differences of its time grid, the master by a fixed h: rounding differs
    np.testing.assert_allclose(r["a.acc"], ref["acc"], rtol=0, atol=1e-15)
