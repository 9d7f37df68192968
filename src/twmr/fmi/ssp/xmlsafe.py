"""Untrusted XML read safely: no DTD, no entity expansion, no network, a size limit.

An SSP file comes from anywhere: a DOCTYPE (the door to XXE and entity bombs) is refused before
anything is expanded, and a syntax error is reported with its file and line."""
from __future__ import annotations

from typing import Any

from lxml import etree

from twmr.core.errors import Location, Problem, ScenarioError

#: the largest XML file read (bytes)
MAX_XML_BYTES = 32 * 2**20

NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "ssm": "http://ssp-standard.org/SSP1/SystemStructureParameterMapping",
      "ssb": "http://ssp-standard.org/SSP1/SystemStructureSignalDictionary",
      # libcosim's annotations, and ours (base step, algorithm, recording; `twmr export`)
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
      "twmr": "https://twmr-cosim.org/SSP/Annotations"}
_PREFIX = {uri: prefix for prefix, uri in NS.items()}


def parser() -> etree.XMLParser:
    """An lxml parser that loads no DTD, expands no entity and reaches no network."""
    return etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False,
                           dtd_validation=False, huge_tree=False, remove_pis=True)


def parse_xml(data: bytes, source: str) -> Any:
    """The root element of XML `data` read from `source` (named in errors)."""
    if len(data) > MAX_XML_BYTES:
        raise ScenarioError(Problem(Location(source), f"the XML file is {len(data):,} bytes, more "
                                    f"than the limit of {MAX_XML_BYTES:,}.",
                                    "an SSP description is a few kilobytes to megabytes; check "
                                    "that this is the right file."))
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        line = data[:max(data.find(b"<!DOCTYPE"), data.find(b"<!ENTITY"))].count(b"\n") + 1
        raise _doctype(source, line)
    try:
        root = etree.fromstring(data, parser())
    except etree.XMLSyntaxError as err:
        line = err.lineno or 0
        raise ScenarioError(Problem(Location(source, line), f"the file is not well-formed XML "
                                    f"({err.msg}).", "repair the XML (an XML editor or "
                                    "`xmllint --noout` shows where).")) from None
    if root.getroottree().docinfo.doctype:
        raise _doctype(source, 1)
    return root


def _doctype(source: str, line: int) -> ScenarioError:
    return ScenarioError(Problem(Location(source, line), "the XML has a DOCTYPE or ENTITY "
                                 "declaration; SSP files have none, and entities are how XXE and "
                                 "entity-bomb attacks work, so it is not read.",
                                 "remove the <!DOCTYPE ...> / <!ENTITY ...> declarations."))


def tag(element: Any) -> str:
    """An element's name as written with the standard prefixes, e.g. 'ssd:Connection'."""
    q = etree.QName(element)
    prefix = _PREFIX.get(q.namespace or "")
    return f"{prefix}:{q.localname}" if prefix else q.localname


def at(source: str, element: Any, what: str = "") -> Location:
    """Where `element` is: the file, its line, and what it is (default: its tag)."""
    return Location(source, int(element.sourceline or 0), what or tag(element))
