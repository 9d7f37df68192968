"""A scenario format from another package, registered as installed packages register one: an
entry point `toml = toml_scenario:load` in the group `twmr.loaders` of a distribution on the
import path (a dist-info folder written here, the module beside it). One registration reaches
every way a scenario is read: `twmr.load`, `twmr.scenario.load`, and `twmr check` / `twmr run`
in a fresh process."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import twmr
from twmr import registry
from twmr.scenario import load as load_system

MODULE = '''
import tomllib
from pathlib import Path

from twmr.scenario.loaders import read_structure


def load(path: Path):
    """A scenario written in TOML, in the shape of the YAML one."""
    data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    return read_structure(data, str(path), Path(path).resolve().parent)
'''
SCENARIO = '''
connections = ["src.y -> g.u"]

[components.src]
kind = "constant"
parameters = {value = 2.0}

[components.g]
kind = "gain"
parameters = {k = 3.0}

[experiment]
start = 0.0
stop = 0.05
step = 0.01
'''


@pytest.fixture
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The package `toml-scenario` on the import path (this process and its children), with a
    cache of entry points of its own."""
    pytest.importorskip("tomllib")
    site = tmp_path / "site"
    (site / "toml_scenario-1.0.dist-info").mkdir(parents=True)
    (site / "toml_scenario-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: toml-scenario\nVersion: 1.0\n")
    (site / "toml_scenario-1.0.dist-info" / "entry_points.txt").write_text(
        "[twmr.loaders]\ntoml = toml_scenario:load\n")
    (site / "toml_scenario.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(site), os.environ.get("PYTHONPATH",
                                                                                  "")]))
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    registry._group.cache_clear()
    registry._all_groups.cache_clear()
    yield tmp_path
    registry._group.cache_clear()
    registry._all_groups.cache_clear()


def scenario(folder: Path) -> Path:
    path = folder / "model.toml"
    path.write_text(SCENARIO)
    return path


def test_the_registered_format_reaches_every_reader(installed: Path) -> None:
    path = scenario(installed)
    assert "toml" in registry.plugins(registry.LOADERS)
    s = twmr.load(path)
    assert set(s.system.components) == {"src", "g"}
    assert twmr.simulate(s)["g.y"][-1] == 6.0
    assert set(load_system(path, ["g.k=4"]).components) == {"src", "g"}
    for command in (["check", str(path)], ["run", str(path), "--out", str(installed / "out"),
                                          "-q"]):
        done = subprocess.run([sys.executable, "-m", "twmr.cli", *command], cwd=installed,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
    assert (installed / "out" / "summary.json").is_file()


def test_a_file_no_loader_claims_is_read_as_yaml(installed: Path) -> None:
    """The fallback stays: an unknown suffix is YAML (and said so when it is not)."""
    path = installed / "model.txt"
    path.write_text("components:\n  g: {kind: gain}\nopen: [g.u]\n"
                    "experiment: {stop: 0.02, step: 0.01}\n")
    assert set(twmr.load(path).system.components) == {"g"}
