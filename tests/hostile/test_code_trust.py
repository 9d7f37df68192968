"""The trust model for code in scenarios (docs/security.md): inspecting imports no user block
unless --trust-code; a run imports files only from the scenario's folder tree and no module
but twmr's unless TWMR_ALLOW_CODE allows it; an exit() at a block file's top level is a
reported failure, not a silent end."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import twmr
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(120)

BLOCK = """
from pathlib import Path
from twmr.core import Component, Input, Output
Path(__file__).with_suffix(".ran").write_text("imported")
class C(Component):
    u = Input(0.0)
    y = Output(0.0)
"""


def _scenario(folder: Path, kind: str) -> Path:
    path = folder / "s.yaml"
    path.write_text(f'components:\n  c: {{kind: "{kind}"}}\nopen: [c.u]\n'
                    f"experiment: {{stop: 0.02, step: 0.01}}\n")
    return path


def _twmr(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "twmr.cli", *args], capture_output=True,
                          text=True, timeout=100, env=env)


def test_check_imports_no_user_block_unless_trusted(tmp_path: Path) -> None:
    (tmp_path / "blk.py").write_text(BLOCK)
    scenario = _scenario(tmp_path, "blk.py:C")
    done = _twmr("check", str(scenario))
    assert done.returncode != 0 and "--trust-code" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "blk.ran").exists()
    done = _twmr("check", "--trust-code", str(scenario))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "blk.ran").exists()


@pytest.mark.parametrize("where", ["outside", "dotdot"])
def test_a_run_refuses_a_file_outside_the_scenario_folder(tmp_path: Path, where: str,
                                                           monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    folder = tmp_path / "scenario"
    folder.mkdir()
    (tmp_path / "evil.py").write_text(BLOCK)
    kind = f"{tmp_path / 'evil.py'}:C" if where == "outside" else "../evil.py:C"
    with pytest.raises(ScenarioError, match="outside the scenario's folder") as info:
        twmr.load(_scenario(folder, kind))
    assert "TWMR_ALLOW_CODE=" in str(info.value)
    assert not (tmp_path / "evil.ran").exists()
    monkeypatch.setenv("TWMR_ALLOW_CODE", str(tmp_path))
    twmr.load(_scenario(folder, kind))
    assert (tmp_path / "evil.ran").exists()


def test_a_module_kind_is_refused_unless_allowed(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="imports the module 'this'"):
        twmr.load(_scenario(tmp_path, "this:s"))


def test_exit_at_a_block_files_top_level_is_a_reported_failure(tmp_path: Path) -> None:
    (tmp_path / "quits.py").write_text("import sys\nsys.exit(0)\n")
    with pytest.raises(ScenarioError, match=r"quits.py:2: the code called exit \(0\)"):
        twmr.load(_scenario(tmp_path, "quits.py:C"))


def test_exit_in_a_blocks_step_ends_the_run_with_a_message_and_rows_kept(tmp_path: Path
                                                                         ) -> None:
    (tmp_path / "q.py").write_text(
        "import sys\nfrom twmr.core import Component, Input, Output\n"
        "class Q(Component):\n    u = Input(0.0)\n    y = Output(0.0)\n"
        "    def do_step(self, t, h):\n        if t > 0.05:\n            sys.exit(0)\n")
    scenario = tmp_path / "q.yaml"
    scenario.write_text('components:\n  q: {kind: "q.py:Q"}\nopen: [q.u]\n'
                        "experiment: {stop: 0.1, step: 0.01}\n")
    done = _twmr("run", str(scenario), "--out", str(tmp_path / "r"))
    assert done.returncode != 0
    assert "component 'q' at t = 0.06 s: do_step() called exit (0)" in done.stderr
    rows = twmr.read_result(tmp_path / "r.incomplete").to_pandas()
    assert rows["time"].iloc[-1] >= 0.05
