"""Subsystems in YAML (`kind: system`): another scenario file used as a block, its exposed ports
with units, values of its blocks set from outside, nesting, and the errors of bad inclusions.

The answers are analytic: a gain k inside a subsystem gives k u; a port exposed in mm in front of
an inner port in m receives the value / 1000."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.cli import main
from twmr.core import ScenarioError, WiringError
from twmr.core.errors import AlgebraicLoopError
from twmr.scenario import load_structure

AMP = """\
# y = k u, as a subsystem
inputs:
  u: g.u
outputs:
  y: {port: g.y}
components:
  g: {kind: gain, parameters: {k: 1.0}}
"""

TOP = """\
components:
  src: {kind: constant, parameters: {value: 2.0}}
  amp: {kind: system, parameters: {path: amp.yaml}}
connections:
  - src.y -> amp.u
experiment: {stop: 0.005, step: 0.001}
record: {signals: [amp.g.y, src.y]}
"""

ECHO = '''\
from twmr.core import Component, Input, Output


class Echo(Component):
    """y = x, both in metres."""

    x = Input(unit="m")
    y = Output(unit="m", depends_on=("x",))

    def evaluate(self, t: float) -> None:
        self.y = self.x

    def do_step(self, t: float, h: float) -> None:
        self.y = self.x
'''


def write(folder: Path, **files: str) -> None:
    """Write each file: `mid__amp_yaml` is mid/amp.yaml ('__' a slash, the last '_' the dot)."""
    for key, text in files.items():
        stem, _, suffix = key.replace("__", "/").rpartition("_")
        (folder / f"{stem}.{suffix}").write_text(text)


def column(result: twmr.Result, name: str) -> np.ndarray:
    return np.asarray(result.data[name])


def line_of(path: Path, text: str) -> int:
    """The 1-based line of `path` that contains `text`."""
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if text in line)


@pytest.mark.parametrize("how", ["including file", "--set", "set list of load"])
def test_a_gain_inside_a_subsystem_set_to_3_gives_3u(tmp_path: Path, how: str) -> None:
    top = TOP.replace("path: amp.yaml}", "path: amp.yaml, g.k: 3.0}") \
        if how == "including file" else TOP
    write(tmp_path, amp_yaml=AMP, top_yaml=top)
    overrides = [] if how == "including file" else ["amp.g.k=3"]
    if how == "--set":
        assert main(["run", str(tmp_path / "top.yaml"), "--out", str(tmp_path / "r"), "-q",
                     *[f"--set={o}" for o in overrides], "--format", "csv"]) == 0
        y = np.loadtxt(tmp_path / "r" / "result.csv", delimiter=",", skiprows=1)[:, 1]
    else:
        y = column(twmr.simulate(twmr.load(tmp_path / "top.yaml", overrides)), "amp.g.y")
    assert len(y) == 6 and np.all(y == 3.0 * 2.0)


def test_nested_three_deep_values_and_names_reach_the_innermost_block(tmp_path: Path) -> None:
    mid = """\
inputs: {u: amp.u}
outputs: {y: amp.y}
components:
  amp: {kind: system, parameters: {path: amp.yaml, g.k: 5.0}}
"""
    outer = """\
inputs: {u: mid.u}
outputs: {y: mid.y}
components:
  mid: {kind: system, parameters: {path: mid/mid.yaml}}
"""
    (tmp_path / "mid").mkdir()
    write(tmp_path, mid__amp_yaml=AMP, mid__mid_yaml=mid, outer_yaml=outer)
    top = TOP.replace("amp: {kind: system, parameters: {path: amp.yaml}}",
                      "robot: {kind: system, parameters: {path: outer.yaml}}") \
        .replace("amp.u", "robot.u").replace("amp.g.y", "robot.y")
    write(tmp_path, top_yaml=top)
    base = twmr.simulate(twmr.load(tmp_path / "top.yaml"))
    # the exposed output recorded by its outer name is the innermost port, by its full path
    assert base.data.dtype.names == ("time", "robot.mid.amp.g.y", "src.y")
    assert np.all(column(base, "robot.mid.amp.g.y") == 10.0)  # k = 5 set by mid.yaml
    again = twmr.simulate(twmr.load(tmp_path / "top.yaml", ["robot.mid.amp.g.k=-0.5"]))
    assert np.all(column(again, "robot.mid.amp.g.y") == -1.0)


def test_a_port_exposed_in_other_units_converts_on_the_way(tmp_path: Path) -> None:
    sub = """\
inputs:
  x: {port: e.x, unit: mm}     # outside, x is in millimetres
outputs:
  y: {port: e.y, unit: cm}     # and y in centimetres
components:
  e: {kind: "echo.py:Echo"}
"""
    top = """\
components:
  src: {kind: constant, parameters: {value: 1500.0}}
  s: {kind: system, parameters: {path: sub.yaml}}
  g: {kind: gain}
connections:
  - src.y -> s.x
  - s.y -> g.u
experiment: {stop: 0.003, step: 0.001}
record: {signals: [s.e.x, s.e.y, g.u]}
"""
    write(tmp_path, echo_py=ECHO, sub_yaml=sub, top_yaml=top)
    scenario = twmr.load(tmp_path / "top.yaml")
    gains = {(c.dst, c.dst_port): c.gain for c in scenario.system.connections}
    assert gains == {("s.e", "x"): 1e-3, ("g", "u"): 100.0}
    result = twmr.simulate(scenario)
    assert np.all(column(result, "s.e.x") == 1.5)      # 1500 mm = 1.5 m
    assert np.all(column(result, "g.u") == 150.0)      # 1.5 m = 150 cm


def test_an_exposed_unit_of_another_quantity_names_the_inner_file_line(tmp_path: Path) -> None:
    sub = "inputs:\n  x: {port: e.x, unit: kg}\ncomponents:\n  e: {kind: \"echo.py:Echo\"}\n"
    top = "components:\n  src: {kind: constant}\n  s: {kind: system, parameters: {path: " \
          "sub.yaml}}\nconnections: [src.y -> s.x]\nexperiment: {stop: 0.01, step: 0.001}\n"
    write(tmp_path, echo_py=ECHO, sub_yaml=sub, top_yaml=top)
    with pytest.raises(WiringError) as err:
        twmr.load(tmp_path / "top.yaml")
    text = str(err.value)
    assert f"{tmp_path / 'sub.yaml'}:2" in text and "exposed input 's.x'" in text
    assert "'kg'" in text and "'m'" in text and "Fix:" in text
    assert len(err.value.problems) == 1  # the wire through it is not reported again


def test_a_cycle_of_inclusion_names_each_including_line(tmp_path: Path) -> None:
    write(tmp_path,
          a_yaml="components:\n  b: {kind: system, parameters: {path: b.yaml}}\n"
                 "experiment: {stop: 1, step: 0.1}\n",
          b_yaml="outputs: {y: a.y}\ncomponents:\n  a:\n    kind: system\n"
                 "    parameters: {path: a.yaml}\n")
    with pytest.raises(ScenarioError) as err:
        twmr.load(tmp_path / "a.yaml")
    text = str(err.value)
    assert "\n" not in text and text.count("Fix:") == 1
    assert f"{tmp_path / 'a.yaml'}:2" in text and f"{tmp_path / 'b.yaml'}:5" in text
    assert "never ends" in text
    write(tmp_path, self_yaml="components:\n  me: {kind: system, parameters: {path: self.yaml}}"
                              "\nexperiment: {stop: 1, step: 0.1}\n")
    with pytest.raises(ScenarioError, match=r"self\.yaml:2 .*includes '\S*self\.yaml'"):
        twmr.load(tmp_path / "self.yaml")


def test_a_missing_file_names_the_including_file_and_line(tmp_path: Path) -> None:
    write(tmp_path, top_yaml=TOP.replace("amp.yaml", "nothere.yaml"))
    with pytest.raises(ScenarioError) as err:
        twmr.load(tmp_path / "top.yaml")
    text = str(err.value)
    assert text.startswith(f"{tmp_path / 'top.yaml'}:3 (components.amp.parameters.path)")
    assert "'nothere.yaml'" in text and "does not exist" in text and "Fix:" in text


def test_a_port_typo_in_the_inner_file_names_its_line_and_the_full_path(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP.replace("u: g.u", "u: g.uu"), top_yaml=TOP)
    with pytest.raises(WiringError) as err:
        twmr.load(tmp_path / "top.yaml")
    first = err.value.problems[0]
    assert (first.location.file, first.location.line) == (str(tmp_path / "amp.yaml"), 3)
    assert "exposed input 'amp.u'" in first.message and "'amp.g'" in first.message
    assert "did you mean 'u'" in first.message


def test_a_wire_to_a_port_the_subsystem_does_not_expose_is_refused(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP,
          top_yaml=TOP.replace("  - src.y -> amp.u\n",
                               "  - src.y -> amp.uu\n  - src.y -> amp.g.u\n"))
    with pytest.raises(ScenarioError) as err:
        twmr.load(tmp_path / "top.yaml")
    messages = [p.message for p in err.value.problems]
    assert "exposes no input 'uu' (did you mean 'u'?)" in messages[0]
    assert "'amp.g.u' reaches inside the subsystem 'amp'" in messages[1]
    assert "exposed input 'amp.u'" in messages[2] and "is not connected" in messages[2]


def test_an_exposed_input_may_be_left_open_and_is_open_when_the_file_runs_alone(
        tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP + "experiment: {stop: 0.002, step: 0.001}\n",
          top_yaml=TOP.replace("connections:\n  - src.y -> amp.u\n", "open: [amp.u]\n"))
    assert np.all(column(twmr.simulate(twmr.load(tmp_path / "top.yaml")), "amp.g.y") == 0.0)
    alone = twmr.simulate(twmr.load(tmp_path / "amp.yaml", ["g.u=4", "g.k=0.5"]))
    assert np.all(column(alone, "g.y") == 2.0)  # the open input kept the value given to it


def test_a_subsystem_file_without_an_experiment_does_not_run_alone(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP)
    with pytest.raises(ScenarioError, match=r"amp\.yaml:\d+ \(experiment\): .*has no "
                                            r"'experiment:' .*Fix:"):
        twmr.load(tmp_path / "amp.yaml")


def test_an_algebraic_loop_through_a_subsystem_prints_the_full_paths(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP, top_yaml="""\
components:
  amp: {kind: system, parameters: {path: amp.yaml}}
  back: {kind: gain}
connections:
  - amp.y -> back.u
  - back.y -> amp.u
experiment: {stop: 0.01, step: 0.001}
""")
    with pytest.raises(AlgebraicLoopError) as err:
        twmr.load(tmp_path / "top.yaml")
    assert "amp.g.y -> back.u => back.y -> amp.g.u => amp.g.y" in str(err.value)
    assert re.search(r"top\.yaml:\d+ \(connections", str(err.value))


def test_a_step_multiple_on_a_subsystem_multiplies_its_blocks(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP.replace("k: 1.0}}", "k: 1.0}, step_multiple: 2}"),
          top_yaml=TOP.replace("path: amp.yaml}}", "path: amp.yaml}, step_multiple: 3}"))
    system = twmr.load(tmp_path / "top.yaml").system
    assert system.multiple("amp.g") == 6 and system.multiple("src") == 1
    assert twmr.load(tmp_path / "top.yaml", ["amp.step_multiple=1"]).system.multiple(
        "amp.g") == 2


def test_bad_values_from_outside_name_the_subsystem_and_its_blocks(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP, top_yaml=TOP)
    cases = {
        "amp.k=3": "'amp' is a subsystem",
        "amp.x.k=3": "no component 'x' in the subsystem 'amp'",
        "src.value.k=1": "component 'src' (Constant) has no parameter 'value.k' (did you "
                         "mean 'value'?)",
        "amp.g.kk=1": "component 'amp.g' (Gain) has no parameter 'kk' (did you mean 'k'?)"}
    for text, expected in cases.items():
        with pytest.raises(ScenarioError) as err:
            twmr.load(tmp_path / "top.yaml", [text])
        assert expected in str(err.value) and f"--set ({text})" in str(err.value), text
    write(tmp_path, top_yaml=TOP.replace("path: amp.yaml}", "path: amp.yaml, k: 2}"))
    with pytest.raises(ScenarioError, match=r"top\.yaml:3 .*'k' of subsystem 'amp'.*g\.k"):
        twmr.load(tmp_path / "top.yaml")


def test_an_inner_problem_is_located_in_the_inner_file(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP.replace("k: 1.0", "k: fast"), top_yaml=TOP)
    with pytest.raises(ScenarioError) as err:
        twmr.load(tmp_path / "top.yaml")
    where = err.value.problems[0].location
    assert (where.file, where.line) == (str(tmp_path / "amp.yaml"), line_of(
        tmp_path / "amp.yaml", "fast"))
    assert "component 'amp.g'" in err.value.problems[0].message


def test_the_structure_keeps_the_nesting_and_its_exposed_ports(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP, top_yaml=TOP.replace("path: amp.yaml}", "path: amp.yaml, "
                                                       "g.k: 3.0}"))
    spec = load_structure(tmp_path / "top.yaml")
    inner = spec.components["amp"].system
    assert inner is not None and list(inner.components) == ["g"]
    assert inner.components["g"].parameters["k"].value == 3.0
    assert inner.components["g"].parameters["k"].where.file == str(tmp_path / "top.yaml")
    assert inner.inputs["u"].port.value == "g.u" and inner.outputs["y"].unit is None


def test_twmr_check_prints_the_tree(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(tmp_path, amp_yaml=AMP.replace("u: g.u", "u: {port: g.u, unit: '1'}"), top_yaml=TOP)
    assert main(["check", str(tmp_path / "top.yaml")]) == 0
    out = capsys.readouterr().out
    assert "  2. amp.g: Gain feedthrough" in out
    tree = out[out.index("tree (subsystems"):].splitlines()[1:6]
    assert tree == ["  src: constant", f"  amp: system {tmp_path / 'amp.yaml'}",
                    "    input  u [1] -> g.u", "    output y <- g.y", "    g: gain"]


def test_one_file_used_twice_and_from_a_dict_gives_two_independent_blocks(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP)
    data = {"components": {"src": {"kind": "constant", "parameters": {"value": 2.0}},
                           "a": {"kind": "system", "parameters": {"path": "amp.yaml",
                                                                  "g.k": 3.0}},
                           "b": {"kind": "system", "parameters": {"path": "amp.yaml"}}},
            "connections": ["src.y -> a.u", "a.y -> b.u"],
            "experiment": {"stop": 0.002, "step": 0.001}, "record": {"signals": ["*.g.y"]}}
    spec = twmr.scenario.read_structure(data, "<dict>", tmp_path)
    result = twmr.simulate(twmr.load(spec, ["b.g.k=-1"]))
    assert result.data.dtype.names == ("time", "a.g.y", "b.g.y")
    assert np.all(column(result, "a.g.y") == 6.0) and np.all(column(result, "b.g.y") == -6.0)


def test_a_format_error_in_the_inner_file_says_where_it_was_included(tmp_path: Path) -> None:
    write(tmp_path, amp_yaml=AMP.replace("{kind: gain,", "{kind: gain, paramters: {},"),
          top_yaml=TOP)
    with pytest.raises(ScenarioError) as err:
        twmr.load(tmp_path / "top.yaml")
    text = str(err.value)
    assert text.startswith(f"{tmp_path / 'amp.yaml'}:7 (components.g.paramters)")
    assert f"(included as 'amp' at {tmp_path / 'top.yaml'}:3). Fix:" in text


def test_exposed_ports_select_elements_and_wires_select_from_them(tmp_path: Path) -> None:
    sub = """\
outputs:
  y: ref.position[2]                                  # y_T = sin(0.5 t) + 0.5 t + 1
  position: {port: ref.position, unit: [mm, cm]}
components:
  ref: {kind: trajectory, parameters: {shape: paper1}}
"""
    top = """\
components:
  s: {kind: system, parameters: {path: sub.yaml}}
  a: {kind: gain}
  b: {kind: gain}
connections:
  - s.y -> a.u
  - s.position[2] -> b.u
experiment: {stop: 0.5, step: 0.01}
record: {signals: [a.u, b.u]}
"""
    write(tmp_path, sub_yaml=sub, top_yaml=top)
    result = twmr.simulate(twmr.load(tmp_path / "top.yaml"))
    t = column(result, "time")
    np.testing.assert_allclose(column(result, "a.u"), np.sin(0.5 * t) + 0.5 * t + 1, rtol=1e-12)
    np.testing.assert_allclose(column(result, "b.u"), 100 * column(result, "a.u"), rtol=1e-12)
    write(tmp_path, top_yaml=top.replace("s.position[2]", "s.y[2]"))
    with pytest.raises(ScenarioError, match=r"top\.yaml:7 .*'s\.y\[2\]' selects element 2 but "
                                            r"the exposed output 's\.y' \(ref\.position\[2\]\) "
                                            r"has 1"):
        twmr.load(tmp_path / "top.yaml")
