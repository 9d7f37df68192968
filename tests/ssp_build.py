"""SSP packages for the tests: standalone C FMUs of our blocks (built at test time) and a small
system written by hand after the examples of the SSP standard, as a folder or an .ssp zip."""
from __future__ import annotations

import zipfile
from pathlib import Path

from twmr.fmi.cexport import export_c_fmu

FIXTURES = Path(__file__).parent / "fixtures" / "ssp"
HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssd:SystemStructureDescription '
        'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
        'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
        'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
        'name="linear" version="{version}">\n')


def fmus(folder: Path) -> dict[str, Path]:
    """constant, gain, sum and integrator as FMI 2.0 C FMUs in `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    return {k: export_c_fmu(k, folder / f"{k}.fmu") for k in ("constant", "gain", "sum",
                                                              "integrator")}


def linear_ssd(version: str = "1.0", factor: float = 3.0, offset: float = 1.0,
               units: tuple[str, str] = ("", ""), extra: str = "") -> str:
    """A constant source -> linear transformation -> integrator inside the nested system `sub`;
    parameters from resources/values.ssv (source.value, sub.integ.k)."""
    su = f' unit="{units[0]}"' if units[0] else ""
    du = f' unit="{units[1]}"' if units[1] else ""
    return HEAD.format(version=version) + f"""\
  <ssd:System name="top">
    <ssd:ParameterBindings>
      <ssd:ParameterBinding source="resources/values.ssv"/>
    </ssd:ParameterBindings>
    <ssd:Elements>
      <ssd:Component name="source" source="resources/constant.fmu">
        <ssd:Connectors>
          <ssd:Connector name="y" kind="output"><ssc:Real{su}/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
      <ssd:System name="sub">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
        <ssd:Elements>
          <ssd:Component name="integ" source="resources/integrator.fmu">
            <ssd:Connectors>
              <ssd:Connector name="u" kind="input"><ssc:Real{du}/></ssd:Connector>
              <ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector>
            </ssd:Connectors>
          </ssd:Component>
        </ssd:Elements>
        <ssd:Connections>
          <ssd:Connection startConnector="u" endElement="integ" endConnector="u"/>
          <ssd:Connection startElement="integ" startConnector="y" endConnector="y"/>
        </ssd:Connections>
      </ssd:System>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="source" startConnector="y" endElement="sub" endConnector="u">
        <ssc:LinearTransformation factor="{factor}" offset="{offset}"/>
      </ssd:Connection>
    </ssd:Connections>
  </ssd:System>
{extra}  <ssd:DefaultExperiment startTime="0" stopTime="2"/>
</ssd:SystemStructureDescription>
"""


def values_ssv(value: str = '<ssv:Real value="2"/>', k: str = '<ssv:Real value="0.5"/>',
               version: str = "1.0") -> str:
    """The parameter set of `linear_ssd`: source.value and sub.integ.k."""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    version="{version}" name="values">
  <ssv:Parameters>
    <ssv:Parameter name="source.value">{value}</ssv:Parameter>
    <ssv:Parameter name="sub.integ.k">{k}</ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"""


def package(folder: Path, ssd: str, built: dict[str, Path], ssv: str | None = None,
            fmus_: tuple[str, ...] = ("constant", "integrator")) -> Path:
    """An unpacked SSP in `folder`: SystemStructure.ssd, resources/ with the FMUs and the .ssv."""
    (folder / "resources").mkdir(parents=True, exist_ok=True)
    (folder / "SystemStructure.ssd").write_text(ssd)
    for name in fmus_:
        (folder / "resources" / f"{name}.fmu").write_bytes(built[name].read_bytes())
    (folder / "resources" / "values.ssv").write_text(ssv if ssv is not None else values_ssv())
    return folder


def zipped(folder: Path, archive: Path) -> Path:
    """The folder's files as the .ssp zip `archive`."""
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(folder).as_posix())
    return archive


def pyssp_package(folder: Path, built: dict[str, Path]) -> Path:
    """src (constant) -> amp (gain) -> acc (integrator), src.value = 1.5 and amp.k = 4 in an
    .ssv, written with the pyssp-standard package (PyPI), FMUs in resources/."""
    from pyssp_standard.common_content_ssc import TypeReal
    from pyssp_standard.ssd import (
        SSD,
        Component,
        Connection,
        Connector,
        DefaultExperiment,
        ParameterBinding,
        System,
    )
    from pyssp_standard.ssv import SSV

    (folder / "resources").mkdir(parents=True, exist_ok=True)
    for name in ("constant", "gain", "integrator"):
        (folder / "resources" / f"{name}.fmu").write_bytes(built[name].read_bytes())

    def component(name: str, fmu: str, connectors: list[tuple[str, str]]) -> Component:
        c = Component()
        c.name, c.source = name, f"resources/{fmu}.fmu"
        c.component_type, c.implementation = "application/x-fmu-sharedlibrary", "CoSimulation"
        c.connectors = [Connector(name=n, kind=k, type_=TypeReal(None)) for n, k in connectors]
        return c

    with SSV(folder / "resources" / "params.ssv", "w") as ssv:
        ssv.add_parameter("src.value", "Real", value=1.5, unit="1")
        ssv.add_parameter("amp.k", "Real", value=4.0, unit="1")
    with SSD(folder / "SystemStructure.ssd", "w") as ssd:
        ssd.name, ssd.version = "pyssp", "1.0"
        system = System(name="top")
        system.elements = [
            component("src", "constant", [("y", "output"), ("value", "parameter")]),
            component("amp", "gain", [("u", "input"), ("y", "output"), ("k", "parameter")]),
            component("acc", "integrator", [("u", "input"), ("y", "output")])]
        system.connections = [
            Connection(start_element="src", start_connector="y", end_element="amp",
                       end_connector="u"),
            Connection(start_element="amp", start_connector="y", end_element="acc",
                       end_connector="u")]
        system.parameter_bindings = [ParameterBinding(source="resources/params.ssv")]
        ssd.system = system
        experiment = DefaultExperiment()
        experiment.start_time, experiment.stop_time = 0.0, 1.0
        ssd.default_experiment = experiment
    return folder


MAPPINGS = HEAD.format(version="2.0") + """\
  <ssd:System name="top">
    <ssd:Elements>
      <ssd:Component name="a" source="resources/mixed2.fmu"/>
      <ssd:Component name="b" source="resources/mixed2.fmu"/>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="a" startConnector="i1o" endElement="b" endConnector="i1">
        <ssc:IntegerMappingTransformation>
          <ssc:MapEntry source="4" target="10"/>
        </ssc:IntegerMappingTransformation>
      </ssd:Connection>
      <ssd:Connection startElement="a" startConnector="b1o" endElement="b" endConnector="b1">
        <ssc:BooleanMappingTransformation>
          <ssc:MapEntry source="true" target="false"/>
          <ssc:MapEntry source="false" target="true"/>
        </ssc:BooleanMappingTransformation>
      </ssd:Connection>
      <ssd:Connection startElement="a" startConnector="r1o" endElement="b" endConnector="r1"
          suppressUnitConversion="true"/>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="0.01"/>
</ssd:SystemStructureDescription>
"""


ENUMERATIONS = HEAD.format(version="2.0") + """\
  <ssd:System name="top">
    <ssd:Elements>
      <ssd:Component name="a" source="resources/types3.fmu"/>
      <ssd:Component name="b" source="resources/types3.fmu"/>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="a" startConnector="Enumeration_output" endElement="b"
          endConnector="Enumeration_input">
        <ssc:EnumerationMappingTransformation>
          <ssc:MapEntry source="medium" target="high"/>
        </ssc:EnumerationMappingTransformation>
      </ssd:Connection>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="0.01"/>
</ssd:SystemStructureDescription>
"""
