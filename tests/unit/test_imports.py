"""The engine stays light and robot-free: `import twmr.master` loads no YAML or JSON Schema, a
1-step run loads none of the heavy libraries it does not use, the engine never imports the
robot's or the CAN package, and it ships none of their code (no kind of theirs named in its code,
no C twin of theirs among its files)."""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("scipy.signal", "scipy.interpolate", "control", "pandas", "matplotlib", "numba", "can",
         "fmpy", "twmr.components.compare", "twmr.components.metrics", "twmr.hw.drive")


def modules_after(code: str) -> set[str]:
    code += "\nimport sys\nprint(' '.join(sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    return set(out.stdout.split())


def test_import_master_loads_no_yaml_or_jsonschema() -> None:
    loaded = modules_after("import twmr.master")
    assert not {"yaml", "jsonschema", *HEAVY} & loaded


def test_a_one_step_run_loads_only_what_it_uses(tmp_path, monkeypatch) -> None:
    # an empty cache: with the kinds compiled already, `auto` runs even one step compiled (numba)
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    scenario = tmp_path / "one.yaml"
    scenario.write_text("components:\n  s: {kind: sine}\n  g: {kind: gain}\n"
                        "connections: [s.y -> g.u]\nexperiment: {stop: 0.001, step: 0.001}\n")
    loaded = modules_after(f"from twmr.cli import main\nmain(['run', {str(scenario)!r}, '--out', "
                           f"{str(tmp_path / 'out')!r}, '-q', '--format', 'csv'])")
    assert "pyarrow" in loaded and not set(HEAVY) & loaded


def test_a_valid_tiny_scenario_runs_without_jsonschema_dask_or_the_plugin_commands(
        tmp_path, monkeypatch) -> None:
    """jsonschema words problems only (a quick check passes a valid file), the installed
    packages' subcommands load only for `twmr <their name>`, and the entry points come from their
    cache once it is written for this way of starting Python (no importlib.metadata)."""
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    scenario = tmp_path / "one.yaml"
    scenario.write_text("components:\n  s: {kind: sine}\n  g: {kind: gain}\n"
                        "connections: [s.y -> g.u]\nexperiment: {stop: 0.001, step: 0.001}\n")
    run = (f"from twmr.cli import main\nassert main(['run', {str(scenario)!r}, '--out', "
           f"{str(tmp_path / 'out')!r}, '-q', '--format', 'none']) == 0")
    first, second = modules_after(run), modules_after(run)
    unwanted = {"jsonschema", "dask", "distributed", "matplotlib", "numba", "twmr.hw.cli",
                "twmr.components.cli", "twmr.blocks.nonlinear", "twmr.blocks.signals"}
    assert not unwanted & first and not unwanted & second
    kinds = "from twmr import registry\nassert 'sine' in registry.kinds()"
    assert "importlib.metadata" not in modules_after(kinds)  # read from the runs' cache
    broken = tmp_path / "broken.yaml"
    broken.write_text(scenario.read_text().replace("stop: 0.001", "stop: soon"))
    refused = modules_after(f"from twmr.cli import main\nassert main(['check', "
                            f"{str(broken)!r}]) == 1")
    assert "jsonschema" in refused  # the problem is worded by jsonschema


def test_the_paper_scenario_checks_and_runs_in_python_without_numba(tmp_path) -> None:
    """The robot's model is `kernel_function`s: plain Python until a compiled loop calls them,
    so checking the paper scenario and a run of it on the Python schedule import no numba."""
    paper = str(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml")
    checked = modules_after(f"from twmr.cli import main\nassert main(['check', {paper!r}]) == 0")
    ran = modules_after(
        f"import os\nos.environ['TWMR_COMPILED'] = 'off'\nimport twmr\n"
        f"r = twmr.simulate(twmr.load({paper!r}, ['experiment.stop=0.05']))\n"
        f"assert r.values.shape[0] == 6 and r.summary['status'] == 'completed'")
    assert "twmr.components.plant" in ran and "numba" not in checked | ran


def test_engine_sources_never_import_the_robot_or_can_packages() -> None:
    banned = re.compile(r"^\s*(from|import)\s+(twmr\.components|twmr\.hw|can|canopen|cantools)\b",
                        re.MULTILINE)
    for path in (ROOT / "src" / "twmr").rglob("*.py"):
        found = banned.search(path.read_text(encoding="utf-8"))
        assert found is None, f"{path.relative_to(ROOT)}: {found.group(0)}"


def _foreign(targets: dict[str, str]) -> set[str]:
    """The names registered by the robot's or the CAN package (not by the engine)."""
    return {name for name, target in targets.items()
            if target.startswith(("twmr.components.", "twmr.hw."))}


def _code_strings(tree: ast.AST) -> set[str]:
    """Every string constant of a module that is not a docstring."""
    docs = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) and \
                isinstance(body[0].value, ast.Constant):
            docs.add(id(body[0].value))
    return {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)
            and isinstance(n.value, str) and id(n) not in docs}


def test_engine_ships_no_robot_code() -> None:
    from twmr.fmi.cexport.twin import twin_of, twins
    from twmr.registry import kinds

    robot = _foreign(kinds())
    assert {"twmr_plant", "asmc", "slip_disturbance"} <= robot
    engine = ROOT / "src" / "twmr"
    for path in engine.rglob("*.py"):
        named = robot & _code_strings(ast.parse(path.read_text(encoding="utf-8")))
        assert not named, f"{path.relative_to(ROOT)} names the robot's kinds {sorted(named)}"
    engine_twins = {Path(twin_of(k).source).resolve() for k in set(twins()) - robot}
    defines_kernel = re.compile(r"^void kernel_step\(", re.MULTILINE)
    for path in engine.rglob("*.c"):
        if defines_kernel.search(path.read_text(encoding="utf-8")):
            assert path.resolve() in engine_twins, (
                f"{path.relative_to(ROOT)} is a block's C kernel but no engine block's C twin")
