"""Hostile SSP files through `twmr check X.ssp`: malformed XML, XXE and entity bombs, zip-slip
and link members, zip bombs, a missing FMU, connectors and elements that do not exist, units
that cannot be converted, .ssv values of the wrong type, SSP features twmr does not run. Each is
refused in one paragraph naming the file, line and element, with a fix; nothing is written
outside the cache folder the package is unpacked into."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

import twmr
from tests.hostile.runner import (
    assert_clean_error,
    assert_ok,
    assert_writes_only_under,
    result_family,
    run_cli,
)
from tests.ssp_build import fmus, linear_ssd, package, values_ssv, zipped
from twmr.core.errors import ScenarioError
from twmr.fmi.ssp import archive

XXE = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
       '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/'
       'SystemStructureDescription" name="x" version="1.0">&x;</ssd:SystemStructureDescription>')
LAUGHS = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol0 "lol">' +
          "".join(f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">' for i in range(1, 10)) +
          ']>\n<r>&lol9;</r>')


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return fmus(tmp_path_factory.mktemp("fmus"))


def check(tmp_path: Path, archive: Path) -> object:
    """`twmr check archive` with the cache in tmp_path/cache; only the cache may change."""
    cache = tmp_path / "cache"
    env = {**__import__("os").environ, "TWMR_CACHE_DIR": str(cache)}
    outcome = run_cli(["check", archive], tmp_path, timeout=120, env=env)
    assert_writes_only_under(outcome, [cache])
    return outcome


def line(text: str, needle: str) -> str:
    """'SystemStructure.ssd:N' for the line of `text` that holds `needle`."""
    return f"SystemStructure.ssd:{text[:text.index(needle)].count(chr(10)) + 1}"


def broken(tmp_path: Path, built: dict[str, Path], ssd: str, ssv: str | None = None) -> Path:
    return zipped(package(tmp_path / "pkg", ssd, built, ssv), tmp_path / "x.ssp")


CASES = {
    "malformed XML": (lambda: linear_ssd()[:-40], None,
                      ["SystemStructure.ssd:", "not well-formed XML"]),
    "XXE": (lambda: XXE, None, ["SystemStructure.ssd:2", "DOCTYPE"]),
    "entity bomb": (lambda: LAUGHS, None, ["SystemStructure.ssd:2", "ENTITY"]),
    "connector that does not exist": (
        lambda: linear_ssd().replace('endElement="integ" endConnector="u"',
                                     'endElement="integ" endConnector="nope"'),
        None, ["@endConnector=\"nope\"", "sub.integ", "no connector 'nope'"]),
    "element that does not exist": (
        lambda: linear_ssd().replace('startElement="source"', 'startElement="ghost"'),
        None, ["@ghost", "no element 'ghost'"]),
    "unit that cannot be converted": (lambda: linear_ssd(units=("s", "m")), None,
                                      ["@startConnector=\"u\"", "unit mismatch", "'s'"]),
    ".ssv value of the wrong type": (
        lambda: linear_ssd(), values_ssv(value='<ssv:Boolean value="true"/>'),
        ["values.ssv:5", "ssv:Boolean", "source.value", "Real"]),
    ".ssv value that is not a number": (
        lambda: linear_ssd(), values_ssv(k='<ssv:Real value="fast"/>'),
        ["values.ssv:6", "schema", "fast"]),
    "component that is not an FMU": (
        lambda: linear_ssd().replace('<ssd:Component name="source"',
                                     '<ssd:Component name="source" type="text/x-python"'),
        None, ["@text/x-python", "source", "not an FMU"]),
    "signal dictionary": (
        lambda: linear_ssd().replace(
            "    </ssd:Connections>\n  </ssd:System>",
            '    </ssd:Connections>\n    <ssd:SignalDictionaries><ssd:SignalDictionary '
            'name="d" source="resources/d.ssb"/></ssd:SignalDictionaries>\n  </ssd:System>'),
        None, ["@SignalDictionaries", "signal dictionaries"]),
    "binding source outside the package": (
        lambda: linear_ssd().replace("resources/values.ssv", "../../../../etc/hostname"),
        None, ["@etc/hostname", "outside the package"]),
    "element not of the schema": (
        lambda: linear_ssd().replace("<ssd:Elements>", "<ssd:Elements><ssd:Gadget/>", 1),
        None, ["@Gadget", "schema", "Gadget"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_ssp_content_is_refused_in_one_paragraph(built, tmp_path, case) -> None:
    make, ssv, mentions = CASES[case]
    ssd = make()
    outcome = check(tmp_path, broken(tmp_path, built, ssd, ssv))
    assert_clean_error(outcome, mentions=["x.ssp/", *[line(ssd, m[1:]) if m[0] == "@" else m
                                                      for m in mentions]])


def test_a_missing_fmu_is_named(built, tmp_path) -> None:
    folder = package(tmp_path / "pkg", linear_ssd(), built, fmus_=("constant",))
    outcome = check(tmp_path, zipped(folder, tmp_path / "x.ssp"))
    assert_clean_error(outcome, mentions=[line(linear_ssd(), "resources/integrator.fmu"),
                                          "resources/integrator.fmu",
                                          "neither in the package nor beside it"])


@pytest.mark.parametrize("member", ["../evil.txt", "/tmp/twmr-evil.txt", "a/../../evil.txt"])
def test_zip_slip_members_are_refused_before_anything_is_written(built, tmp_path,
                                                                 member) -> None:
    archive = broken(tmp_path, built, linear_ssd())
    with zipfile.ZipFile(archive, "a") as z:
        z.writestr(member, "owned")
    outcome = check(tmp_path, archive)
    assert_clean_error(outcome, mentions=["x.ssp", member, "zip-slip"])
    assert not (tmp_path / "evil.txt").exists() and not Path("/tmp/twmr-evil.txt").exists()
    assert not list((tmp_path / "cache").rglob("*.fmu"))


def test_a_link_member_is_refused(built, tmp_path) -> None:
    archive = broken(tmp_path, built, linear_ssd())
    info = zipfile.ZipInfo("resources/link.fmu")
    info.external_attr = (0o120777 << 16)
    with zipfile.ZipFile(archive, "a") as z:
        z.writestr(info, "/etc/passwd")
    assert_clean_error(check(tmp_path, archive), mentions=["resources/link.fmu",
                                                           "symbolic link"])


def test_not_a_zip_is_refused(tmp_path) -> None:
    (tmp_path / "x.ssp").write_text("components: {}\n")
    assert_clean_error(check(tmp_path, tmp_path / "x.ssp"), mentions=["x.ssp", "not a zip"])


def test_an_archive_beyond_the_size_limit_is_refused(built, tmp_path, monkeypatch) -> None:
    """A small archive that unpacks big (zeros compress 1000:1) against a lowered limit."""
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(archive, "MAX_UNPACKED_BYTES", 10 * 2**20)
    ssp = broken(tmp_path, built, linear_ssd())
    with zipfile.ZipFile(ssp, "a", zipfile.ZIP_DEFLATED) as z:
        z.writestr("resources/zeros.bin", bytes(20 * 2**20))
    assert ssp.stat().st_size < 2**20
    with pytest.raises(ScenarioError, match="unpacks to more than 10,485,760 bytes"):
        twmr.load(ssp)
    assert not list((tmp_path / "cache").rglob("zeros.bin"))


def test_an_attribute_outside_the_schema_is_a_warning_naming_it(built, tmp_path) -> None:
    ssd = linear_ssd().replace('<ssd:System name="top">', '<ssd:System name="top" color="red">')
    outcome = check(tmp_path, broken(tmp_path, built, ssd))
    assert_ok(outcome)
    assert line(ssd, 'color="red"') in outcome.stderr and "'color'" in outcome.stderr


def test_an_xxe_in_utf16_is_refused_by_the_parser_too() -> None:
    """The byte scan for '<!DOCTYPE' cannot see UTF-16; the parser's document info can."""
    from twmr.fmi.ssp.xmlsafe import parse_xml

    text = XXE.replace('version="1.0"?>', 'version="1.0" encoding="UTF-16"?>', 1)
    with pytest.raises(ScenarioError, match="DOCTYPE or ENTITY"):
        parse_xml(text.encode("utf-16"), "u16.ssd")


@pytest.mark.parametrize(("change", "warning"), [
    (('linear" version="1.0"', 'linear" version="Draft20180219"'), "is not one of the standard's"),
    (('name="y" kind="output"><ssc:Real/></ssd:Connector>\n        </ssd:Connectors>\n'
      '      </ssd:Component>', 'name="y" kind="output"><ssc:Real/></ssd:Connector>\n'
      '          <ssd:Connector name="value" kind="structuralParameter"><ssc:Real/>'
      '</ssd:Connector>\n        </ssd:Connectors>\n      </ssd:Component>'),
     "uses SSP 2.0 content"),
])
def test_departures_other_tools_accept_are_warnings(built, tmp_path, change, warning) -> None:
    ssd = linear_ssd().replace(*change, 1)
    assert ssd != linear_ssd()
    outcome = check(tmp_path, broken(tmp_path, built, ssd))
    assert_ok(outcome)
    assert warning in outcome.stderr and "SystemStructure.ssd" in outcome.stderr


def test_a_run_writes_only_its_results_and_the_unpacked_package(built, tmp_path) -> None:
    archive = broken(tmp_path, built, linear_ssd())
    cache = tmp_path / "cache"
    env = {**__import__("os").environ, "TWMR_CACHE_DIR": str(cache)}
    out = tmp_path / "results" / "x"
    outcome = run_cli(["run", archive, "--out", out, "--quiet", "--set", "experiment.step=0.5"],
                      tmp_path, timeout=180, env=env)
    assert_ok(outcome)
    assert_writes_only_under(outcome, [cache, *result_family(out)])
    assert (out / "summary.json").is_file() and list(cache.glob("ssp/*/SystemStructure.ssd"))


@pytest.mark.parametrize("tamper", ["edit", "add", "remove", "manifest"])
def test_an_unpacked_copy_changed_in_the_cache_is_not_trusted(built, tmp_path, monkeypatch,
                                                              caplog, tamper) -> None:
    """The unpacked folder is checked against the SHA-256 of every file it was unpacked with:
    an edited .ssd (which would change the next run's result), a file added or removed, or a
    manifest not ours make the next load unpack the archive again, with a warning naming it."""
    monkeypatch.setenv("TWMR_CACHE_DIR", str(tmp_path / "cache"))
    ssp = broken(tmp_path, built, linear_ssd())
    folder = archive.unpacked(ssp)
    ssd = folder / "SystemStructure.ssd"
    original = ssd.read_bytes()
    fmu_count = len(list(folder.rglob("*.fmu")))
    if tamper == "edit":
        ssd.write_bytes(original.replace(b'name="', b'name="x', 1))
    elif tamper == "add":
        (folder / "resources" / "extra.fmu").write_bytes(b"PK")
    elif tamper == "remove":
        next(folder.rglob("*.fmu")).unlink()
    else:
        (folder / archive.MANIFEST).write_text("{}")
    with caplog.at_level("WARNING", logger="twmr.fmi.ssp.archive"):
        again = archive.unpacked(ssp)
    assert again == folder and ssd.read_bytes() == original
    assert not (folder / "resources" / "extra.fmu").exists()
    assert len(list(folder.rglob("*.fmu"))) == fmu_count > 0
    assert any("was changed since it was unpacked" in m for m in caplog.messages)
    caplog.clear()
    with caplog.at_level("WARNING", logger="twmr.fmi.ssp.archive"):
        archive.unpacked(ssp)  # as unpacked: trusted, nothing said
    assert not caplog.messages
