"""docs/tutorial.md, run as written: every `file=` block written into an empty folder and every
`sh` block's commands run there in order (the `sh setup` block, installing, is not), each
expected to succeed."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(600)

DOC = Path(__file__).resolve().parents[2] / "docs" / "tutorial.md"


def steps() -> list[tuple[str, str, str]]:
    """('file', name, text) and ('sh', command, '') in the order of the tutorial."""
    out: list[tuple[str, str, str]] = []
    for info, body in re.findall(r"```([^\n]*)\n(.*?)```", DOC.read_text(), re.S):
        named = re.search(r"file=(\S+)", info)
        if named:
            out.append(("file", named.group(1), body))
        elif info.strip() == "sh":
            out += [("sh", line, "") for line in body.splitlines() if line.strip()]
    return out


def test_the_tutorial_runs_as_written(tmp_path: Path) -> None:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}"
           f"{os.environ.get('PATH', '')}", "MPLBACKEND": "Agg"}
    ran = []
    for kind, what, text in steps():
        if kind == "file":
            (tmp_path / what).write_text(text)
            continue
        done = subprocess.run(["bash", "-c", what], cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=400)
        assert done.returncode == 0, f"`{what}` failed:\n{done.stderr[-3000:]}"
        assert "Traceback" not in done.stderr, what
        ran.append(what.split()[0:2])
    assert ["twmr", "tune"] in ran and ["twmr", "verify"] in ran and len(ran) >= 12
    assert (tmp_path / "results" / "robot" / "plots").is_dir()
    assert (tmp_path / "sweeps" / "robot" / "report").is_dir()
    assert (tmp_path / "compare" / "xy.png").is_file()
