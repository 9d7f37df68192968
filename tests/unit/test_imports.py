"""The engine stays light and robot-free: `import twmr.master` loads no YAML or JSON Schema, a
1-step run loads none of the heavy libraries it does not use, and the engine never imports the
robot's or the CAN package."""
from __future__ import annotations

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


def test_a_one_step_run_loads_only_what_it_uses(tmp_path) -> None:
    scenario = tmp_path / "one.yaml"
    scenario.write_text("components:\n  s: {kind: sine}\n  g: {kind: gain}\n"
                        "connections: [s.y -> g.u]\nexperiment: {stop: 0.001, step: 0.001}\n")
    loaded = modules_after(f"from twmr.cli import main\nmain(['run', {str(scenario)!r}, '--out', "
                           f"{str(tmp_path / 'out')!r}, '-q', '--format', 'csv'])")
    assert "pyarrow" in loaded and not set(HEAVY) & loaded


def test_engine_sources_never_import_the_robot_or_can_packages() -> None:
    import re

    banned = re.compile(r"^\s*(from|import)\s+(twmr\.components|twmr\.hw|can|canopen|cantools)\b",
                        re.MULTILINE)
    for path in (ROOT / "src" / "twmr").rglob("*.py"):
        found = banned.search(path.read_text())
        assert found is None, f"{path.relative_to(ROOT)}: {found.group(0)}"
