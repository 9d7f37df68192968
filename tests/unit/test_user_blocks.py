"""A user's own block from YAML: `kind: "file.py:Class"` (relative to the scenario's folder) and
`kind: "package.module:Class"`, registered kinds of an installed package, and every way such a
kind can be wrong, each one paragraph naming the scenario line, the component, the file and class
and the fix. The worked example of docs/components.md runs as documented, in the Python and the
compiled loop, with identical rows."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core import ScenarioError
from twmr.scenario import loads

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "scenarios" / "examples"
DOC = ROOT / "docs" / "components.md"

SCALE = '''
from twmr.core import Component, Input, Output, Parameter


class Scale(Component):
    """y = {formula}."""

    k = Parameter(2.0, unit="1")
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def evaluate(self, t: float) -> None:
        self.y = {formula}
'''

SCENARIO = """components:
  src: {{kind: sine, parameters: {{amplitude: 1.0, frequency: 1.0}}}}
  blk:
    kind: "{kind}"
    parameters: {{k: 3.0}}
connections: [src.y -> blk.u]
experiment: {{start: 0.0, stop: 0.1, step: 0.01}}
"""


def write_block(folder: Path, formula: str = "self.k * self.u", name: str = "my_block.py",
                text: str | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text if text is not None else SCALE.format(formula=formula))
    return path


def write_scenario(folder: Path, kind: str = "my_block.py:Scale") -> Path:
    path = folder / "scenario.yaml"
    path.write_text(SCENARIO.format(kind=kind))
    return path


def cli(*args: str, cwd: Path, env: dict[str, str] | None = None
        ) -> subprocess.CompletedProcess[str]:
    """`twmr ARGS` as a user types it, in `cwd`."""
    return subprocess.run([sys.executable, "-m", "twmr.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def error_of(scenario: Path, overrides: tuple[str, ...] = ()) -> str:
    with pytest.raises(ScenarioError) as err:
        twmr.load(scenario, overrides)
    text = str(err.value)
    assert len(err.value.problems) == 1 and "\n" not in text and "Traceback" not in text, text
    return text


# -- the worked example of docs/components.md ------------------------------------------------
def test_the_documented_block_is_the_shipped_file() -> None:
    doc = DOC.read_text()
    shown = re.search(r"<!-- scenarios/examples/my_block.py -->\n```python\n(.*?)```", doc,
                      re.S)
    assert shown is not None, "docs/components.md shows scenarios/examples/my_block.py"
    assert shown.group(1) == (EXAMPLES / "my_block.py").read_text()
    assert "twmr run scenarios/examples/noisy_sensor.yaml" in doc


def test_worked_example_runs_from_twmr_run_with_identical_rows_python_and_compiled(
        tmp_path: Path) -> None:
    rows = {}
    for mode in ("off", "on"):
        env = {**os.environ, "TWMR_COMPILED": mode}
        out = tmp_path / mode
        done = cli("run", "scenarios/examples/noisy_sensor.yaml", "--out", str(out), "-q",
                   cwd=ROOT, env=env)
        assert done.returncode == 0, done.stderr
        summary = (out / "summary.json").read_text()
        assert ('"algorithm.compiled": true' in summary) == (mode == "on"), summary
        rows[mode] = twmr.read_result(out)
    python, compiled = rows["off"], rows["on"]
    assert python.columns == compiled.columns and len(python) == 1001
    assert np.array_equal(python.values, compiled.values)
    frame = python.to_pandas()
    for i, amplitude in ((1, 0.002), (2, 0.002), (3, 0.01)):  # noise: [2 mm, 2 mm, 0.01]
        noise = frame[f"sensor.measured[{i}]"] - frame[f"plant.pose[{i}]"]
        assert noise.abs().max() <= amplitude and noise.abs().max() > 0.9 * amplitude
        assert noise.std() > amplitude / 3  # drawn anew every step, not a constant offset
    assert frame["plant.pose[1]"].iloc[-1] == pytest.approx(-10.0, abs=0.05)  # x_T = -t


def test_set_check_and_components_accept_the_user_block(tmp_path: Path) -> None:
    quiet = twmr.simulate(twmr.load(EXAMPLES / "noisy_sensor.yaml",
                                    ["sensor.noise=[0, 0, 0]", "experiment.stop=0.5"]))
    frame = quiet.to_pandas()
    for i in (1, 2, 3):
        assert (frame[f"sensor.measured[{i}]"] == frame[f"plant.pose[{i}]"]).all()
    checked = cli("check", "--trust-code", "noisy_sensor.yaml", "--set", "sensor.seed=3",
                  cwd=EXAMPLES)
    assert checked.returncode == 0, checked.stderr
    assert "sensor: NoisySensor feedthrough" in checked.stdout
    listed = cli("components", "--trust-code", "scenarios/examples/my_block.py:NoisySensor",
                 cwd=ROOT)
    assert listed.returncode == 0, listed.stderr
    assert "input     truth[3] [(m, m, rad)]" in listed.stdout
    assert "parameter noise[3] [(m, m, rad)]" in listed.stdout
    bad = cli("components", "--trust-code", "my_block.py:NoisySensr", cwd=EXAMPLES)
    assert bad.returncode == 1 and "did you mean 'NoisySensor'" in bad.stderr
    assert "Traceback" not in bad.stderr


# -- where the class comes from --------------------------------------------------------------
def test_file_kind_relative_to_the_scenario_folder_not_the_working_folder(tmp_path: Path,
                                                                          monkeypatch) -> None:
    write_block(tmp_path / "blocks")
    scenario = write_scenario(tmp_path, "blocks/my_block.py:Scale")
    monkeypatch.chdir(ROOT)
    result = twmr.simulate(scenario)
    frame = result.to_pandas()
    assert np.allclose(frame["blk.y"], 3.0 * frame["src.y"]) and frame["src.y"].abs().max() > 0.5


def test_two_scenarios_with_their_own_my_block_do_not_collide(tmp_path: Path) -> None:
    write_block(tmp_path / "a", "self.k * self.u")
    write_block(tmp_path / "b", "self.k + self.u")
    a = twmr.simulate(write_scenario(tmp_path / "a")).to_pandas()
    b = twmr.simulate(write_scenario(tmp_path / "b")).to_pandas()
    assert np.allclose(a["blk.y"], 3.0 * a["src.y"])
    assert np.allclose(b["blk.y"], 3.0 + b["src.y"])
    cls_a = twmr.load(tmp_path / "a" / "scenario.yaml").system.components["blk"]
    cls_b = twmr.load(tmp_path / "b" / "scenario.yaml").system.components["blk"]
    assert type(cls_a) is not type(cls_b)
    assert type(cls_a).__module__ != type(cls_b).__module__


def test_a_file_is_imported_once_per_process(tmp_path: Path) -> None:
    write_block(tmp_path, text=SCALE.format(formula="self.k * self.u") +
                "\nimport builtins\nbuiltins.twmr_test_imports = "
                "getattr(builtins, 'twmr_test_imports', 0) + 1\n")
    scenario = write_scenario(tmp_path)
    first = type(twmr.load(scenario).system.components["blk"])
    again = twmr.load(scenario, ["blk.k=4"])
    assert type(again.system.components["blk"]) is first
    import builtins

    assert builtins.twmr_test_imports == 1  # type: ignore[attr-defined]


def test_module_kind_and_a_dict_source(tmp_path: Path, monkeypatch) -> None:
    system = loads(SCENARIO.format(kind="twmr.blocks:Gain").replace("{k: 3.0}", "{k: 4.0}"))
    assert type(system.components["blk"]).__name__ == "Gain"
    assert system.components["blk"].k == 4.0
    write_block(tmp_path)
    monkeypatch.chdir(tmp_path)
    scenario = twmr.load({"components": {"src": {"kind": "constant", "parameters": {"value": 2.0}},
                                         "blk": {"kind": "my_block.py:Scale"}},
                          "connections": ["src.y -> blk.u"],
                          "experiment": {"stop": 0.05, "step": 0.01}})
    assert twmr.simulate(scenario).to_pandas()["blk.y"].iloc[-1] == 4.0  # k = 2 (default) * 2


def test_an_installed_package_registers_its_kind_by_entry_point(tmp_path: Path) -> None:
    """A distribution on the path (as `pip install` leaves it: the package and its
    .dist-info with entry_points.txt) adds a kind by name, for `twmr components` and YAML."""
    site = tmp_path / "site"
    write_block(site / "acme_blocks", name="__init__.py")
    info = site / "acme_blocks-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: acme-blocks\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[twmr.components]\nacme_scale = acme_blocks:Scale\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get(
        "PYTHONPATH", "")])}
    listed = cli("components", "acme_scale", cwd=tmp_path, env=env)
    assert listed.returncode == 0, listed.stderr
    assert "acme_scale: acme_blocks.Scale" in listed.stdout
    scenario = write_scenario(tmp_path, "acme_scale")
    ran = cli("run", str(scenario), "--out", str(tmp_path / "out"), "-q", cwd=tmp_path, env=env)
    assert ran.returncode == 0, ran.stderr
    frame = twmr.read_result(tmp_path / "out").to_pandas()
    assert np.allclose(frame["blk.y"], 3.0 * frame["src.y"])


def test_a_sweep_rebuilds_the_user_block_in_its_worker_processes(tmp_path: Path) -> None:
    write_block(tmp_path)
    scenario = write_scenario(tmp_path)
    outcome = twmr.sweep(scenario, ["blk.k=values:5,7"], method="grid", out=tmp_path / "sweep",
                         workers=1, keep_signals=True)
    table = outcome.frame()
    assert list(table["status"]) == ["ok", "ok"], list(table["error"])
    assert all(w.rsplit(":", 1)[1] != str(os.getpid()) for w in table["worker"])
    for _, row in table.iterrows():
        frame = twmr.read_result(tmp_path / "sweep" / "runs" / row["run_id"]).to_pandas()
        assert np.allclose(frame["blk.y"], row["blk.k"] * frame["src.y"])


# -- every way a kind can be wrong -----------------------------------------------------------
def test_missing_file_names_the_scenario_line_component_and_path(tmp_path: Path) -> None:
    write_block(tmp_path, name="my_blocks.py")
    text = error_of(write_scenario(tmp_path))
    assert "scenario.yaml:4 (components.blk.kind)" in text and "component 'blk'" in text
    assert f"'{tmp_path / 'my_block.py'}'" in text and "does not exist" in text
    assert "did you mean 'my_blocks.py'" in text and "Fix:" in text


def test_syntax_error_in_the_user_file_names_its_own_line(tmp_path: Path) -> None:
    write_block(tmp_path, "self.k * * self.u")
    text = error_of(write_scenario(tmp_path))
    assert "scenario.yaml:4" in text and "component 'blk'" in text
    assert f"{tmp_path / 'my_block.py'}:16" in text and "syntax error" in text
    assert "Fix: correct line 16" in text


def test_missing_class_suggests_the_one_defined(tmp_path: Path) -> None:
    write_block(tmp_path)
    text = error_of(write_scenario(tmp_path, "my_block.py:Scal"))
    assert "scenario.yaml:4" in text and "defines no class 'Scal'" in text
    assert "did you mean 'Scale'" in text and "Fix: use one of the Component classes it " \
        "defines: Scale" in text


def test_not_a_component_subclass(tmp_path: Path) -> None:
    write_block(tmp_path, text="class Scale:\n    pass\n\n\ndef helper():\n    pass\n")
    text = error_of(write_scenario(tmp_path))
    assert "'Scale' in the file 'my_block.py' is a class not derived from " \
        "twmr.core.Component" in text
    assert "class Scale(Component):" in text
    text = error_of(write_scenario(tmp_path, "my_block.py:helper"))
    assert "'helper' in the file 'my_block.py' is a function, not a class" in text


def test_import_error_inside_the_file_names_the_line_and_the_missing_module(
        tmp_path: Path) -> None:
    write_block(tmp_path, text="import math\nimport no_such_dependency_xyz\n" +
                SCALE.format(formula="self.u"))
    text = error_of(write_scenario(tmp_path))
    assert f"{tmp_path / 'my_block.py'}:2" in text
    assert "no module named 'no_such_dependency_xyz'" in text
    assert "install the package that provides 'no_such_dependency_xyz'" in text
    write_block(tmp_path, text="x = 1 / 0\n")
    text = error_of(write_scenario(tmp_path))
    assert f"{tmp_path / 'my_block.py'}:1: ZeroDivisionError" in text


def test_unknown_module_and_a_module_name_that_is_a_file_next_to_the_scenario(
        tmp_path: Path) -> None:
    write_block(tmp_path)
    text = error_of(write_scenario(tmp_path, "my_block:Scale"))
    assert "imports the module 'my_block'" in text  # refused before any import
    assert "did you mean the file 'my_block.py:Scale'" in text
    text = error_of(write_scenario(tmp_path, "twmr.blocks:Gian"))
    assert "the module 'twmr.blocks' defines no class 'Gian' (did you mean 'Gain'?)" in text
    text = error_of(write_scenario(tmp_path, "my_block.py:"))
    assert "names no class after ':'" in text


def test_units_that_do_not_match_a_port_size_name_the_class_and_port(tmp_path: Path) -> None:
    write_block(tmp_path, text=SCALE.format(formula="self.u").replace(
        'u = Input(0.0)', 'u = Input(unit=("m", "m", "rad"))'))
    text = error_of(write_scenario(tmp_path))
    assert f"{tmp_path / 'my_block.py'}:" in text
    assert "Scale.u: 3 units ('m', 'm', 'rad') are given for a scalar Input (no size)" in text
    assert "Fix: declare it as a vector, Input(size=3, unit=('m', 'm', 'rad'))" in text
    from twmr.core import Component, Input
    from twmr.core.port import DeclarationError

    with pytest.raises((DeclarationError, RuntimeError)) as err:
        type("Pose", (Component,), {"pose": Input(size=2, unit=("m", "m", "rad"))})
    cause = err.value if isinstance(err.value, DeclarationError) else err.value.__cause__
    assert "Pose.pose: 3 units ('m', 'm', 'rad') are given for an Input of size 2" in str(cause)


def test_an_error_in_the_user_class_constructor_names_its_line(tmp_path: Path) -> None:
    text = SCALE.format(formula="self.u") + (
        "\n    def __init__(self, name='', **parameters):\n"
        "        super().__init__(name, **parameters)\n"
        "        self.table = {}['missing']\n")
    write_block(tmp_path, text=text)
    message = error_of(write_scenario(tmp_path))
    assert "scenario.yaml:3 (components.blk)" in message
    assert "component 'blk' (my_block.py:Scale) cannot be created" in message
    assert f"{tmp_path / 'my_block.py'}:20: KeyError" in message


TAGGED = '''
from twmr.core import STRING, Component, Output, Parameter


class Tagged(Component):
    """A block with a text parameter and a whole-number one."""

    tag = Parameter("", type=STRING)
    count = Parameter(0, type="Integer")
    y = Output(0.0)
'''


@pytest.mark.parametrize(("written", "text"), [
    ("01234567", "01234567"), ("0x1f", "0x1f"), ("1.10", "1.10"), ("on", "on"), ("1e3", "1e3"),
    ("'quoted'", "quoted"), ("42", "42")])
def test_a_text_parameter_keeps_what_was_written_where_yaml_reads_a_number(
        tmp_path: Path, written: str, text: str) -> None:
    write_block(tmp_path, name="tagged.py", text=TAGGED)
    scenario = tmp_path / "s.yaml"
    scenario.write_text("components:\n  blk:\n    kind: tagged.py:Tagged\n"
                        f"    parameters: {{tag: {written}, count: 0x10}}\n"
                        "experiment: {stop: 0.01, step: 0.01}\n")
    block = twmr.load(scenario).system.components["blk"]
    assert block.tag == text
    assert block.count == 16  # a number parameter takes the number
    again = twmr.load(scenario, overrides=[f"blk.tag={written}"]).system.components["blk"]
    assert again.tag == text
