"""The signal-routing blocks (`mux`, `demux`, `selector`, `gain` with a matrix, `sum` with
signs, `product`, `math`) against numpy and analytic answers; bad parameters refused by `twmr
check`; each exported as a C FMU and run in fmpy; and one scenario chaining every discrete,
linear and routing block, vectors included, whose compiled loop (numba) is bit-identical to the
Python schedule under both fixed-step algorithms."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from twmr.core.errors import ScenarioError
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load, loads
from twmr.testing import Harness

rng = np.random.default_rng(11)


def outputs(kind: str, params: dict[str, Any], **inputs: Any) -> dict[str, Any]:
    """The block's outputs for `inputs` at its start (direct feedthrough)."""
    with Harness(kind, parameters=params) as dut:
        dut.set(**inputs)
        dut.initialize()
        comp = dut.component
        comp.evaluate(0.0)
        return {name: np.array(comp.get(name), dtype=float) for name in comp.outputs}


def test_gain_scalar_element_wise_and_matrix_match_numpy():
    u = rng.standard_normal(3)
    K = rng.standard_normal((2, 3))
    assert outputs("gain", {"k": 2.5}, u=0.4)["y"] == 2.5 * 0.4
    assert np.array_equal(outputs("gain", {"k": -3.0, "n_in": 3, "n_out": 3}, u=tuple(u))["y"],
                          -3.0 * u)
    got = outputs("gain", {"n_in": 3, "n_out": 2, "K": K.tolist()}, u=tuple(u))["y"]
    assert np.allclose(got, K @ u, rtol=1e-15, atol=1e-15)


def test_sum_with_signs_and_the_old_k1_k2():
    assert outputs("sum", {"k1": 2.0, "k2": -1.0}, u1=3.0, u2=0.5)["y"] == 5.5
    got = outputs("sum", {"signs": "+-+-", "k1": 2.0}, u1=1.0, u2=2.0, u3=4.0, u4=8.0)["y"]
    assert got == 2.0 - 2.0 + 4.0 - 8.0
    a, b, c = rng.standard_normal((3, 2))
    got = outputs("sum", {"signs": "-+-", "n": 2}, u1=tuple(a), u2=tuple(b), u3=tuple(c))["y"]
    assert np.allclose(got, -a + b - c, rtol=1e-15)


def test_product_multiplies_and_divides_element_wise():
    a, b, c = rng.standard_normal((3, 3))
    got = outputs("product", {"ops": "*/*", "n": 3}, u1=tuple(a), u2=tuple(b), u3=tuple(c))["y"]
    assert np.allclose(got, a / b * c, rtol=1e-14)
    assert outputs("product", {"ops": "/*"}, u1=4.0, u2=2.0)["y"] == 0.5
    assert outputs("product", {"ops": "*/"}, u1=1.0, u2=0.0)["y"] == np.inf


def test_mux_demux_and_selector_route_elements():
    y = outputs("mux", {"n_in": 3, "width": 2}, u1=(1.0, 2.0), u2=(3.0, 4.0), u3=(5.0, 6.0))["y"]
    assert np.array_equal(y, [1, 2, 3, 4, 5, 6])
    parts = outputs("demux", {"n_out": 3, "width": 2}, u=(1.0, 2.0, 3.0, 4.0, 5.0, 6.0))
    assert [list(parts[f"y{i}"]) for i in (1, 2, 3)] == [[1, 2], [3, 4], [5, 6]]
    u = tuple(rng.standard_normal(5))
    got = outputs("selector", {"width": 5, "indices": [5, 1, 1, 3]}, u=u)["y"]
    assert np.array_equal(got, np.array(u)[[4, 0, 0, 2]])


@pytest.mark.parametrize("function, reference", [
    ("abs", np.abs), ("sqrt", np.sqrt), ("exp", np.exp), ("log", np.log), ("log10", np.log10),
    ("sin", np.sin), ("cos", np.cos), ("tan", np.tan), ("asin", np.arcsin), ("acos", np.arccos),
    ("atan", np.arctan), ("tanh", np.tanh), ("square", np.square),
    ("reciprocal", np.reciprocal), ("sign", np.sign)])
def test_math_functions_match_numpy_inside_and_outside_their_domain(function, reference):
    u = np.array([-2.5, -1.0, -0.3, 0.0, 0.7, 1.0, 3.0, 800.0])
    with np.errstate(all="ignore"):
        want = reference(u)
    got = outputs("math", {"function": function, "n": len(u)}, u=tuple(u))["y"]
    assert np.allclose(got, want, rtol=1e-15, atol=0, equal_nan=True), (got, want)


def scenario(kind: str, params: str, open_: str = "blk.u") -> str:
    return (f"components:\n  blk: {{kind: {kind}, parameters: {{{params}}}}}\n"
            f"open: [{open_}]\nexperiment: {{stop: 0.01, step: 0.001}}\n")


@pytest.mark.parametrize("kind, params, words", [
    ("selector", "width: 3, indices: [0, 4]", ["'blk'", "indices", "1 .. 3", "Fix"]),
    ("gain", "n_in: 2, n_out: 2, K: [1, 2, 3]", ["'blk'", "K has 3 values", "2 x 2"]),
    ("gain", "n_in: 2, n_out: 3", ["'blk'", "scalar gain", "n_in = 2"]),
    ("math", "function: cbrt", ["'blk'", "function", "sqrt"]),
])
def test_bad_parameters_are_refused_at_check_in_one_paragraph(kind, params, words):
    with pytest.raises(ScenarioError) as err:
        loads(scenario(kind, params))
    text = str(err.value)
    assert "Traceback" not in text
    for word in words:
        assert word in text, text


def test_a_bad_sign_pattern_is_refused_naming_it():
    with pytest.raises(ScenarioError) as err:
        loads(scenario("sum", "signs: '+*'", "blk.u1, blk.u2"))
    assert "'blk'" in str(err.value) and "signs" in str(err.value) and "+*" in str(err.value)


KINDS = {"mux": ["n_in=3"], "demux": ["n_out=2", "width=2"], "selector": ["width=3",
         "indices=[3, 1]"], "gain": ["n_in=2", "n_out=2", "K=[[1, 2], [3, 4]]"],
         "sum": ["signs=+-+"], "product": ['ops="*/"'], "math": ["function=atan", "n=2"]}


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_twmr_export_runs_in_fmpy(kind: str, tmp_path: Path):
    """The FMU, its inputs all 2.0, gives the block's outputs for those inputs."""
    from fmpy import read_model_description, simulate_fmu

    out = tmp_path / f"{kind}.fmu"
    sets = [a for s in KINDS[kind] for a in ("--set", s)]
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "export", kind, "--out", str(out),
                           *sets], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    md = read_model_description(str(out))
    names = [v.name for v in md.modelVariables if v.causality == "input"]
    signal_in = np.array([(t, *([2.0] * len(names))) for t in (0.0, 1.0)],
                         dtype=[("time", float)] + [(n, float) for n in names])
    res = simulate_fmu(str(out), stop_time=0.01, output_interval=1e-3, input=signal_in,
                       fmi_type="CoSimulation")
    import yaml

    params = {s.split("=")[0]: yaml.safe_load(s.split("=")[1]) for s in KINDS[kind]}
    with Harness(kind, parameters=params) as dut:
        comp = dut.component
        dut.set(**{n: comp.variables[n].coerce(2.0) for n in comp.inputs}).initialize()
        want = [float(x) for n in comp.outputs for x in np.ravel(comp.get(n))]
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    got = np.array([[row[n] for n in outs] for row in res])
    assert np.allclose(got, np.tile(want, (len(res), 1)), rtol=1e-14, atol=0)


CHAIN = """\
components:
  src: {kind: sine, parameters: {amplitude: 1.0, frequency: 2.0}}
  src2: {kind: step, parameters: {height: 0.5, time: 0.1}}
  mux: {kind: mux, parameters: {n_in: 2}}
  K: {kind: gain, parameters: {n_in: 2, n_out: 3, K: [[1.0, 2.0], [0.5, -1.0], [3.0, 0.0]]}}
  sel: {kind: selector, parameters: {width: 3, indices: [3, 1]}}
  lag: {kind: first_order, parameters: {n: 2, T: 0.05}}
  zoh: {kind: zero_order_hold, parameters: {n: 2, sample_period: 0.005}}
  dly: {kind: transport_delay, parameters: {n: 2, delay: 0.0025, buffer: 16}}
  dm: {kind: demux, parameters: {n_out: 2}}
  m: {kind: math, parameters: {function: tanh}}
  s: {kind: sum, parameters: {signs: "+-+"}}
  p: {kind: product, parameters: {ops: "**"}}
  two: {kind: constant, parameters: {value: 2.0}}
  tf: {kind: transfer_function, parameters: {num: [1.0, 3.0], den: [0.1, 1.0, 4.0]}}
  tfz: {kind: transfer_function, parameters: {num: [0.5, 0.1], den: [1.0, -0.9], method: discrete}}
  tft: {kind: transfer_function, parameters: {num: [1.0], den: [0.02, 1.0], method: tustin}}
  pid: {kind: pid, parameters: {kp: 2.0, ki: 1.0, kd: 0.01, N: 50.0, limit_output: true,
                                 y_min: -0.5, y_max: 0.5, antiwindup: back_calculation}}
  ss: {kind: state_space, parameters: {n_in: 2, n_out: 2, A: [[-1.0, 2.0], [-3.0, -4.0]],
                                       B: [[1.0, 0.0], [0.5, 2.0]], C: [[1.0, -1.0], [0.0, 1.0]],
                                       D: [[0.0, 0.1], [0.0, 0.0]]}}
  ss1: {kind: state_space, parameters: {A: [-2.0], B: [1.0], C: [1.0]}}
  g: {kind: gain, parameters: {k: -2.0, n_in: 2, n_out: 2}}
connections:
  - src.y -> mux.u1
  - src2.y -> mux.u2
  - mux.y -> K.u
  - K.y -> sel.u
  - sel.y -> lag.u
  - lag.y -> zoh.u
  - zoh.y -> dly.u
  - dly.y -> dm.u
  - dm.y1 -> m.u
  - m.y -> s.u1
  - dm.y2 -> s.u2
  - src.y -> s.u3
  - s.y -> p.u1
  - two.y -> p.u2
  - p.y -> tf.u
  - tf.y -> tfz.u
  - tfz.y -> tft.u
  - tft.y -> pid.u
  - mux.y -> ss.u
  - ss.y -> g.u
  - pid.y -> ss1.u
experiment: {start: 0.0, stop: 1.0, step: 1.0e-3}
record: {signals: [K.y, sel.y, lag.y, zoh.y, dly.y, m.y, s.y, p.y, tf.y, tfz.y, tft.y, pid.y,
                   ss.y, g.y, ss1.y]}
"""


def _run(path: Path, mode: str, algorithm: str) -> np.ndarray:
    store = ResultStore()
    Execution(load(path, [f"experiment.algorithm={algorithm}"]), [store],
              algorithm=make_algorithm(algorithm, mode)).run()
    return store.data()


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
def test_every_block_in_one_chain_compiled_is_bit_identical(tmp_path: Path, algorithm: str):
    path = tmp_path / "chain.yaml"
    path.write_text(CHAIN)
    python = _run(path, "off", algorithm)
    compiled = _run(path, "on", algorithm)
    assert python.shape == (1001, 24) and np.all(np.isfinite(python))
    assert np.array_equal(python, compiled), np.max(np.abs(python - compiled))


def test_every_example_of_the_block_docs_is_accepted():
    """docs/blocks.md, its discrete, linear and routing sections: each example line builds its
    block, checked and initialised."""
    import re

    import yaml

    text = (Path(__file__).resolve().parents[2] / "docs" / "blocks.md").read_text()
    text = text[text.index("## Discrete and linear"):]
    examples = re.findall(r"```yaml\n(.*?)\n```", text, re.S)
    assert len(examples) == 13
    for example in examples:
        (spec,) = yaml.safe_load(example).values()
        with Harness(spec["kind"], parameters=spec["parameters"]) as dut:
            assert dut.component.check(frozenset(spec["parameters"])) == []
            dut.initialize()
