"""Source-only FMUs: compiled when loaded (fmpy's CMake project and the system C compiler), cached
by the FMU's hash, or refused clearly at `twmr check` when this machine cannot compile them."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.fmu_build import SOURCES
from twmr.core import CosimError
from twmr.fmi import fmu_interface

pytestmark = pytest.mark.skipif(not (shutil.which("cmake") and shutil.which("cc")),
                                reason="needs cmake and a C compiler")


def source_only_lag2(out: Path) -> Path:
    """lag2 as its vendor might ship it: modelDescription.xml naming its C file, no binaries."""
    text = (SOURCES / "lag2" / "modelDescription.xml").read_text()
    files = '<SourceFiles><File name="lag2.c"/></SourceFiles>'
    text = text.replace('canGetAndSetFMUstate="true"/>\n  <CoSimulation',
                        f'canGetAndSetFMUstate="true">{files}</ModelExchange>\n  <CoSimulation')
    text = text.replace('canHandleVariableCommunicationStepSize="true" '
                        'canGetAndSetFMUstate="true"/>',
                        f'canHandleVariableCommunicationStepSize="true" '
                        f'canGetAndSetFMUstate="true">{files}</CoSimulation>')
    assert text.count("<SourceFiles>") == 2
    fmu = out / "lag2_sources.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", text)
        z.write(SOURCES / "lag2" / "lag2.c", "sources/lag2.c")
    return fmu


SCENARIO = """
components:
  src: {kind: constant, parameters: {value: 1.5}}
  lag: {kind: fmu, parameters: {path: %s, T: 0.25}}
connections:
  - src.y -> lag.u[1]
  - src.y -> lag.u[2]
experiment: {start: 0.0, stop: 1.0, step: 0.01}
"""


def test_compiled_when_loaded_then_taken_from_the_cache(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    fmu = source_only_lag2(tmp_path)
    info = fmu_interface(fmu)
    assert info["runs_here"] == "after compiling its C sources"
    result = twmr.simulate(twmr.load(SCENARIO % fmu), tmp_path / "out")
    expected = 2.0 * 1.5 * (1.0 - np.exp(-result["time"] / 0.25))
    np.testing.assert_allclose(result["lag.y[1]"], expected, atol=1e-12)
    cached = list((tmp_path / "cache" / "fmus").glob("*.fmu"))
    assert len(cached) == 1
    stamp = cached[0].stat().st_mtime_ns
    twmr.load(SCENARIO % fmu)  # loaded again: not compiled again
    assert cached[0].stat().st_mtime_ns == stamp


def test_without_a_compiler_check_refuses_it_clearly(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO % fmu)
    env = dict(os.environ, TWMR_CACHE_DIR=str(tmp_path / "cache"), CC="no-such-compiler")
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "check", str(scenario)],
                          capture_output=True, text=True, env=env)
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "C sources only" in done.stderr and "no-such-compiler" in done.stderr
    assert "s.yaml" in done.stderr


def test_inspect_json_lists_the_ports(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "inspect", str(fmu), "--json"],
                          capture_output=True, text=True, check=True)
    info = json.loads(done.stdout)
    ports = {p["name"]: p for p in info["ports"]}
    assert ports["u"]["size"] == 2 and ports["u"]["unit"] == "m"
    assert ports["u"]["causality"] == "input" and ports["y"]["causality"] == "output"
    assert ports["T"]["kind"] == "parameter" and ports["T"]["type"] == "Real"


def test_a_broken_source_fails_with_the_compiler_message(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    good = source_only_lag2(tmp_path)
    bad = tmp_path / "broken.fmu"
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(bad, "w") as zout:
        zout.writestr("modelDescription.xml", zin.read("modelDescription.xml"))
        zout.writestr("sources/lag2.c", "this is not C;\n")
    with pytest.raises(CosimError, match="compiling them failed"):
        twmr.load(SCENARIO % bad)
