"""SSP import: systems written by hand after the SSP standard's examples and by OMSimulator,
with our blocks' standalone C FMUs, run to analytic answers (SSP 1.0 and 2.0, .ssp zip and
unpacked folder, nested systems, linear transformations, .ssv bindings, .ssm mappings, units)."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.fmu_build import build_c_fmu
from tests.ssp_build import (
    ENUMERATIONS,
    FIXTURES,
    MAPPINGS,
    fmus,
    linear_ssd,
    package,
    pyssp_package,
    values_ssv,
    zipped,
)
from twmr.cli import main


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return fmus(tmp_path_factory.mktemp("fmus"))


@pytest.fixture(autouse=True)
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("TWMR_CACHE_DIR", str(folder))
    return folder


def rows(source: Path | str, overrides: tuple[str, ...] = ("experiment.step=0.01",)) -> dict:
    df = twmr.simulate(twmr.load(source, list(overrides))).to_pandas()
    return {c: df[c].to_numpy() for c in df.columns}


@pytest.mark.parametrize("version", ["1.0", "2.0"])
@pytest.mark.parametrize("form", ["ssp", "folder"])
def test_linear_transformation_and_ssv_binding_give_the_analytic_ramp(
        built, tmp_path, cache, version, form) -> None:
    """source.value = 2 (.ssv), u = 3 y + 1 on the wire, integ.k = 0.5 (.ssv) inside the nested
    system `sub`: y(t) = k (3 c + 1) t = 3.5 t, which forward Euler integrates exactly."""
    folder = package(tmp_path / "pkg", linear_ssd(version), built, values_ssv(version=version))
    source = zipped(folder, tmp_path / "linear.ssp") if form == "ssp" else folder
    got = rows(source)
    np.testing.assert_allclose(got["sub.integ.y"], 3.5 * got["time"], rtol=0, atol=1e-12)
    assert got["time"][-1] == pytest.approx(2.0)  # DefaultExperiment stopTime
    if form == "ssp":  # unpacked into the cache folder, nowhere else
        assert (next(cache.glob("ssp/*")) / "resources" / "values.ssv").is_file()
        assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "linear.ssp", "pkg"]


def test_units_declared_on_connectors_are_converted(built, tmp_path) -> None:
    """The source's connector is in cm, the integrator's in m (the FMUs declare none). The
    standard converts the units before the linear transformation: u = 3 * (0.01 * 2) + 1 =
    1.06, so y(t) = 0.5 * 1.06 t."""
    folder = package(tmp_path / "pkg", linear_ssd(units=("cm", "m")), built)
    got = rows(folder)
    np.testing.assert_allclose(got["sub.integ.y"], 0.53 * got["time"], rtol=1e-12, atol=1e-15)


def test_a_parameter_of_a_nested_component_is_set_from_outside(built, tmp_path) -> None:
    folder = package(tmp_path / "pkg", linear_ssd(), built)
    got = rows(folder, ("experiment.step=0.01", "sub.integ.k=2"))
    np.testing.assert_allclose(got["sub.integ.y"], 14.0 * got["time"], rtol=0, atol=1e-12)


def test_the_step_comes_from_an_annotation(built, tmp_path) -> None:
    note = ('  <ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:FixedStepMaster '
            'xmlns:oms="urn:oms" stepSize="0.25"/></ssc:Annotation></ssd:Annotations>\n')
    ssd = linear_ssd().replace('stopTime="2"/>',
                               f'stopTime="2">\n{note}  </ssd:DefaultExperiment>')
    folder = package(tmp_path / "pkg", ssd, built)
    scenario = twmr.load(folder)
    assert scenario.system.experiment.step == 0.25
    assert scenario.system.experiment.n_steps == 8


def test_an_omsimulator_file_with_a_parameter_mapping_runs(built, tmp_path) -> None:
    """OMSimulator's LinearTransformation3 system (tests/fixtures/ssp/README.md): the .ssv
    names mapped_Gain_u / mapped_Gain_k, the .ssm maps them to Gain1.u and Gain1.k; Add1.u2 is
    left unconnected (its start value 0). Add1.y = k1 * (k * u) + k2 * 0 = 1 * 2 * 2 = 4."""
    folder = tmp_path / "oms"
    shutil.copytree(FIXTURES / "omsimulator_linear3", folder)
    shutil.copy(built["gain"], folder / "resources" / "Gain.fmu")
    shutil.copy(built["sum"], folder / "resources" / "Add.fmu")
    got = rows(zipped(folder, tmp_path / "oms.ssp"), ())
    assert got["Add1.y"][-1] == 4.0 and got["Gain1.y"][0] == 4.0
    assert got["time"][-1] == pytest.approx(1.0)


def test_an_fmu_beside_the_archive_is_found(built, tmp_path) -> None:
    folder = package(tmp_path / "pkg", linear_ssd(), built, fmus_=("constant",))
    (tmp_path / "beside" / "resources").mkdir(parents=True)
    archive = zipped(folder, tmp_path / "beside" / "x.ssp")
    shutil.copy(built["integrator"], tmp_path / "beside" / "resources" / "integrator.fmu")
    got = rows(archive)
    np.testing.assert_allclose(got["sub.integ.y"], 3.5 * got["time"], rtol=0, atol=1e-12)


def test_cli_check_and_run_an_ssp(built, tmp_path, capsys) -> None:
    archive = zipped(package(tmp_path / "pkg", linear_ssd("2.0"), built), tmp_path / "l.ssp")
    assert main(["check", str(archive)]) == 0
    shown = capsys.readouterr().out
    assert "sub.integ: FmuComponent" in shown and "OK: the scenario is valid." in shown
    assert main(["run", str(archive), "--out", str(tmp_path / "out"), "--quiet",
                 "--set", "experiment.step=0.5"]) == 0
    data = twmr.read_result(tmp_path / "out").to_pandas()
    assert list(data["sub.integ.y"]) == [0.0, 1.75, 3.5, 5.25, 7.0]


def test_cli_inspect_shows_where_each_value_came_from(built, tmp_path, capsys) -> None:
    folder = package(tmp_path / "pkg", linear_ssd(), built)
    assert main(["inspect", str(folder)]) == 0
    shown = capsys.readouterr().out
    assert "sub.integ_u_ssp: transformation (Real -> Real), y = 3 * u + 1" in shown
    assert "k = 0.5  (" in shown and "values.ssv:6" in shown


def test_a_file_written_by_pyssp_standard_runs(built, tmp_path) -> None:
    """acc.y(t) = k * value * t = 4 * 1.5 * t."""
    pytest.importorskip("pyssp_standard", reason="pyssp-standard is in the [test] extra")
    got = rows(pyssp_package(tmp_path / "pyssp", built))
    np.testing.assert_allclose(got["acc.y"], 6.0 * got["time"], rtol=0, atol=1e-12)


def test_integer_and_boolean_mappings_change_the_values_on_the_wire(tmp_path) -> None:
    """mixed2 (tests/fmus/README.md): a.i1o = i1 + 1 = 4 maps to 10, so b.i1o = 11; a.b1o =
    not false = true maps to false, so b.b1o = not false = true (unmapped it would be
    false); a.r1o = 2 * 1.5 goes to b.r1 unconverted, so b.r1o = 6."""
    folder = tmp_path / "maps"
    (folder / "resources").mkdir(parents=True)
    build_c_fmu("mixed2", folder / "resources")
    (folder / "SystemStructure.ssd").write_text(MAPPINGS)
    got = rows(folder, ("experiment.step=0.005",))
    assert list(got["b.i1o"]) == [11, 11, 11]
    assert list(got["b.b1o"]) == [True, True, True]
    assert list(got["b.r1o"]) == [6.0, 6.0, 6.0]


def test_another_ssd_of_the_archive_and_a_nested_ssd_component(built, tmp_path) -> None:
    """`X.ssp#variant.ssd` reads another .ssd of the archive; there a component whose source
    is SystemStructure.ssd is the whole linear system nested as `inner`."""
    folder = package(tmp_path / "pkg", linear_ssd(), built)
    (folder / "variant.ssd").write_text(linear_ssd().split("<ssd:System ")[0] + """\
  <ssd:System name="outer">
    <ssd:Elements>
      <ssd:Component name="inner" type="application/x-ssp-definition"
          source="SystemStructure.ssd"/>
    </ssd:Elements>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="1"/>
</ssd:SystemStructureDescription>
""")
    got = rows(f"{zipped(folder, tmp_path / 'x.ssp')}#variant.ssd")
    np.testing.assert_allclose(got["inner.sub.integ.y"], 3.5 * got["time"], rtol=0,
                               atol=1e-12)
    assert got["time"][-1] == pytest.approx(1.0)


def test_a_system_parameter_reaches_the_component_it_is_connected_to(built, tmp_path) -> None:
    """A parameter connector `gain` of the system `sub`, bound to 0.25 from the top, connected
    (through a linear transformation x 2) to integ.k: y(t) = 0.5 * 7 t."""
    sub_u = '<ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>\n'
    ssd = linear_ssd().replace(
        sub_u, sub_u + '          <ssd:Connector name="gain" kind="parameter"><ssc:Real/>'
        '</ssd:Connector>\n', 1).replace(
        '<ssd:Connection startConnector="u" endElement="integ" endConnector="u"/>',
        '<ssd:Connection startConnector="u" endElement="integ" endConnector="u"/>\n'
        '          <ssd:Connection startConnector="gain" endElement="integ" endConnector="k">'
        '<ssc:LinearTransformation factor="2"/></ssd:Connection>')
    ssv = values_ssv().replace('name="sub.integ.k"', 'name="sub.gain"').replace(
        'value="0.5"', 'value="0.25"')
    got = rows(package(tmp_path / "pkg", ssd, built, ssv))
    np.testing.assert_allclose(got["sub.integ.y"], 3.5 * got["time"], rtol=0, atol=1e-12)


def test_an_ssp_references_file_without_a_default_experiment_runs(tmp_path, caplog) -> None:
    """pyssporg/ssp_references' Stair system with tests/fmus/stair2 as its Stair.fmu:
    counter(t) = floor(t) + 1; no DefaultExperiment, so the stop is given with --set."""
    folder = tmp_path / "stair"
    shutil.copytree(FIXTURES / "ssp_references_stair", folder)
    (folder / "resources").mkdir()
    build_c_fmu("stair2", folder / "resources").rename(folder / "resources" / "Stair.fmu")
    got = rows(zipped(folder, tmp_path / "stair.ssp"), ("experiment.stop=3",
                                                        "experiment.step=0.5"))
    assert list(got["fmu.counter"]) == [1, 1, 2, 2, 3, 3, 4]
    assert "no stopTime" in caplog.text


def test_an_enumeration_mapping_uses_the_fmus_item_names(tmp_path) -> None:
    """types3 (FMI 3.0, tests/fmus/README.md): Enumeration_output = Enumeration_input, type
    Level (low 1, medium 2, high 3), start 2. a gives medium, mapped to high: b's output 3."""
    folder = tmp_path / "enums"
    (folder / "resources").mkdir(parents=True)
    build_c_fmu("types3", folder / "resources", fmi3=True)
    (folder / "SystemStructure.ssd").write_text(ENUMERATIONS)
    got = rows(folder, ("experiment.step=0.005",))
    assert list(got["a.Enumeration_output"]) == [2, 2, 2]
    assert list(got["b.Enumeration_output"]) == [3, 3, 3]


def test_inline_values_a_prefix_and_an_inline_mapping(built, tmp_path) -> None:
    """The integrator's own binding holds an inline parameter set (gain = 0.5, mapped to k by
    an inline ssm); the top's binding has prefix 'source.' over a set naming 'value' = 2.
    y(t) = 0.5 (3 * 2 + 1) t."""
    inline = """
            <ssd:ParameterBindings>
              <ssd:ParameterBinding>
                <ssd:ParameterValues>
                  <ssv:ParameterSet version="1.0" name="own"><ssv:Parameters>
                    <ssv:Parameter name="gain"><ssv:Real value="0.5"/></ssv:Parameter>
                  </ssv:Parameters></ssv:ParameterSet>
                </ssd:ParameterValues>
                <ssd:ParameterMapping>
                  <ssm:ParameterMapping version="1.0">
                    <ssm:MappingEntry source="gain" target="k"/>
                  </ssm:ParameterMapping>
                </ssd:ParameterMapping>
              </ssd:ParameterBinding>
            </ssd:ParameterBindings>"""
    ssd = linear_ssd().replace(
        'xmlns:ssv=', 'xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"'
        ' xmlns:ssv=', 1).replace(
        '<ssd:ParameterBinding source="resources/values.ssv"/>',
        '<ssd:ParameterBinding source="resources/values.ssv" prefix="source."/>').replace(
        '<ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector>\n'
        '            </ssd:Connectors>',
        '<ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector>\n'
        f'            </ssd:Connectors>{inline}')
    assert "prefix" in ssd and "ssm:MappingEntry" in ssd
    ssv = values_ssv().replace('name="source.value"', 'name="value"').replace(
        '<ssv:Parameter name="sub.integ.k"><ssv:Real value="0.5"/></ssv:Parameter>', "")
    got = rows(package(tmp_path / "pkg", ssd, built, ssv))
    np.testing.assert_allclose(got["sub.integ.y"], 3.5 * got["time"], rtol=0, atol=1e-12)


def test_a_linear_transformation_runs_in_the_compiled_loop(built, tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("TWMR_COMPILED", "on")
    folder = package(tmp_path / "pkg", linear_ssd(), built)
    result = twmr.simulate(twmr.load(folder, ["experiment.step=0.01"]))
    assert result.summary["pacing"]["algorithm.compiled"] is True
    df = result.to_pandas()
    np.testing.assert_allclose(df["sub.integ.y"], 3.5 * df["time"], rtol=0, atol=1e-12)
