"""Units from the FMU's own UnitDefinitions (BaseUnit exponents, factor, offset): conversions
between FMUs, the same unknown unit at both ends, unknown to known refused, unitless to united
warned about at check."""
from __future__ import annotations

import logging
import re
import zipfile
from pathlib import Path

import pytest

from tests.fmu_build import build_c_fmu
from twmr.core import ScenarioError
from twmr.master import simulate
from twmr.scenario import loads


def variant(fmu: Path, out: Path, **units: str) -> Path:
    """A copy of `fmu` whose variables named in `units` declare another unit (the binary does
    not use units, so it computes the same)."""
    with zipfile.ZipFile(fmu) as zin:
        text = zin.read("modelDescription.xml").decode()
        for var, unit in units.items():
            text, n = re.subn(rf'(name="{var}".*?<Real[^>]*?unit=")[^"]*(")', rf"\g<1>{unit}\2",
                              text, count=1, flags=re.S)
            assert n == 1
        with zipfile.ZipFile(out, "w") as zout:
            for item in zin.namelist():
                data = text if item == "modelDescription.xml" else zin.read(item)
                zout.writestr(item, data)
    return out


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("units")
    base = build_c_fmu("units2", d)
    return {"F": base,
            "C": variant(base, d / "celsius.fmu", temp_in="degC", temp_out="degC",
                         len_in="mm", len_out="mm"),
            "W": variant(base, d / "widget.fmu", temp_in="widget", len_in="widget")}


def scenario(a: Path, b: Path, wires: list[str], stop: float = 0.2) -> str:
    conns = "\n".join(f"  - {w}" for w in wires)
    return f"""
components:
  a: {{kind: fmu, parameters: {{path: {a}}}}}
  b: {{kind: fmu, parameters: {{path: {b}}}}}
connections:
{conns}
open: [a.temp_in, a.len_in, b.temp_in, b.len_in]
experiment: {{start: 0.0, stop: {stop}, step: 0.1}}
"""


def test_offset_and_factor_units_are_converted(fmus) -> None:
    """212 degF (the FMU's factor 5/9 and offset) is 100 degC; 1 ft (myLen, factor 0.3048) is
    304.8 mm."""
    text = scenario(fmus["F"], fmus["C"], ["a.temp_out -> b.temp_in", "a.len_out -> b.len_in"])
    text = text.replace("open: [a.temp_in, a.len_in, b.temp_in, b.len_in]",
                        "open: [a.temp_in, a.len_in]")
    r = simulate(loads(text, source="units.yaml"))
    assert r["b.temp_out"][-1] == pytest.approx(100.0, abs=1e-9)
    assert r["b.len_out"][-1] == pytest.approx(304.8, abs=1e-9)


def test_the_same_unit_unknown_to_us_connects_as_is(fmus) -> None:
    text = scenario(fmus["F"], fmus["F"], ["a.temp_out -> b.temp_in"])
    text = text.replace("b.temp_in, ", "")
    r = simulate(loads(text, source="units.yaml"))
    assert r["b.temp_out"][-1] == 212.0
    text = scenario(fmus["W"], fmus["W"], ["a.w -> b.len_in"])  # 'widget' has no BaseUnit
    text = text.replace("b.len_in]", "]")
    r = simulate(loads(text, source="units.yaml"))
    assert r["b.len_out"][-1] == 1.0


def test_unknown_to_known_unit_is_refused_naming_both(fmus) -> None:
    text = scenario(fmus["F"], fmus["W"], ["a.temp_out -> b.temp_in"]).replace("b.temp_in, ", "")
    with pytest.raises(ScenarioError) as err:
        loads(text, source="units.yaml")
    msg = str(err.value)
    assert "units.yaml:" in msg and "'degF'" in msg and "'widget'" in msg
    assert "b.temp_in" in msg and "BaseUnit" in msg
    assert "not connected" not in msg  # the refused wire's input is not reported twice


def test_unitless_to_united_is_warned_about_at_check(fmus, caplog) -> None:
    text = scenario(fmus["F"], fmus["C"], ["a.plain -> b.len_in"]).replace("b.len_in]", "]")
    with caplog.at_level(logging.WARNING, logger="twmr"):
        loads(text, source="units.yaml")
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("'a.plain' declares no unit" in m and "'mm'" in m for m in warned)
