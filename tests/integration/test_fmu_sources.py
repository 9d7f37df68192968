"""Source-only FMUs: built only when asked (`compile: true` on the component, or
`twmr fmu build`), with the system C compiler called directly, once per process; refused
clearly at `twmr check` when this machine cannot compile them or the build fails."""
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

pytestmark = pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")


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


def test_compile_true_builds_it_once_per_process(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    info = fmu_interface(fmu)
    assert info["runs_here"] == "once built from its C sources (compile: true, or twmr fmu build)"
    opted = (SCENARIO % fmu).replace("T: 0.25", "T: 0.25, compile: true")
    scenario = twmr.load(opted)
    result = twmr.simulate(scenario, tmp_path / "out")
    expected = 2.0 * 1.5 * (1.0 - np.exp(-result["time"] / 0.25))
    np.testing.assert_allclose(result["lag.y[1]"], expected, atol=1e-12)
    built = scenario.system.components["lag"].path
    assert built != fmu and built.name == fmu.name
    assert "binaries/linux64/lag2.so" in zipfile.ZipFile(built).namelist()
    stamp = built.stat().st_mtime_ns
    assert twmr.load(opted).system.components["lag"].path == built  # not built again
    assert built.stat().st_mtime_ns == stamp


def test_without_a_compiler_check_refuses_it_clearly(tmp_path) -> None:
    fmu = source_only_lag2(tmp_path)
    scenario = tmp_path / "s.yaml"
    scenario.write_text((SCENARIO % fmu).replace("T: 0.25", "T: 0.25, compile: true"))
    env = dict(os.environ, CC="no-such-compiler")
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


def test_a_broken_source_fails_with_the_compiler_message(tmp_path) -> None:
    good = source_only_lag2(tmp_path)
    bad = tmp_path / "broken.fmu"
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(bad, "w") as zout:
        zout.writestr("modelDescription.xml", zin.read("modelDescription.xml"))
        zout.writestr("sources/lag2.c", "this is not C;\n")
    with pytest.raises(CosimError, match=r"building it failed: cc exited with status 1\. Its "
                       r"last output: .*lag2\.c:1:.*error"):
        twmr.load((SCENARIO % bad).replace("T: 0.25", "T: 0.25, compile: true"))
