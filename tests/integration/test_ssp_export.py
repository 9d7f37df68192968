"""`twmr export SCENARIO.yaml --out X.ssp`: the archive validates against the standard's XML
schemas (SSP 1.0, and 2.0 with --ssp 2; the copies pyssp-standard ships of the Modelica
Association's XSDs), holds one FMU per block (fmpy validates each), its parameters and
experiment; a unit conversion becomes a linear transformation that Ecos applies to the analytic
answer; blocks that cannot be exported are refused in one paragraph naming them, and nothing is
written; --python exports a block without a C twin through pythonfmu."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from lxml import etree

from tests.fmu_build import build_c_fmu
from tests.integration import ssp_runners as r
from tests.integration.test_fmu_units import variant
from twmr.cli import main
from twmr.core.errors import CosimError
from twmr.fmi.ssp.write import SSC, SSD, TWMR, export_ssp

PAPER = r.ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
NS = {"ssd": SSD, "ssc": SSC, "twmr": TWMR}


def _schemas(ssp: int) -> Path:
    pyssp = pytest.importorskip("pyssp_standard")
    folder = Path(pyssp.__file__).parent / "resources"
    return folder if ssp == 1 else folder / "ssp2"


def _validate(archive: Path, ssp: int) -> etree._Element:
    """Every .ssd and .ssv of `archive` against the standard's schema; the parsed .ssd."""
    folder = _schemas(ssp)
    kinds = {".ssd": "SystemStructureDescription.xsd", ".ssv": "SystemStructureParameterValues.xsd"}
    schemas = {k: etree.XMLSchema(etree.parse(str(folder / v))) for k, v in kinds.items()}
    with zipfile.ZipFile(archive) as z:
        for name in z.namelist():
            suffix = Path(name).suffix
            if suffix in schemas:
                doc = etree.fromstring(z.read(name))
                assert schemas[suffix].validate(doc), (name, schemas[suffix].error_log)
        return etree.fromstring(z.read("SystemStructure.ssd"))


def test_cli_exports_the_paper_scenario_as_valid_ssp_1(tmp_path, capsys) -> None:
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    out = tmp_path / "paper.ssp"
    assert main(["export", str(PAPER), "--out", str(out), "--set", "experiment.stop=2"]) == 0
    assert capsys.readouterr().out.strip() == str(out.resolve())
    ssd = _validate(out, 1)
    assert ssd.get("version") == "1.0"
    comps = ssd.findall("ssd:System/ssd:Elements/ssd:Component", NS)
    assert [c.get("name") for c in comps] == ["ref", "ctrl", "motor", "plant", "slip"]
    with zipfile.ZipFile(out) as z:
        for c in comps:
            fmu = tmp_path / f"{c.get('name')}.fmu"
            fmu.write_bytes(z.read(c.get("source")))
            assert validate_fmu(str(fmu)) == []
            md = read_model_description(str(fmu))
            assert md.fmiVersion == "2.0" and md.coSimulation is not None
            names = {v.name for v in md.modelVariables}
            assert {k.get("name") for k in c.findall("ssd:Connectors/ssd:Connector", NS)} <= names
        plant = etree.fromstring(z.read("resources/plant.ssv"))
    ssv = {"ssv": plant.nsmap["ssv"]}
    values = {p.get("name"): float(p[0].get("value")) for p in plant.iterfind(".//ssv:Parameter",
                                                                              ssv)}
    assert values["scale"] == 1.25 and values["pose[3]"] == -0.7853981633974483
    exp = ssd.find("ssd:DefaultExperiment", NS)
    assert (float(exp.get("startTime")), float(exp.get("stopTime"))) == (0.0, 2.0)
    ours = exp.find("ssd:Annotations/ssc:Annotation[@type='org.twmr-cosim']/twmr:Experiment", NS)
    assert float(ours.get("step")) == 1e-3 and ours.get("algorithm") == "gauss_seidel"
    record = ours.find("twmr:Record", NS)
    assert record.get("decimation") == "10"
    assert ("plant", "pose") in [(s.get("element"), s.get("port")) for s in record]
    wires = ssd.findall("ssd:System/ssd:Connections/ssd:Connection", NS)
    assert len(wires) == 41 and all(len(w) == 0 for w in wires)  # same units: no transformation


def test_ssp_2_with_fmi_3_fmus_validates(tmp_path) -> None:
    from fmpy import read_model_description

    out = export_ssp(PAPER, tmp_path / "paper.ssp", ["experiment.stop=1"], fmi=3, ssp=2)
    ssd = _validate(out, 2)
    assert ssd.get("version") == "2.0"
    assert ssd.find(".//ssd:Connector/ssc:Float64", NS) is not None
    with zipfile.ZipFile(out) as z:
        (tmp_path / "plant.fmu").write_bytes(z.read("resources/plant.fmu"))
    assert read_model_description(str(tmp_path / "plant.fmu")).fmiVersion == "3.0"


@pytest.fixture(scope="module")
def units_ssp(tmp_path_factory) -> tuple[Path, Path]:
    """Two FMUs of tests/fmus/units2: a in degF and ft, b in degC and mm, wired; exported."""
    d = tmp_path_factory.mktemp("units")
    a = build_c_fmu("units2", d)
    b = variant(a, d / "celsius.fmu", temp_in="degC", temp_out="degC", len_in="mm",
                len_out="mm")
    scenario = d / "units.yaml"
    scenario.write_text(f"""
components:
  a: {{kind: fmu, parameters: {{path: {a}}}}}
  b: {{kind: fmu, parameters: {{path: {b}}}}}
connections:
  - a.temp_out -> b.temp_in
  - a.len_out -> b.len_in
open: [a.temp_in, a.len_in]
experiment: {{start: 0.0, stop: 0.5, step: 0.1, algorithm: jacobi}}
""")
    return scenario, export_ssp(scenario, d / "units.ssp")


def test_unit_conversions_become_linear_transformations(units_ssp) -> None:
    """degF -> degC: factor 5/9, offset -160/9; ft -> mm: factor 304.8; the tool's own unit
    conversion suppressed, so a unit-aware tool does not convert twice."""
    ssd = _validate(units_ssp[1], 1)
    wires = {w.get("endConnector"): w for w in ssd.iterfind(".//ssd:Connection", NS)}
    temp, length = wires["temp_in"], wires["len_in"]
    for w in (temp, length):
        assert w.get("suppressUnitConversion") == "true"
    t = temp.find("ssc:LinearTransformation", NS)
    assert float(t.get("factor")) == pytest.approx(5 / 9, rel=1e-15)
    assert float(t.get("offset")) == pytest.approx(-160 / 9, rel=1e-15)
    assert float(length.find("ssc:LinearTransformation", NS).get("factor")) == \
        pytest.approx(304.8, rel=1e-15)
    assert {u.get("name") for u in ssd.iterfind("ssd:Units/ssc:Unit", NS)} >= {"degC", "mm"}


def test_ecos_applies_the_transformations_to_the_analytic_answer(units_ssp) -> None:
    """212 degF is 100 degC; 1 ft is 304.8 mm (the FMUs copy input to output)."""
    try:
        import ecospy  # noqa: F401
    except OSError as err:
        pytest.skip(f"ecospy's library cannot be loaded here ({err}): apt-get install libtbb12")
    rows = r.ecos(units_ssp[1], ["b.temp_out", "b.len_out"], 0.1, 5, "units")
    assert rows[-1, 0] == pytest.approx(100.0, abs=1e-9)
    assert rows[-1, 1] == pytest.approx(304.8, abs=1e-9)


def test_blocks_that_cannot_be_exported_are_refused_by_name(tmp_path) -> None:
    cases = [
        (r.ROOT / "scenarios" / "bench_odrive_trajectory1.yaml", [],
         ["'motor' (kind can_drive)", "hardware", "motor_driver"]),
        (r.ROOT / "scenarios" / "examples" / "noisy_sensor.yaml", [],
         ["'sensor' (kind my_block.py:NoisySensor)", "no C twin", "--python"]),
        (PAPER, ["slip.profile=random"], ["'slip' (kind slip_disturbance)", "'random'",
                                          "--python"]),
    ]
    for scenario, overrides, words in cases:
        out = tmp_path / "x.ssp"
        with pytest.raises(CosimError) as err:
            export_ssp(scenario, out, overrides)
        text = str(err.value)
        assert str(scenario) in text and "Fix:" in text and "\n" not in text
        for word in words:
            assert word in text
        assert not list(tmp_path.iterdir())  # nothing written
    with pytest.raises(CosimError, match=r"does not end in \.ssp"):
        export_ssp(PAPER, tmp_path / "x.zip")


def test_python_route_exports_a_block_without_a_c_twin(tmp_path) -> None:
    from fmpy import read_model_description

    out = export_ssp(r.ROOT / "scenarios" / "examples" / "noisy_sensor.yaml",
                     tmp_path / "noisy.ssp", python=True)
    ssd = _validate(out, 1)
    sensor = ssd.find(".//ssd:Component[@name='sensor']", NS)
    assert "Python route" in sensor.get("description")
    with zipfile.ZipFile(out) as z:
        (tmp_path / "sensor.fmu").write_bytes(z.read("resources/sensor.fmu"))
    md = read_model_description(str(tmp_path / "sensor.fmu"))
    assert "Python route" in md.generationTool
    ctrl = ssd.find(".//ssd:Component[@name='ctrl']", NS)
    assert ctrl.get("description") == "C FMU, FMI 2.0"  # the others stay C FMUs


def test_ssp_option_on_a_kind_is_refused(capsys) -> None:
    assert main(["export", "gain", "--ssp", "2"]) == 1
    err = capsys.readouterr().err
    assert "--ssp applies to a scenario" in err and "Fix:" in err
