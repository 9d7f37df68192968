"""SSP files checked against the standard's XML schemas (shipped in `schemas/`, SSP 1.0 and 2.0).

A file is validated by the schema of the version it declares. Departures that other tools accept
are warnings naming the departure: a `version` that is not '1.0' / '2.0' (drafts), SSP 2.0
content in a file that says 1.0, and attributes the schema does not define. Every other
departure is an error naming the file, line and element."""
from __future__ import annotations

import logging
from functools import lru_cache
from pathlib import Path
from typing import Any

from lxml import etree

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.fmi.ssp.xmlsafe import NS, tag

log = logging.getLogger("twmr")

#: the shipped XSD files (schemas/README.md names their origin and licence)
SCHEMAS = Path(__file__).parent / "schemas"

_FILES = {"ssd": "SystemStructureDescription", "ssv": "SystemStructureParameterValues",
          "ssm": "SystemStructureParameterMapping", "ssb": "SystemStructureSignalDictionary"}
#: lxml error types of departures accepted with a warning (an attribute the schema lacks)
_TOLERATED = {"SCHEMAV_CVC_COMPLEX_TYPE_3_2_1", "SCHEMAV_CVC_COMPLEX_TYPE_3_2_2"}


@lru_cache(maxsize=2)
def schema(edition: str) -> etree.XMLSchema:
    """The schema of every SSP file kind of `edition` ('ssp1' or 'ssp2'), one driver importing
    the shipped files (inline parameter sets inside an .ssd are checked too)."""
    folder = SCHEMAS / edition
    imports = "".join(f'<xs:import namespace="{NS[prefix]}" '
                      f'schemaLocation="{(folder / (name + ".xsd")).as_uri()}"/>'
                      for prefix, name in _FILES.items())
    driver = (f'<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema">{imports}</xs:schema>')
    return etree.XMLSchema(etree.fromstring(driver.encode()))


def validate(root: Any, source: str) -> None:
    """Check the root element read from `source` against the schema of its declared version;
    warnings for accepted departures, ScenarioError listing the others."""
    version = root.get("version", "")
    edition = "ssp2" if version.startswith("2") else "ssp1"
    checker = schema(edition)
    if checker.validate(root):
        return
    errors = list(checker.error_log)
    if edition == "ssp1" and schema("ssp2").validate(root):
        log.warning("warning: %s: the file says SSP version %r but uses SSP 2.0 content (%s); "
                    "it is read as SSP 2.0.", source, version, _first(errors))
        return
    bad_version = [e for e in errors if "'version'" in e.message and e.line == root.sourceline]
    if bad_version:
        log.warning("warning: %s:%d: %s version %r is not one of the standard's ('1.0', "
                    "'2.0'); it is read as SSP %s.", source, root.sourceline, tag(root), version,
                    "2.0" if edition == "ssp2" else "1.0")
    rest = [e for e in errors if e not in bad_version]
    for e in (e for e in rest if e.type_name in _TOLERATED):
        log.warning("warning: %s:%d: %s; the attribute is ignored (other SSP tools accept it).",
                    source, e.line, _plain(e.message))
    fatal = [e for e in rest if e.type_name not in _TOLERATED]
    if fatal:
        raise ScenarioError([Problem(Location(source, e.line, e.path.rsplit("/", 1)[-1]),
                                     f"the file does not follow the SSP "
                                     f"{'2.0' if edition == 'ssp2' else '1.0'} schema: "
                                     f"{_plain(e.message)}.",
                                     "correct the element as the SSP standard defines it "
                                     "(src/twmr/fmi/ssp/schemas/ holds the schemas).")
                             for e in fatal[:20]])


def _plain(message: str) -> str:
    """An lxml schema message with the namespaces written as the standard's prefixes."""
    for prefix, uri in NS.items():
        message = message.replace("{" + uri + "}", prefix + ":")
    return message.rstrip(".")


def _first(errors: list[Any]) -> str:
    return f"line {errors[0].line}: {_plain(errors[0].message)}" if errors else "?"
